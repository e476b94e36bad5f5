#include "core/sim/skin_pressure.h"

#include "core/mesh/point_cloud.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace kgd {
namespace {

// Barycentric coordinates of the point of triangle (a, b, c) closest to p (Ericson, Real-Time
// Collision Detection, 5.1.5).
Eigen::Vector3d ClosestPointBarycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                        const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {1 - v - w, v, w};
}

// Candidate triangles per query: the nearest centroids. On a garment of roughly even triangles the
// closest triangle is among them.
constexpr int kCandidateTriangles = 8;

}  // namespace

Eigen::VectorXd ContactNormalForces(const BodyField& field, const Positions& x, ContactModel model, double k) {
  Eigen::VectorXd f = Eigen::VectorXd::Zero(x.rows());
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    NeighborCache cache;
    Eigen::Vector3d g;
    const ContactEvaluation ce = EvaluateContactVertex(field, x.row(i).transpose(), &cache, model, k, &g, nullptr, false);
    const double len = ce.phi_grad.norm();
    if (!ce.supported || len == 0) continue;
    f[i] = -g.dot(ce.phi_grad) / len;
  }
  return f;
}

void SummarizePressure(const Eigen::VectorXd& p, SkinPressure* out) {
  std::vector<double> loaded;
  out->peak_Pa = 0;
  out->peak_vertex = -1;
  for (Eigen::Index j = 0; j < p.size(); ++j) {
    if (!(p[j] > 0)) continue;
    loaded.push_back(p[j]);
    if (p[j] > out->peak_Pa) out->peak_Pa = p[j], out->peak_vertex = static_cast<int>(j);
  }
  out->loaded_vertices = static_cast<int>(loaded.size());
  out->p95_Pa = 0;
  if (loaded.empty()) return;
  const size_t rank = static_cast<size_t>(std::ceil(0.95 * loaded.size()));  // nearest rank, 1-based
  std::nth_element(loaded.begin(), loaded.begin() + (rank - 1), loaded.end());
  out->p95_Pa = loaded[rank - 1];
}

Eigen::VectorXd GarmentPressure(const Positions& x, const Faces& garment_faces, const Eigen::VectorXd& normal_force_N) {
  const Eigen::VectorXd area = LumpedVertexAreas(x, garment_faces);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(x.rows());
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    if (area[i] > 0) q[i] = normal_force_N[i] / area[i];
  return q;
}

SkinPressure PressureOnBody(const TriMesh& body, const Positions& x, const Faces& faces, const Eigen::VectorXd& q) {
  SkinPressure out;
  const Eigen::Index nb = body.vertices.rows(), nf = faces.rows();
  out.pressure_Pa = Eigen::VectorXd::Zero(nb);
  if (nf > 0 && q.cwiseAbs().maxCoeff() > 0) {
    const double tolerance = 0.5 * MeanEdgeLength(x, faces);
    PointCloud cloud{FaceCentroids(x, faces)};
    PointCloudTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    tree.buildIndex();
    const Eigen::RowVector3d lo = x.colwise().minCoeff().array() - tolerance, hi = x.colwise().maxCoeff().array() + tolerance;
    const int k = static_cast<int>(std::min<Eigen::Index>(kCandidateTriangles, nf));
    std::vector<int> candidates(k);
    std::vector<double> d2(k);
    for (Eigen::Index j = 0; j < nb; ++j) {
      const Eigen::Vector3d p = body.vertices.row(j).transpose();
      if ((p.transpose().array() < lo.array()).any() || (p.transpose().array() > hi.array()).any()) continue;
      const size_t found = tree.knnSearch(p.data(), k, candidates.data(), d2.data());
      double best = std::numeric_limits<double>::infinity();
      int best_face = -1;
      Eigen::Vector3d best_w = Eigen::Vector3d::Zero();
      for (size_t c = 0; c < found; ++c) {
        const int f = candidates[c];
        const Eigen::Vector3d a = x.row(faces(f, 0)), b = x.row(faces(f, 1)), cc = x.row(faces(f, 2));
        const Eigen::Vector3d w = ClosestPointBarycentric(p, a, b, cc);
        const double d = (w[0] * a + w[1] * b + w[2] * cc - p).squaredNorm();
        if (d < best) best = d, best_face = f, best_w = w;
      }
      if (best_face < 0 || best > tolerance * tolerance) continue;
      for (int v = 0; v < 3; ++v) out.pressure_Pa[j] += best_w[v] * q[faces(best_face, v)];
    }
  }
  SummarizePressure(out.pressure_Pa, &out);
  return out;
}

SkinPressure ComputeSkinPressure(const TriMesh& body, const BodyField& field, const Positions& x, const Faces& garment_faces,
                                 ContactModel model, double k) {
  const Eigen::VectorXd f = ContactNormalForces(field, x, model, k);
  SkinPressure out = PressureOnBody(body, x, garment_faces, GarmentPressure(x, garment_faces, f));
  out.normal_force_N = f.sum();
  return out;
}

}  // namespace kgd
