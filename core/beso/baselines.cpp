#include "core/beso/baselines.h"

#include <Eigen/SparseCholesky>
#include <Eigen/Geometry>
#include <cmath>

#include "core/mesh/topology.h"
#include "core/sim/garment_system.h"

namespace kgd {
namespace {

double WrapAngle(double a) {
  a = std::fmod(a + M_PI, 2 * M_PI);
  if (a < 0) a += 2 * M_PI;
  return a - M_PI;
}

}  // namespace

const char* ToString(BaselineShape shape) { return shape == BaselineShape::kLine ? "line" : "x"; }

Result<GarmentCoordinates> ComputeGarmentCoordinates(const TriMesh& garment, const std::vector<int>& attachment_faces) {
  const Faces& F = garment.faces;
  const Positions& V = garment.vertices;
  const int nv = static_cast<int>(V.rows()), nf = static_cast<int>(F.rows());
  if (EdgeConnectedPieces(F).count != 1) return Status::Error("baselines need a connected garment");
  Faces band_faces(attachment_faces.size(), 3);
  for (size_t k = 0; k < attachment_faces.size(); ++k) band_faces.row(k) = F.row(attachment_faces[k]);
  const FacePieces bands = EdgeConnectedPieces(band_faces);
  if (bands.count != 2)
    return Status::Error("Line and X baselines run between two attachment bands; this garment has " + std::to_string(bands.count));

  // Harmonic s with s = 0 / 1 on the vertices of the two bands (graph Laplacian: s only has to rise
  // monotonically along the garment; the bands' width is then set by area, not by s).
  std::vector<int> fixed(nv, -1);
  for (size_t k = 0; k < attachment_faces.size(); ++k)
    for (int c = 0; c < 3; ++c) fixed[F(attachment_faces[k], c)] = bands.piece[k];
  const std::vector<std::vector<int>> nbr = VertexNeighbors(F, nv);
  std::vector<int> index(nv, -1);
  int n = 0;
  for (int v = 0; v < nv; ++v)
    if (fixed[v] < 0) index[v] = n++;
  Eigen::VectorXd sv(nv);
  for (int v = 0; v < nv; ++v) sv[v] = fixed[v] < 0 ? 0.0 : fixed[v];
  if (n > 0) {
    std::vector<Eigen::Triplet<double>> t;
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
    for (int v = 0; v < nv; ++v) {
      if (index[v] < 0) continue;
      t.emplace_back(index[v], index[v], static_cast<double>(nbr[v].size()));
      for (int w : nbr[v]) {
        if (index[w] >= 0) t.emplace_back(index[v], index[w], -1.0);
        else rhs[index[v]] += sv[w];
      }
    }
    Eigen::SparseMatrix<double> L(n, n);
    L.setFromTriplets(t.begin(), t.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(L);
    if (ldlt.info() != Eigen::Success) return Status::Error("baselines: the harmonic coordinate could not be solved");
    const Eigen::VectorXd sol = ldlt.solve(rhs);
    for (int v = 0; v < nv; ++v)
      if (index[v] >= 0) sv[v] = sol[index[v]];
  }

  // Centre line: area-weighted centroids of the faces in bins of s; axis = its local direction.
  GarmentCoordinates c;
  c.s.resize(nf);
  const Eigen::VectorXd area = FaceAreas(V, F);
  std::vector<Eigen::Vector3d> centroid(nf);
  for (int f = 0; f < nf; ++f) {
    c.s[f] = (sv[F(f, 0)] + sv[F(f, 1)] + sv[F(f, 2)]) / 3.0;
    centroid[f] = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))).transpose() / 3.0;
  }
  const int bins = 24;
  std::vector<Eigen::Vector3d> centre(bins, Eigen::Vector3d::Zero());
  std::vector<double> weight(bins, 0.0);
  auto bin_of = [&](double s) { return std::clamp(static_cast<int>(s * bins), 0, bins - 1); };
  for (int f = 0; f < nf; ++f) {
    centre[bin_of(c.s[f])] += area[f] * centroid[f];
    weight[bin_of(c.s[f])] += area[f];
  }
  for (int b = 0; b < bins; ++b) {
    if (weight[b] > 0) {
      centre[b] /= weight[b];
    } else {  // an empty bin borrows its neighbour's centre
      centre[b] = b > 0 ? centre[b - 1] : Eigen::Vector3d::Zero();
    }
  }
  const Eigen::Vector3d main_axis = (centre[bins - 1] - centre[0]).normalized();
  // A reference direction perpendicular to the main axis, transported to each bin by projection.
  Eigen::Vector3d ref = main_axis.unitOrthogonal();
  std::vector<Eigen::Vector3d> axis(bins), u(bins);
  for (int b = 0; b < bins; ++b) {
    const int lo = std::max(0, b - 1), hi = std::min(bins - 1, b + 1);
    axis[b] = (centre[hi] - centre[lo]).normalized();
    if (!axis[b].allFinite()) axis[b] = main_axis;
    u[b] = (ref - ref.dot(axis[b]) * axis[b]).normalized();
  }
  c.theta.resize(nf);
  for (int f = 0; f < nf; ++f) {
    const int b = bin_of(c.s[f]);
    const Eigen::Vector3d r = centroid[f] - centre[b];
    const Eigen::Vector3d w = axis[b].cross(u[b]);
    c.theta[f] = std::atan2(r.dot(w), r.dot(u[b]));
  }
  return c;
}

std::vector<uint8_t> BaselineDesign(const GarmentCoordinates& c, const Eigen::VectorXd& area, BaselineShape shape, double theta0,
                                    double target) {
  const Eigen::Index nf = c.s.size();
  Eigen::VectorXd distance(nf);  // angular distance from the band's centre line
  for (Eigen::Index f = 0; f < nf; ++f) {
    if (shape == BaselineShape::kLine) {
      distance[f] = std::abs(WrapAngle(c.theta[f] - theta0));
    } else {
      const double shift = M_PI * (c.s[f] - 0.5);
      distance[f] = std::min(std::abs(WrapAngle(c.theta[f] - theta0 - shift)), std::abs(WrapAngle(c.theta[f] - theta0 + shift)));
    }
  }
  auto area_within = [&](double half_width) {
    double a = 0;
    for (Eigen::Index f = 0; f < nf; ++f)
      if (distance[f] <= half_width) a += area[f];
    return a;
  };
  double lo = 0, hi = M_PI;
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi);
    (area_within(mid) < target ? lo : hi) = mid;
  }
  const double half_width = std::abs(area_within(lo) - target) <= std::abs(area_within(hi) - target) ? lo : hi;
  std::vector<uint8_t> design(nf, kCloth);
  for (Eigen::Index f = 0; f < nf; ++f)
    if (distance[f] <= half_width) design[f] = kReinforced;
  return design;
}

double WeightedMeanAngle(const GarmentCoordinates& c, const Eigen::VectorXd& weight) {
  double x = 0, y = 0;
  for (Eigen::Index f = 0; f < c.theta.size(); ++f) {
    x += weight[f] * std::cos(c.theta[f]);
    y += weight[f] * std::sin(c.theta[f]);
  }
  return std::atan2(y, x);
}

Result<BaselineComparison> CompareWithBaselines(const SceneSpec& scene, const std::vector<uint8_t>& optimized,
                                                const Eigen::VectorXd& full_energy_per_face, std::optional<double> angle_rad) {
  Result<GarmentCoordinates> c = ComputeGarmentCoordinates(scene.garment, scene.attachment_faces);
  if (!c.ok()) return c.status();
  const Eigen::VectorXd area = FaceAreas(scene.garment.vertices, scene.garment.faces);
  BaselineComparison out;
  for (size_t f = 0; f < optimized.size(); ++f) out.area_m2 += optimized[f] == kReinforced ? area[f] : 0.0;
  out.theta0_rad = angle_rad ? *angle_rad : WeightedMeanAngle(*c, full_energy_per_face);
  out.line = BaselineDesign(*c, area, BaselineShape::kLine, out.theta0_rad, out.area_m2);
  out.x = BaselineDesign(*c, area, BaselineShape::kX, out.theta0_rad, out.area_m2);
  using Job = std::pair<const std::vector<uint8_t>*, SimulationResult*>;
  for (auto [design, result] : {Job{&optimized, &out.optimized_result}, Job{&out.line, &out.line_result}, Job{&out.x, &out.x_result}}) {
    SceneSpec s = scene;
    s.design = *design;
    Result<SimulationResult> r = SimulateScene(s);
    if (!r.ok()) return r.status();
    *result = std::move(r).value();
  }
  return out;
}

}  // namespace kgd
