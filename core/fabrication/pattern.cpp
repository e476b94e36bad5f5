#include "core/fabrication/pattern.h"

// CGAL's parameterization with Eigen's sparse solvers.
#ifndef CGAL_EIGEN3_ENABLED
#define CGAL_EIGEN3_ENABLED
#endif
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/LSCM_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Error_code.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <array>
#include <queue>
#include <set>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <Eigen/SparseCholesky>

#include "core/fabrication/sew_line.h"
#include "core/mesh/topology.h"

namespace kgd {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace SMP = CGAL::Surface_mesh_parameterization;

double CornerAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d u = b - a, v = c - a;
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

using EdgeKey = std::pair<int, int>;
EdgeKey Key(int a, int b) { return a < b ? EdgeKey{a, b} : EdgeKey{b, a}; }

// Shortest path along edges from any vertex of `from` to any vertex of `to` (vertex sequence), with
// edge cost = length x (1 + weight of the faces beside it).
std::vector<int> ShortestPath(const Positions& x, const std::vector<std::vector<std::pair<int, double>>>& graph, const std::vector<char>& from,
                              const std::vector<char>& to) {
  const int n = static_cast<int>(graph.size());
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  std::vector<int> prev(n, -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (int v = 0; v < n; ++v)
    if (from[v]) dist[v] = 0, queue.push({0, v});
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist[v]) continue;
    if (to[v]) {
      std::vector<int> path;
      for (int u = v; u >= 0; u = prev[u]) path.push_back(u);
      std::reverse(path.begin(), path.end());
      return path;
    }
    for (const auto& [u, w] : graph[v])
      if (d + w < dist[u]) dist[u] = d + w, prev[u] = v, queue.push({dist[u], u});
  }
  (void)x;
  return {};
}

// The flat coordinates of a planar piece in its own plane (exact), or nothing if it is not planar.
std::optional<FlatPositions> InPlane(const Positions& x) {
  const Eigen::RowVector3d c = x.colwise().mean();
  const Eigen::MatrixXd centred = x.rowwise() - c;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(centred, Eigen::ComputeThinV);
  const double size = svd.singularValues()(0);
  if (!(size > 0) || svd.singularValues()(2) > 1e-12 * size) return std::nullopt;
  FlatPositions uv = centred * svd.matrixV().leftCols(2);
  return uv;
}

// One edge of a piece's outline sewn to another's: the flat edge (a0 -> a1) of piece `piece_a` and
// (b0 -> b1) of piece `piece_b` (possibly the same piece) are the same garment edge.
struct SewnEdges {
  int piece_a, a0, a1;
  int piece_b, b0, b1;
};

// Whether pieces of these distortions (after a refinement's first steps) are worth finishing.
using Hopeless = std::function<bool(const std::vector<Distortion>&)>;

// The target a triangle's flat map is pulled towards, from the map's singular values s1 >= s2: the
// area-preserving stretch diag(t, 1/t) nearest to them, held towards a rotation by `rigidity`
// (minimizes (s1 - t)^2 + (s2 - 1/t)^2 + rigidity ((t - 1)^2 + (1/t - 1)^2) over t >= 1). Fabric
// sewn back onto the body takes up shear far more readily than a change of area, so the refinement
// keeps areas first and angles second.
double AreaPreservingStretch(double s1, double s2, double rigidity, double t) {
  t = std::max(t, 1.0);
  for (int i = 0; i < 8; ++i) {
    const double inv = 1 / t, inv2 = inv * inv, inv3 = inv2 * inv, inv4 = inv2 * inv2;
    const double g1 = -2 * (s1 - t) + 2 * (s2 * inv2 - inv3) + 2 * rigidity * (t - 1) - 2 * rigidity * (inv3 - inv2);
    const double g2 = 2 + 2 * (-2 * s2 * inv3 + 3 * inv4) + 2 * rigidity - 2 * rigidity * (-3 * inv4 + 2 * inv3);
    const double step = g2 > 0 ? g1 / g2 : g1;
    t = std::clamp(t - step, 1.0, 1.0 + 4 * (std::abs(s1) + 1));
    if (std::abs(step) < 1e-12) break;
  }
  return t;
}

// Local/global refinement of several pieces at once (Liu et al. 2008, with the area-preserving local
// step above), each with a free boundary and free scale, and every sewn pair of outline edges pulled to
// a common length (the mean of the two), so that the two sides of a seam sew together.
class JointRefinement {
 public:
  JointRefinement(const std::vector<const Positions*>& rest, const std::vector<const Faces*>& faces, std::vector<SewnEdges> sewn)
      : sewn_(std::move(sewn)) {
    for (size_t p = 0; p < rest.size(); ++p) {
      pieces_.push_back(std::make_unique<Piece>());
      Prepare(*rest[p], *faces[p], p);
    }
  }

  bool ok() const { return ok_; }

  // Refines `uv` (one per piece) in place: local/global steps, accelerated by Anderson mixing of the
  // last few steps (Peng et al. 2018), each mixed step kept only if it lowers the energy (otherwise the
  // plain step, which always does, and the history restarts).
  void Run(std::vector<FlatPositions*> uv, int iterations) {
    offset_.assign(1, 0);
    for (FlatPositions* f : uv) offset_.push_back(offset_.back() + 2 * f->rows());
    // FlatPositions is row-major: vertex v's (u, w) at 2v, 2v + 1 of its piece's segment.
    Eigen::VectorXd x(offset_.back());
    for (size_t p = 0; p < uv.size(); ++p) x.segment(offset_[p], 2 * uv[p]->rows()) = Eigen::Map<const Eigen::VectorXd>(uv[p]->data(), 2 * uv[p]->rows());
    double energy = LocalStep(x);
    constexpr int kHistory = 6;
    std::vector<Eigen::VectorXd> df, dg;
    Eigen::VectorXd f_prev, g_prev;
    for (int it = 0; it < iterations; ++it) {
      const Eigen::VectorXd g = GlobalStep();
      if (!g.allFinite()) break;
      const Eigen::VectorXd f = g - x;
      // Converged to a micrometre: far below what a cutter resolves (about 25 micrometres).
      if (f.cwiseAbs().maxCoeff() < 1e-6) {
        x = g;
        break;
      }
      Eigen::VectorXd next = g;
      if (f_prev.size()) {
        df.push_back(f - f_prev), dg.push_back(g - g_prev);
        if (static_cast<int>(df.size()) > kHistory) df.erase(df.begin()), dg.erase(dg.begin());
        Eigen::MatrixXd mf(f.size(), df.size()), mg(g.size(), dg.size());
        for (size_t k = 0; k < df.size(); ++k) mf.col(k) = df[k], mg.col(k) = dg[k];
        const Eigen::VectorXd gamma = mf.colPivHouseholderQr().solve(f);
        if (gamma.allFinite()) next = g - mg * gamma;
      }
      f_prev = f, g_prev = g;
      double next_energy = LocalStep(next);
      if (!(next_energy <= energy)) {
        next = g;
        next_energy = LocalStep(next);
        df.clear(), dg.clear();
      }
      x = std::move(next);
      energy = next_energy;
    }
    for (size_t p = 0; p < uv.size(); ++p) Eigen::Map<Eigen::VectorXd>(uv[p]->data(), 2 * uv[p]->rows()) = x.segment(offset_[p], 2 * uv[p]->rows());
  }

 private:
  // Sewn edges are held to their common length about as stiffly as a few hundred triangles' worth of
  // cloth: their sides then agree to a few micrometres per edge.
  static constexpr double kSewnWeight = 200;
  static constexpr double kPin = 1e8;  // vertex 0 of each piece stays put (translation)
  // How strongly the local step holds angles against areas (see AreaPreservingStretch): on the built-in
  // and MakeHuman sleeves, 0.1 keeps every face's area within 5 % and the mean angle change within 2
  // degrees (0.15 lets a face at the elbow stretch 5.8 %).
  static constexpr double kRigidity = 0.1;

  struct Piece {
    const Faces* faces = nullptr;
    std::vector<std::array<Eigen::Vector2d, 3>> local;  // each rest triangle in a 2D frame of its own
    std::vector<std::array<double, 3>> cot;             // half-cotangent of the angle opposite edge (k, k+1)
    std::vector<Eigen::Matrix2d> rest_inverse;          // inverse of the rest edge matrix [e1 e2]
    std::vector<Eigen::Matrix2d> target;
    std::vector<double> area;                           // rest area (m^2)
    std::vector<double> energy;                         // each triangle's share of the last local step's energy
    std::vector<double> stretch;                        // the local step's last t, a warm start
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  };

  void Prepare(const Positions& x, const Faces& faces, size_t p) {
    Piece& piece = *pieces_[p];
    piece.faces = &faces;
    const int nv = static_cast<int>(x.rows()), nf = static_cast<int>(faces.rows());
    piece.local.resize(nf);
    piece.cot.resize(nf);
    piece.rest_inverse.resize(nf);
    piece.target.assign(nf, Eigen::Matrix2d::Identity());
    piece.stretch.assign(nf, 1.0);
    piece.area.resize(nf);
    std::vector<Eigen::Triplet<double>> triplets;
    auto edge = [&](int i, int j, double w) {
      triplets.push_back({i, i, w});
      triplets.push_back({j, j, w});
      triplets.push_back({i, j, -w});
      triplets.push_back({j, i, -w});
    };
    for (int f = 0; f < nf; ++f) {
      const Eigen::Vector3d a = x.row(faces(f, 0)), b = x.row(faces(f, 1)), c = x.row(faces(f, 2));
      const Eigen::Vector3d e1 = (b - a).normalized(), n = (b - a).cross(c - a);
      const Eigen::Vector3d e2 = n.cross(b - a).normalized();
      piece.local[f] = {Eigen::Vector2d(0, 0), Eigen::Vector2d((b - a).norm(), 0), Eigen::Vector2d((c - a).dot(e1), (c - a).dot(e2))};
      Eigen::Matrix2d m;
      m << piece.local[f][1] - piece.local[f][0], piece.local[f][2] - piece.local[f][0];
      piece.area[f] = 0.5 * std::abs(m.determinant());
      piece.rest_inverse[f] = std::abs(m.determinant()) > 0 ? Eigen::Matrix2d(m.inverse()) : Eigen::Matrix2d::Zero();
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector2d& q = piece.local[f][(k + 2) % 3];
        const Eigen::Vector2d u = piece.local[f][k] - q, v = piece.local[f][(k + 1) % 3] - q;
        const double cross = u.x() * v.y() - u.y() * v.x();
        piece.cot[f][k] = cross != 0 ? 0.5 * u.dot(v) / std::abs(cross) : 0;
        edge(faces(f, k), faces(f, (k + 1) % 3), piece.cot[f][k]);
      }
    }
    for (const SewnEdges& e : sewn_) {
      if (e.piece_a == static_cast<int>(p)) edge(e.a0, e.a1, kSewnWeight);
      if (e.piece_b == static_cast<int>(p)) edge(e.b0, e.b1, kSewnWeight);
    }
    triplets.push_back({0, 0, kPin});
    Eigen::SparseMatrix<double> laplacian(nv, nv);
    laplacian.setFromTriplets(triplets.begin(), triplets.end());
    piece.solver.compute(laplacian);
    ok_ = ok_ && piece.solver.info() == Eigen::Success;
  }

  // The targets of every triangle (its flat map's nearest area-preserving stretch, in closed form for
  // 2x2) and of every sewn pair (their common length along each one's direction), for the positions
  // `x`; returns the energy at `x` with these targets. Keeps `x` for the global step.
  double LocalStep(const Eigen::VectorXd& x) {
    x_ = x;
    double energy = 0;
    for (size_t p = 0; p < pieces_.size(); ++p) {
      Piece& piece = *pieces_[p];
      const Faces& faces = *piece.faces;
      auto at = [&](int v) { return Point(x, p, v); };
      piece.energy.resize(faces.rows());
#pragma omp parallel for schedule(static)
      for (Eigen::Index f = 0; f < faces.rows(); ++f) {
        Eigen::Matrix2d d;
        d << at(faces(f, 1)) - at(faces(f, 0)), at(faces(f, 2)) - at(faces(f, 0));
        const Eigen::Matrix2d j = d * piece.rest_inverse[f];
        // j = rot(phi) diag(s1, s2) rot(theta), s1 >= |s2| (s2 < 0: the triangle is flipped); its
        // rotation r = rot(phi + theta) and j = r p with p symmetric, eigenvalues s1, s2. The target
        // r (a + b p) has p's eigenvectors and eigenvalues t, 1/t: a + b s1 = t, a + b s2 = 1/t.
        const double e = 0.5 * (j(0, 0) + j(1, 1)), fm = 0.5 * (j(0, 0) - j(1, 1));
        const double g = 0.5 * (j(1, 0) + j(0, 1)), h = 0.5 * (j(1, 0) - j(0, 1));
        const double q = std::sqrt(e * e + h * h), r = std::sqrt(fm * fm + g * g);
        const double s1 = q + r, s2 = q - r;
        const double t = piece.stretch[f] = AreaPreservingStretch(s1, s2, kRigidity, piece.stretch[f]);
        Eigen::Matrix2d rotation = Eigen::Matrix2d::Identity();
        if (q > 0) rotation << e / q, -h / q, h / q, e / q;
        if (r > 1e-12 * q) {
          const double b = (t - 1 / t) / (2 * r), a = t - b * s1;
          piece.target[f] = a * rotation + b * j;
        } else {
          piece.target[f] = rotation;  // j is a rotation scaled alike in every direction
        }
        piece.energy[f] = piece.area[f] * ((s1 - t) * (s1 - t) + (s2 - 1 / t) * (s2 - 1 / t) + kRigidity * ((t - 1) * (t - 1) + (1 / t - 1) * (1 / t - 1)));
      }
      // Summed in order, so that the same input gives the same pattern on any number of threads.
      for (double e : piece.energy) energy += e;
    }
    sewn_target_.resize(sewn_.size());
    for (size_t i = 0; i < sewn_.size(); ++i) {
      const SewnEdges& e = sewn_[i];
      const Eigen::Vector2d da = Edge(x, e.piece_a, e.a0, e.a1), db = Edge(x, e.piece_b, e.b0, e.b1);
      const double la = da.norm(), lb = db.norm(), common = 0.5 * (la + lb);
      sewn_target_[i] = {la > 0 ? Eigen::Vector2d(common / la * da) : da, lb > 0 ? Eigen::Vector2d(common / lb * db) : db};
      energy += kSewnWeight * 0.5 * (la - lb) * (la - lb);
    }
    return energy;
  }

  Eigen::Vector2d Point(const Eigen::VectorXd& x, size_t p, int v) const { return x.segment<2>(offset_[p] + 2 * v); }
  Eigen::Vector2d Edge(const Eigen::VectorXd& x, int p, int v0, int v1) const { return Point(x, p, v0) - Point(x, p, v1); }

  // The positions minimizing the energy for the last local step's targets, each piece's vertex 0 held.
  Eigen::VectorXd GlobalStep() const {
    std::vector<Eigen::MatrixX2d> rhs(pieces_.size());
    const int n = static_cast<int>(pieces_.size());
#pragma omp parallel for schedule(dynamic)
    for (int p = 0; p < n; ++p) {
      const Piece& piece = *pieces_[p];
      const Faces& faces = *piece.faces;
      rhs[p] = Eigen::MatrixX2d::Zero((offset_[p + 1] - offset_[p]) / 2, 2);
      for (Eigen::Index f = 0; f < faces.rows(); ++f)
        for (int k = 0; k < 3; ++k) {
          const int i = faces(f, k), j = faces(f, (k + 1) % 3);
          const Eigen::Vector2d r = piece.cot[f][k] * piece.target[f] * (piece.local[f][k] - piece.local[f][(k + 1) % 3]);
          rhs[p].row(i) += r.transpose();
          rhs[p].row(j) -= r.transpose();
        }
    }
    for (size_t i = 0; i < sewn_.size(); ++i) {
      const SewnEdges& e = sewn_[i];
      const Eigen::Vector2d ta = kSewnWeight * sewn_target_[i].first, tb = kSewnWeight * sewn_target_[i].second;
      rhs[e.piece_a].row(e.a0) += ta.transpose();
      rhs[e.piece_a].row(e.a1) -= ta.transpose();
      rhs[e.piece_b].row(e.b0) += tb.transpose();
      rhs[e.piece_b].row(e.b1) -= tb.transpose();
    }
    Eigen::VectorXd next(x_.size());
#pragma omp parallel for schedule(dynamic)
    for (int p = 0; p < n; ++p) {
      rhs[p](0, 0) += kPin * x_[offset_[p]];
      rhs[p](0, 1) += kPin * x_[offset_[p] + 1];
      const Eigen::MatrixX2d solved = pieces_[p]->solver.solve(rhs[p]);
      for (Eigen::Index v = 0; v < solved.rows(); ++v) next[offset_[p] + 2 * v] = solved(v, 0), next[offset_[p] + 2 * v + 1] = solved(v, 1);
    }
    return next;
  }

  std::vector<SewnEdges> sewn_;
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> sewn_target_;
  std::vector<std::unique_ptr<Piece>> pieces_;
  std::vector<Eigen::Index> offset_;  // piece p's positions start at x[offset_[p]]
  Eigen::VectorXd x_;                 // the last local step's positions
  bool ok_ = true;
};

}  // namespace

double SignedArea(const FlatPositions& p) {
  double a = 0;
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    const Eigen::Index j = (i + 1) % p.rows();
    a += p(i, 0) * p(j, 1) - p(j, 0) * p(i, 1);
  }
  return 0.5 * a;
}

Distortion MeasureDistortion(const Positions& x, const Faces& faces, const FlatPositions& uv) {
  Distortion d;
  double total = 0;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    Eigen::Vector3d p[3], q[3];
    for (int k = 0; k < 3; ++k) {
      p[k] = x.row(faces(f, k)).transpose();
      q[k] = Eigen::Vector3d(uv(faces(f, k), 0), uv(faces(f, k), 1), 0);
    }
    const double a3 = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).norm();
    const double a2 = 0.5 * (q[1] - q[0]).cross(q[2] - q[0]).z();
    if (!(a3 > 0)) continue;
    const double area = std::abs(a2 / a3 - 1);
    double angle = 0;
    for (int k = 0; k < 3; ++k)
      angle = std::max(angle, std::abs(CornerAngle(p[k], p[(k + 1) % 3], p[(k + 2) % 3]) - CornerAngle(q[k], q[(k + 1) % 3], q[(k + 2) % 3])));
    angle *= 180 / M_PI;
    if (a2 <= 0) angle = 180;  // a flipped triangle
    // Round-off of an exact (planar) piece is no distortion.
    const double area_noise = 1e-12, angle_noise = 1e-9;
    const double area_d = area < area_noise ? 0 : area;
    if (angle < angle_noise) angle = 0;
    d.area_mean += a3 * area_d;
    d.angle_mean_deg += a3 * angle;
    d.area_max = std::max(d.area_max, area_d);
    d.angle_max_deg = std::max(d.angle_max_deg, angle);
    total += a3;
  }
  if (total > 0) d.area_mean /= total, d.angle_mean_deg /= total;
  return d;
}

namespace {

// A piece's flat start: its own plane, exactly, if it is planar (`planar` set); otherwise `warm` when
// given, else CGAL's least-squares conformal map scaled to the rest area. Counter-clockwise faces stay
// counter-clockwise.
Result<FlatPositions> InitialFlat(const Positions& x, const Faces& faces, const FlatPositions& warm, bool* planar) {
  if (faces.rows() == 0) return Status::Error("flatten: the piece has no faces");
  if (EulerCharacteristic(faces) != 1 || BoundaryLoops(faces).size() != 1)
    return Status::Error("flatten: the piece is not a disk (Euler characteristic " + std::to_string(EulerCharacteristic(faces)) + ", " +
                         std::to_string(BoundaryLoops(faces).size()) + " boundary loops)");
  auto orient = [&](FlatPositions* uv) {
    double signed_area = 0;
    for (Eigen::Index f = 0; f < faces.rows(); ++f) {
      const Eigen::Vector2d a = uv->row(faces(f, 0)), b = uv->row(faces(f, 1)), c = uv->row(faces(f, 2));
      signed_area += (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    }
    if (signed_area < 0) uv->col(0) *= -1;
  };
  *planar = false;
  if (std::optional<FlatPositions> plane = InPlane(x)) {
    orient(&*plane);
    *planar = true;
    return *plane;
  }
  if (warm.rows() == x.rows()) {
    FlatPositions out = warm;
    orient(&out);
    return out;
  }
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> vs(x.rows());
  for (Eigen::Index v = 0; v < x.rows(); ++v) vs[v] = sm.add_vertex(Kernel::Point_3(x(v, 0), x(v, 1), x(v, 2)));
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    if (sm.add_face(vs[faces(f, 0)], vs[faces(f, 1)], vs[faces(f, 2)]) == SurfaceMesh::null_face())
      return Status::Error("flatten: face " + std::to_string(f) + " makes the piece non-manifold");
  const auto bhd = CGAL::Polygon_mesh_processing::longest_border(sm).first;
  auto uv = sm.add_property_map<SurfaceMesh::Vertex_index, Kernel::Point_2>("v:uv").first;
  SMP::LSCM_parameterizer_3<SurfaceMesh> lscm;
  const SMP::Error_code err = SMP::parameterize(sm, lscm, bhd, uv);
  if (err != SMP::OK) return Status::Error(std::string("flatten: CGAL LSCM failed: ") + SMP::get_error_message(err));
  FlatPositions out(x.rows(), 2);
  for (Eigen::Index v = 0; v < x.rows(); ++v) out(v, 0) = uv[vs[v]].x(), out(v, 1) = uv[vs[v]].y();
  orient(&out);
  // LSCM pins two vertices, which fixes an arbitrary scale; the refinement frees it.
  Positions flat3(out.rows(), 3);
  flat3 << out, Eigen::VectorXd::Zero(out.rows());
  const double area3 = FaceAreas(x, faces).sum(), area2 = FaceAreas(flat3, faces).sum();
  if (area2 > 0) out *= std::sqrt(area3 / area2);
  return out;
}

constexpr int kRefinementIterations = 500;

// Flattens every piece (pieces[p]: rest positions and faces) with its sewn edges agreeing, starting
// from warm[p] where it has the piece's vertices. With `hopeless`, the refinement stops after a few
// steps when it says the pieces will not do (`*unfinished` set): far over the distortion limits by
// then, they do not come within them at convergence.
Result<std::vector<FlatPositions>> FlattenPieces(const std::vector<const Positions*>& rest, const std::vector<const Faces*>& faces,
                                                 const std::vector<SewnEdges>& sewn, std::vector<FlatPositions> warm = {},
                                                 const Hopeless& hopeless = nullptr, bool* unfinished = nullptr) {
  const int n = static_cast<int>(rest.size());
  warm.resize(n);
  std::vector<FlatPositions> flat(n);
  std::vector<Status> status(n, Status::Ok());
  std::vector<char> planar(n, 0);
#pragma omp parallel for schedule(dynamic)
  for (int p = 0; p < n; ++p) {
    bool is_planar = false;
    Result<FlatPositions> start = InitialFlat(*rest[p], *faces[p], warm[p], &is_planar);
    planar[p] = is_planar;
    if (start.ok()) flat[p] = std::move(start).value();
    else status[p] = start.status();
  }
  bool all_exact = sewn.empty();
  for (int p = 0; p < n; ++p) {
    if (!status[p].ok()) return status[p].WithContext(n > 1 ? "pattern piece " + std::to_string(p + 1) + ": " : "");
    all_exact = all_exact && planar[p];
  }
  // Flat pieces with nothing sewn are their own pattern, exactly.
  if (all_exact) return flat;
  JointRefinement refinement(rest, faces, sewn);
  if (!refinement.ok()) return Status::Error("flatten: the refinement's system could not be factorized");
  std::vector<FlatPositions*> uv;
  for (FlatPositions& f : flat) uv.push_back(&f);
  // The rest of the refinement lowers a sleeve's distortion by at most a third (the MakeHuman sleeve's
  // mean angle change: 2.8 degrees after 10 steps, 1.9 at convergence; the built-in arm's: 3.4, 3.3).
  constexpr int kDecisionIterations = 10;
  if (hopeless) {
    refinement.Run(uv, kDecisionIterations);
    std::vector<Distortion> d;
    for (int p = 0; p < n; ++p) d.push_back(MeasureDistortion(*rest[p], *faces[p], flat[p]));
    if (hopeless(d)) {
      *unfinished = true;
      return flat;
    }
  }
  refinement.Run(uv, kRefinementIterations);
  for (size_t p = 0; p < flat.size(); ++p)
    for (Eigen::Index v = 0; v < flat[p].rows(); ++v)
      if (!std::isfinite(flat[p](v, 0)) || !std::isfinite(flat[p](v, 1)))
        return Status::Error("flatten: piece " + std::to_string(p + 1) + " vertex " + std::to_string(v) + " got no flat position");
  return flat;
}

}  // namespace

// Cuts `garment` along `seams` and flattens every piece (see FlattenPieces for `hopeless`). A piece cut
// from one piece of `refined` (a pattern of fewer seams) starts from its flat shape there.
Result<Pattern> CutAlong(const TriMesh& garment, const std::vector<Seam>& seams, std::map<EdgeKey, std::vector<int>>& edge_faces,
                         const Hopeless& hopeless, bool* unfinished, const Pattern* refined = nullptr) {
  const Positions& x = garment.vertices;
  const Faces& faces = garment.faces;
  const int nv = static_cast<int>(x.rows()), nf = static_cast<int>(faces.rows());
  // Cut edges: the seams' edges, each checked to be a mesh edge inside the cloth.
  std::set<EdgeKey> cut;
  for (size_t s = 0; s < seams.size(); ++s) {
    const std::vector<int>& p = seams[s].vertices;
    if (p.size() < 2) return Status::Error("pattern: seam " + std::to_string(s + 1) + " has fewer than two vertices");
    for (size_t i = 0; i + 1 < p.size(); ++i) {
      if (p[i] < 0 || p[i] >= nv || p[i + 1] < 0 || p[i + 1] >= nv)
        return Status::Error("pattern: seam " + std::to_string(s + 1) + " names vertex " + std::to_string(std::max(p[i], p[i + 1])) +
                             ", not a garment vertex");
      const auto it = edge_faces.find(Key(p[i], p[i + 1]));
      if (it == edge_faces.end())
        return Status::Error("pattern: seam " + std::to_string(s + 1) + " is not a path along edges: vertices " + std::to_string(p[i]) + " and " +
                             std::to_string(p[i + 1]) + " share no edge");
      if (it->second.size() != 2)
        return Status::Error("pattern: seam " + std::to_string(s + 1) + " runs along the garment's edge at vertices " + std::to_string(p[i]) +
                             "-" + std::to_string(p[i + 1]));
      cut.insert(Key(p[i], p[i + 1]));
    }
  }

  // Faces connected across uncut edges form the pieces.
  std::vector<int> piece_of(nf, -1);
  int pieces = 0;
  for (int f0 = 0; f0 < nf; ++f0) {
    if (piece_of[f0] >= 0) continue;
    std::vector<int> stack = {f0};
    piece_of[f0] = pieces;
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k) {
        const EdgeKey e = Key(faces(f, k), faces(f, (k + 1) % 3));
        if (cut.count(e)) continue;
        for (int g : edge_faces[e])
          if (piece_of[g] < 0) piece_of[g] = pieces, stack.push_back(g);
      }
    }
    ++pieces;
  }

  // Each piece's vertices: a garment vertex gets one copy per fan of the piece's faces around it that
  // is connected across uncut edges (so a seam through a piece opens it).
  const VertexFaceIncidence vf = VertexFaces(faces, nv);
  Pattern pattern;
  pattern.seams = seams;
  pattern.pieces.resize(pieces);
  std::vector<std::map<int, int>> copy_of_face_corner(nf);  // face -> (garment vertex -> piece vertex)
  for (int v = 0; v < nv; ++v) {
    std::vector<int> around;
    for (int i = vf.begin[v]; i < vf.begin[v + 1]; ++i) around.push_back(vf.face[i]);
    std::map<int, int> fan;  // face -> fan id
    int fans = 0;
    for (int f0 : around) {
      if (fan.count(f0)) continue;
      std::vector<int> stack = {f0};
      fan[f0] = fans;
      while (!stack.empty()) {
        const int f = stack.back();
        stack.pop_back();
        for (int k = 0; k < 3; ++k) {
          const int a = faces(f, k), b = faces(f, (k + 1) % 3);
          if (a != v && b != v) continue;
          const EdgeKey e = Key(a, b);
          if (cut.count(e)) continue;
          for (int g : edge_faces[e])
            if (!fan.count(g) && piece_of[g] == piece_of[f0]) fan[g] = fans, stack.push_back(g);
        }
      }
      ++fans;
    }
    std::vector<int> vertex_of_fan(fans, -1);
    for (const auto& [f, id] : fan) {
      PatternPiece& p = pattern.pieces[piece_of[f]];
      if (vertex_of_fan[id] < 0) {
        vertex_of_fan[id] = static_cast<int>(p.garment_vertex.size());
        p.garment_vertex.push_back(v);
      }
      copy_of_face_corner[f][v] = vertex_of_fan[id];
    }
  }
  for (int f = 0; f < nf; ++f) pattern.pieces[piece_of[f]].garment_faces.push_back(f);

  for (size_t i = 0; i < pattern.pieces.size(); ++i) {
    PatternPiece& p = pattern.pieces[i];
    p.faces.resize(p.garment_faces.size(), 3);
    for (size_t j = 0; j < p.garment_faces.size(); ++j)
      for (int k = 0; k < 3; ++k) p.faces(j, k) = copy_of_face_corner[p.garment_faces[j]].at(faces(p.garment_faces[j], k));
    p.rest.resize(p.garment_vertex.size(), 3);
    for (size_t v = 0; v < p.garment_vertex.size(); ++v) p.rest.row(v) = x.row(p.garment_vertex[v]);
  }
  // The two sides of every cut edge, to be sewn together.
  std::vector<SewnEdges> sewn;
  for (const EdgeKey& e : cut) {
    const std::vector<int>& fs = edge_faces.at(e);
    const auto& ca = copy_of_face_corner[fs[0]];
    const auto& cb = copy_of_face_corner[fs[1]];
    sewn.push_back({piece_of[fs[0]], ca.at(e.first), ca.at(e.second), piece_of[fs[1]], cb.at(e.first), cb.at(e.second)});
  }
  std::vector<const Positions*> rest;
  std::vector<const Faces*> piece_faces;
  for (const PatternPiece& p : pattern.pieces) rest.push_back(&p.rest), piece_faces.push_back(&p.faces);
  std::vector<FlatPositions> warm(pattern.pieces.size());
  if (refined) {
    std::vector<std::pair<int, int>> was(nf, {-1, -1});  // garment face -> (piece, face row) in `refined`
    for (size_t q = 0; q < refined->pieces.size(); ++q)
      for (size_t j = 0; j < refined->pieces[q].garment_faces.size(); ++j) was[refined->pieces[q].garment_faces[j]] = {static_cast<int>(q), static_cast<int>(j)};
    for (size_t i = 0; i < pattern.pieces.size(); ++i) {
      const PatternPiece& p = pattern.pieces[i];
      FlatPositions uv(p.rest.rows(), 2);
      bool one = true;
      for (size_t j = 0; j < p.garment_faces.size() && one; ++j) {
        const auto [q, row] = was[p.garment_faces[j]];
        one = q >= 0 && q == was[p.garment_faces[0]].first;
        for (int k = 0; one && k < 3; ++k) uv.row(p.faces(j, k)) = refined->pieces[q].flat.row(refined->pieces[q].faces(row, k));
      }
      if (one) warm[i] = std::move(uv);
    }
  }
  Result<std::vector<FlatPositions>> flat = FlattenPieces(rest, piece_faces, sewn, std::move(warm), hopeless, unfinished);
  if (!flat.ok()) return flat.status();
  for (size_t i = 0; i < pattern.pieces.size(); ++i) {
    PatternPiece& p = pattern.pieces[i];
    p.flat = std::move((*flat)[i]);
    p.distortion = MeasureDistortion(p.rest, p.faces, p.flat);
    const std::vector<std::vector<int>> outline = BoundaryLoops(p.faces);
    p.outline = outline.front();
    FlatPositions polygon(p.outline.size(), 2);
    for (size_t k = 0; k < p.outline.size(); ++k) polygon.row(k) = p.flat.row(p.outline[k]);
    if (SignedArea(polygon) < 0) std::reverse(p.outline.begin(), p.outline.end());
  }
  return pattern;
}

static std::optional<Pattern> SplitOpposite(const TriMesh& garment, const std::vector<std::vector<int>>& loops,
                                            const std::vector<std::vector<std::pair<int, double>>>& graph,
                                            std::map<EdgeKey, std::vector<int>>& edge_faces, const Pattern& one);
static bool OverLimits(const std::vector<Distortion>& pieces, const PatternOptions& o, double margin = 1);

// CutPattern's pieces, before their sew lines are faired.
static Result<Pattern> CutPieces(const TriMesh& garment, const PatternOptions& options) {
  const Positions& x = garment.vertices;
  const Faces& faces = garment.faces;
  const int nv = static_cast<int>(x.rows()), nf = static_cast<int>(faces.rows());
  if (nf == 0) return Status::Error("pattern: the garment has no faces");
  if (EdgeConnectedPieces(faces).count != 1) return Status::Error("pattern: the garment is not one connected piece");
  const std::vector<std::vector<int>> loops = BoundaryLoops(faces);
  if (loops.empty()) return Status::Error("pattern: the garment is closed (no boundary): it cannot be cut into pieces along seams from its edges");
  const int chi = EulerCharacteristic(faces);
  if (chi != 2 - static_cast<int>(loops.size()))
    return Status::Error("pattern: the garment has handles (Euler characteristic " + std::to_string(chi) + " with " +
                         std::to_string(loops.size()) + " boundary loops); give its seams");

  // Edges and their faces.
  std::map<EdgeKey, std::vector<int>> edge_faces;
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) edge_faces[Key(faces(f, k), faces(f, (k + 1) % 3))].push_back(f);

  // Seams: given, or shortest paths joining every loop to the ones joined before.
  std::vector<Seam> seams = options.seams;
  // Edge graphs through the cloth (not along its edge): by length, and by length weighted by strain.
  std::vector<std::vector<std::pair<int, double>>> graph(nv), by_length(nv);
  double mean_strain = 0;
  if (options.strain.size() == nf) mean_strain = options.strain.cwiseAbs().mean();
  for (const auto& [e, fs] : edge_faces) {
    if (fs.size() != 2) continue;
    const double length = (x.row(e.first) - x.row(e.second)).norm();
    double w = length;
    if (mean_strain > 0) w *= 1 + 0.5 * (std::abs(options.strain[fs[0]]) + std::abs(options.strain[fs[1]])) / mean_strain;
    graph[e.first].push_back({e.second, w});
    graph[e.second].push_back({e.first, w});
    by_length[e.first].push_back({e.second, length});
    by_length[e.second].push_back({e.first, length});
  }
  if (seams.empty() && loops.size() > 1) {
    // Boundary vertices may start or end a seam; the edges between them stay out of the graph.
    std::vector<char> joined(nv, 0);
    for (int v : loops[0]) joined[v] = 1;
    for (size_t l = 1; l < loops.size(); ++l) {
      std::vector<char> from(nv, 0);
      for (int v : loops[l]) from[v] = 1;
      std::vector<int> path = ShortestPath(x, graph, from, joined);
      if (path.size() < 2) return Status::Error("pattern: no seam joins boundary loop " + std::to_string(l + 1) + " to the others");
      seams.push_back({path});
      for (int v : path) joined[v] = 1;
      for (int v : loops[l]) joined[v] = 1;
    }
  }

  // A sleeve whose one piece stretches more than the limits opens along a second seam, opposite the
  // first: two halves, each closer to developable. One far over the limits is not flattened to the end.
  const bool may_halve = options.seams.empty() && loops.size() == 2;
  const Hopeless hopeless = [&](const std::vector<Distortion>& d) { return OverLimits(d, options, /*margin=*/1.5); };
  bool unfinished = false;
  Result<Pattern> pattern = CutAlong(garment, seams, edge_faces, may_halve ? hopeless : nullptr, &unfinished);
  if (!pattern.ok() || !may_halve) return pattern;
  std::vector<Distortion> one;
  for (const PatternPiece& piece : pattern->pieces) one.push_back(piece.distortion);
  if (!unfinished && !OverLimits(one, options)) return pattern;
  // The second seam runs straight across, whatever the strain.
  if (std::optional<Pattern> halves = SplitOpposite(garment, loops, by_length, edge_faces, *pattern)) return std::move(*halves);
  return unfinished ? CutAlong(garment, seams, edge_faces, nullptr, nullptr) : pattern;
}

Result<Pattern> CutPattern(const TriMesh& garment, const PatternOptions& options) {
  Result<Pattern> pattern = CutPieces(garment, options);
  if (pattern.ok()) FairSewLines(&*pattern);
  return pattern;
}

static bool OverLimits(const std::vector<Distortion>& pieces, const PatternOptions& o, double margin) {
  for (const Distortion& d : pieces)
    if (d.area_mean > margin * o.max_area_distortion_mean || d.area_max > margin * o.max_area_distortion_max ||
        d.angle_mean_deg > margin * o.max_angle_distortion_mean_deg)
      return true;
  return false;
}

// Halves of a sleeve `one` (one piece, one seam): a second seam from the points of its two boundary
// loops opposite the first seam's ends, by the shortest path; the halves start from their shapes in
// `one`. Nothing when that path would cross the first seam or the halves cannot be cut.
static std::optional<Pattern> SplitOpposite(const TriMesh& garment, const std::vector<std::vector<int>>& loops,
                                            const std::vector<std::vector<std::pair<int, double>>>& graph,
                                            std::map<EdgeKey, std::vector<int>>& edge_faces, const Pattern& one) {
  const int nv = static_cast<int>(garment.vertices.rows());
  const Positions& x = garment.vertices;
  auto opposite = [&](const std::vector<int>& loop, int v) {
    const auto at = std::find(loop.begin(), loop.end(), v);
    if (at == loop.end()) return -1;
    return loop[((at - loop.begin()) + loop.size() / 2) % loop.size()];
  };
  const std::vector<Seam>& seams = one.seams;
  const std::vector<int>& first = seams.front().vertices;
  const bool starts_on_0 = std::find(loops[0].begin(), loops[0].end(), first.front()) != loops[0].end();
  const int a = opposite(loops[0], starts_on_0 ? first.front() : first.back());
  const int b = opposite(loops[1], starts_on_0 ? first.back() : first.front());
  if (a < 0 || b < 0) return std::nullopt;
  std::vector<char> from(nv, 0), to(nv, 0);
  from[a] = 1;
  to[b] = 1;
  std::vector<int> path = ShortestPath(x, graph, from, to);
  for (int v : path)
    if (std::find(first.begin(), first.end(), v) != first.end()) return std::nullopt;  // the seams would cross
  if (path.size() < 2) return std::nullopt;
  std::vector<Seam> two = seams;
  two.push_back({path});
  Result<Pattern> halves = CutAlong(garment, two, edge_faces, nullptr, nullptr, &one);
  if (!halves.ok()) return std::nullopt;
  return std::move(halves).value();
}

}  // namespace kgd
