// Posing the parametric body: dual-quaternion skinning, projection onto the posed implicit surface in
// steps of at most 10 degrees, fold repair and relaxation of the skin's metric.
#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/body/implicit_body.h"
#include "core/body/parametric_body.h"
#include "core/mesh/topology.h"

namespace kgd {
namespace {
using namespace body_internal;

// Dual-quaternion skinning of every rest vertex for bone transforms `t`.
Positions Skin(const ParametricBody& body, const std::array<Eigen::Isometry3d, kNumBones>& t) {
  std::array<Eigen::Quaterniond, kNumBones> qr, qd;
  for (int b = 0; b < kNumBones; ++b) {
    qr[b] = Eigen::Quaterniond(t[b].linear());
    const V3 tr = t[b].translation();
    const Eigen::Quaterniond tq(0, tr.x(), tr.y(), tr.z());
    qd[b] = tq * qr[b];
    qd[b].coeffs() *= 0.5;
  }
  const Eigen::Index nv = body.rest.vertices.rows();
  Positions out(nv, 3);
#pragma omp parallel for schedule(static)
  for (Eigen::Index v = 0; v < nv; ++v) {
    // Blend with signs aligned to the heaviest bone.
    const auto& w = body.weights[v];
    Eigen::Vector4d br = Eigen::Vector4d::Zero(), bd = Eigen::Vector4d::Zero();
    for (const auto& [bone, weight] : w) {
      if (weight == 0) continue;
      const double sign = qr[bone].coeffs().dot(qr[w[0].first].coeffs()) < 0 ? -1.0 : 1.0;
      br += sign * weight * qr[bone].coeffs();
      bd += sign * weight * qd[bone].coeffs();
    }
    const double n = br.norm();
    const Eigen::Quaterniond r(br / n), d(bd / n);
    const V3 translation = 2.0 * (d * r.conjugate()).vec();
    out.row(v) = (r * V3(body.rest.vertices.row(v)) + translation).transpose();
  }
  return out;
}

const double kSkinRelaxStrain = 0.05;
const int kSkinRelaxIterations = 100;
const double kSkinRelaxStep = 0.9;

// Marks every vertex within `rings` edges of a marked one.
void GrowMarks(const std::vector<std::vector<int>>& nbrs, int rings, std::vector<char>* mark) {
  for (int ring = 0; ring < rings; ++ring) {
    std::vector<char> grown = *mark;
    for (size_t v = 0; v < mark->size(); ++v)
      if ((*mark)[v])
        for (int w : nbrs[v]) grown[w] = 1;
    mark->swap(grown);
  }
}

std::vector<int> MarkedVertices(const std::vector<char>& mark) {
  std::vector<int> active;
  for (size_t v = 0; v < mark.size(); ++v)
    if (mark[v]) active.push_back(static_cast<int>(v));
  return active;
}

// Where the skin is compressed (inside of a bent joint) projection can fold triangles over; relax the
// folded patches on the surface until none is left, as skin slides over the flesh there. The relaxed
// patch only grows: compression spread over a wider band needs no fold.
void RepairFolds(const ParametricBody& body, const PosedField& field, const std::vector<std::vector<int>>& nbrs, Positions* x) {
  const Eigen::Index nv = x->rows();
  const double h = body.measurements.resolution_m;
  const Faces& faces = body.rest.faces;
  std::vector<char> mark(nv, 0);
  // Only faces touching moved vertices can fold anew: after the first round check just those.
  std::vector<int> candidates(faces.rows());
  std::iota(candidates.begin(), candidates.end(), 0);
  size_t fewest = SIZE_MAX;
  int stalled = 0;
  for (int round = 0; round < 60; ++round) {
    const std::vector<int> folded = field.FoldedFaces(*x, faces, candidates, 0.02 * h * h);
    if (folded.empty()) break;
    // A few slivers the relaxation cannot improve are no reason to keep going.
    if (folded.size() < fewest) fewest = folded.size(), stalled = 0;
    else if (++stalled >= 5) break;
    for (int f : folded)
      for (int k = 0; k < 3; ++k) mark[faces(f, k)] = 1;
    GrowMarks(nbrs, round == 0 ? 2 : 1, &mark);
    field.Relax(x, nbrs, MarkedVertices(mark), 6);
    candidates.clear();
    for (Eigen::Index f = 0; f < faces.rows(); ++f)
      if (mark[faces(f, 0)] || mark[faces(f, 1)] || mark[faces(f, 2)]) candidates.push_back(static_cast<int>(f));
  }
}

// Skinning and projection leave the skin of a bent joint unevenly stretched: at the inside of the
// elbow the projection spreads the skin sideways (1.5-2.2x around the arm). Real skin slides over the
// flesh towards its own metric; a spring relaxation on the surface of the skin that is stretched or
// compressed does the same, anchored by the skin around it that moved rigidly.
void RelaxSkinMetric(const ParametricBody& body, const PosedField& field, const std::vector<std::vector<int>>& nbrs, Positions* x) {
  const Eigen::Index nv = x->rows();
  const Positions& rest = body.rest.vertices;
  std::vector<char> mark(nv, 0);
  for (Eigen::Index v = 0; v < nv; ++v)
    for (int w : nbrs[v]) {
      const double ratio = (x->row(v) - x->row(w)).norm() / (rest.row(v) - rest.row(w)).norm();
      if (std::abs(ratio - 1.0) > kSkinRelaxStrain) mark[v] = 1;
    }
  GrowMarks(nbrs, 2, &mark);
  const std::vector<int> active = MarkedVertices(mark);
  if (!active.empty()) field.Relax(x, nbrs, active, kSkinRelaxIterations, &rest, kSkinRelaxStep);
}

}  // namespace
using body_internal::Angle;
using body_internal::kDeg;

Result<std::vector<Positions>> PoseSequence(const ParametricBody& body, const std::vector<JointAngles>& keyframes) {
  for (size_t i = 0; i < keyframes.size(); ++i)
    if (Status st = ValidateJointAngles(keyframes[i]); !st.ok()) return st.WithContext("keyframe " + std::to_string(i) + ": ");
  const std::vector<std::string> names = JointAngleNames();
  const std::vector<std::vector<int>> nbrs = VertexNeighbors(body.rest.faces, static_cast<int>(body.rest.vertices.rows()));
  std::vector<Positions> out;
  Positions x = body.rest.vertices;
  Positions skinned_prev = body.rest.vertices;
  JointAngles from = RestAngles();
  for (const JointAngles& target : keyframes) {
    // Continuation in steps of at most 10 degrees per joint: the skin follows the surface and never
    // starts a projection from deep inside the body, where the nearest surface may be the wrong one.
    double largest = 0;
    for (const std::string& n : names) largest = std::max(largest, std::abs(Angle(target, n) - Angle(from, n)));
    const int steps = std::max(1, static_cast<int>(std::ceil(largest / (10 * kDeg))));
    for (int k = 1; k <= steps; ++k) {
      JointAngles at;
      for (const std::string& n : names) at[n] = Angle(from, n) + (Angle(target, n) - Angle(from, n)) * k / steps;
      const Positions skinned = Skin(body, BoneTransforms(body, at));
      const PosedField field(body, at);
      x += skinned - skinned_prev;
      skinned_prev = skinned;
      const Eigen::Index nv = x.rows();
#pragma omp parallel for schedule(static)
      for (Eigen::Index v = 0; v < nv; ++v) x.row(v) = field.Project(x.row(v).transpose()).transpose();
      RepairFolds(body, field, nbrs, &x);
    }
    {
      const PosedField field(body, target);
      RelaxSkinMetric(body, field, nbrs, &x);
      RepairFolds(body, field, nbrs, &x);
    }
    for (Eigen::Index v = 0; v < x.rows(); ++v)
      if (!x.row(v).allFinite()) return Status::Error("posing the parametric body produced a non-finite vertex " + std::to_string(v));
    out.push_back(x);
    from.clear();
    for (const std::string& n : names) from[n] = Angle(target, n);
  }
  return out;
}

Result<Positions> PoseBody(const ParametricBody& body, const JointAngles& angles) {
  Result<std::vector<Positions>> seq = PoseSequence(body, {angles});
  if (!seq.ok()) return seq.status();
  return std::move(seq->front());
}

}  // namespace kgd
