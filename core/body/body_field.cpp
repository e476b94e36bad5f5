#include "core/body/body_field.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <nanoflann.hpp>

namespace kgd {
namespace {
std::atomic<long> g_build_count{0};

struct PointCloud {
  const Positions* points;
  size_t kdtree_get_point_count() const { return points->rows(); }
  double kdtree_get_pt(size_t i, size_t dim) const { return (*points)(i, dim); }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const { return false; }
};
}  // namespace

struct BodyField::Index {
  PointCloud cloud;
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointCloud>, PointCloud, 3, int>;
  std::unique_ptr<Tree> tree;
};

BodyField::~BodyField() = default;

long BodyField::BuildCount() { return g_build_count.load(); }

Result<std::shared_ptr<const BodyField>> BodyField::Build(const Positions& body_vertices, const Faces& body_faces,
                                                          const BodyFieldSettings& settings) {
  if (Status s = ValidateMesh(body_vertices, body_faces, "body"); !s.ok()) return s;
  if (!(settings.support_scale > 0)) return Status::Error("body field: support_scale must be > 0");
  std::shared_ptr<BodyField> field(new BodyField());
  field->vertices_ = body_vertices;
  field->normals_ = AreaWeightedVertexNormals(body_vertices, body_faces);
  const Eigen::VectorXd ring = OneRingMeanEdgeLength(body_vertices, body_faces);
  field->h2_.resize(ring.size());
  field->inv_h2_.resize(ring.size());
  double sum_h = 0;
  int used = 0;
  for (Eigen::Index k = 0; k < ring.size(); ++k) {
    const double h = settings.support_scale * ring[k];
    field->h2_[k] = h * h;  // isolated vertices (no faces) get h = 0: they never contribute
    field->inv_h2_[k] = h > 0 ? 1.0 / (h * h) : 0.0;
    field->max_h_ = std::max(field->max_h_, h);
    if (h > 0) { sum_h += h; ++used; }
  }
  field->mean_h_ = used ? sum_h / used : 0;
  // The margin trades the candidates' count (every evaluation tests each one) against how often a list
  // is rebuilt (a k-d tree query). A BESO re-solve moves the cloth millimetres, well inside a quarter of
  // the support radius; at half of it two thirds of the candidates failed the support test, and
  // evaluating the field took a fifth longer (docs/PERFORMANCE.md).
  field->margin_ = settings.cache_margin_m > 0 ? settings.cache_margin_m : 0.25 * field->mean_h_;
  field->index_ = std::make_unique<Index>();
  field->index_->cloud.points = &field->vertices_;
  field->index_->tree = std::make_unique<Index::Tree>(3, field->index_->cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  field->index_->tree->buildIndex();
  ++g_build_count;
  return std::shared_ptr<const BodyField>(std::move(field));
}

void BodyField::RefreshCache(const Eigen::Vector3d& x, NeighborCache* cache) const {
  const double r = max_h_ + margin_;
  std::vector<std::pair<int, double>> found;
  nanoflann::SearchParams params;
  params.sorted = false;
  index_->tree->radiusSearch(x.data(), r * r, found, params);  // nanoflann's L2 radius is squared
  cache->candidates.clear();
  for (const auto& [k, d2] : found) {
    if (!(h2_[k] > 0)) continue;  // an isolated vertex has no kernel
    const double reach = std::sqrt(h2_[k]) + margin_;
    if (d2 < reach * reach) cache->candidates.push_back(k);
  }
  // The tree returns neighbours in an order that depends on the query point; index order makes the
  // field's sums independent of where the cache was built (bit-identical resumed BESO runs).
  std::sort(cache->candidates.begin(), cache->candidates.end());
  cache->center = x;
  ++cache->rebuilds;
}

FieldSample BodyField::Evaluate(const Eigen::Vector3d& x, NeighborCache* cache, bool want_grad, bool want_hess) const {
  // The cache is valid while x stays within the margin of where it was built (NaN center: never built).
  if (!((x - cache->center).squaredNorm() <= margin_ * margin_)) RefreshCache(x, cache);
  // Sums over the support of the kernel phi = (1 - q)^4, q = |d|^2 / h^2, d = x - x_k, and of its
  // derivatives dphi = -s d and hphi = c d d^T - s I with s = 8 (1-q)^3 / h^2, c = 48 (1-q)^2 / h^4:
  //   D = sum phi, N = sum phi g (g = n_k . d),
  //   dD = -sum s d, dN = sum (phi n_k - s g d),
  //   hD = sum c d d^T - (sum s) I,  hN = sum c g d d^T - (sum s g) I - (Q + Q^T), Q = sum s d n_k^T.
  // Summing the rank-one parts and adding the identity terms once halves the Hessian's arithmetic.
  double D = 0, N = 0, S = 0, SG = 0;
  Eigen::Vector3d dD = Eigen::Vector3d::Zero(), dN = Eigen::Vector3d::Zero();
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero(), B = Eigen::Matrix3d::Zero(), Q = Eigen::Matrix3d::Zero();
  for (int k : cache->candidates) {
    const Eigen::Vector3d d = x - vertices_.row(k).transpose();
    // Multiplying by the stored 1/h^2 rather than dividing: this loop is the contact's hot spot, and
    // many candidates fail the support test (the cache margin keeps some spare).
    const double inv_h2 = inv_h2_[k];
    const double q = d.squaredNorm() * inv_h2;
    if (q >= 1.0) continue;
    const double t = 1.0 - q, t2 = t * t, t3 = t2 * t;
    const double phi = t2 * t2;
    const Eigen::Vector3d n = normals_.row(k).transpose();
    const double g = n.dot(d);
    D += phi;
    N += phi * g;
    if (!want_grad && !want_hess) continue;
    const double s_k = 8.0 * t3 * inv_h2;
    const Eigen::Vector3d sd = s_k * d;
    dD -= sd;
    dN += phi * n - g * sd;
    if (want_hess) {
      const Eigen::Vector3d cd = (48.0 * t2 * inv_h2 * inv_h2) * d;
      S += s_k;
      SG += s_k * g;
      A.noalias() += cd * d.transpose();
      B.noalias() += (g * cd) * d.transpose();
      Q.noalias() += sd * n.transpose();
    }
  }
  FieldSample s;
  // A vanishing kernel sum is where Phi stops being defined; below 1e-300 a division would overflow.
  if (!(D > 1e-300)) return s;
  s.supported = true;
  s.phi_m = N / D;
  if (want_grad || want_hess) s.grad = (dN - s.phi_m * dD) / D;
  if (want_hess) {
    const Eigen::Matrix3d hD = A - S * Eigen::Matrix3d::Identity();
    const Eigen::Matrix3d hN = B - SG * Eigen::Matrix3d::Identity() - Q - Q.transpose();
    s.hess = (hN - s.grad * dD.transpose() - dD * s.grad.transpose() - s.phi_m * hD) / D;
  }
  return s;
}

Result<Positions> PlaceOnZeroSet(const BodyField& field, const Positions& points, const std::string& what) {
  constexpr double kTolerance_m = 1e-12;
  constexpr int kMaxSteps = 50;
  const double max_step = 0.25 * field.mean_support_radius_m();
  Positions out = points;
  NeighborCache cache;
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    Eigen::Vector3d x = points.row(i).transpose();
    FieldSample s = field.Evaluate(x, &cache, true, false);
    int steps = 0;
    for (; s.supported && std::abs(s.phi_m) > kTolerance_m && steps < kMaxSteps; ++steps) {
      const double g2 = s.grad.squaredNorm();
      if (!(g2 > 1e-12)) break;
      Eigen::Vector3d step = -s.phi_m / g2 * s.grad;
      if (step.norm() > max_step) step *= max_step / step.norm();
      x += step;
      s = field.Evaluate(x, &cache, true, false);
    }
    auto where = [&] {
      char buf[160];
      std::snprintf(buf, sizeof buf, " %ld at (%.6g, %.6g, %.6g) m", static_cast<long>(i), points(i, 0), points(i, 1), points(i, 2));
      return what + buf;
    };
    if (!s.supported)
      return Status::Error(where() + ": is farther from the body than the body field's support (about " +
                           std::to_string(field.mean_support_radius_m()) + " m), so it cannot be placed on the body surface");
    if (!(std::abs(s.phi_m) <= kTolerance_m))
      return Status::Error(where() + ": cannot be placed on the body surface (Phi = " + std::to_string(s.phi_m) + " m after " +
                           std::to_string(steps) + " steps)");
    out.row(i) = x.transpose();
  }
  return out;
}

}  // namespace kgd
