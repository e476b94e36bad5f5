// The parametric body built to measurements: skeleton joints, primitives, the implicit surface meshed
// by surface nets, and the skinning weights.
#include "core/body/parametric_body.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "core/body/implicit_body.h"
#include "core/mesh/surface_nets.h"
#include "core/mesh/topology.h"

namespace kgd {
namespace {
using namespace body_internal;

// Circumference of an ellipse with semi-axes a, b (Ramanujan's second approximation).
double EllipsePerimeter(double a, double b) {
  const double h = (a - b) * (a - b) / ((a + b) * (a + b));
  return kPi * (a + b) * (1 + 3 * h / (10 + std::sqrt(4 - 3 * h)));
}
// Semi-axes (lateral, depth) of an ellipse with the given girth and depth/width ratio.
std::pair<double, double> EllipseFromGirth(double girth, double ratio) {
  const double a = girth / EllipsePerimeter(1.0, ratio);
  return {a, ratio * a};
}

BodyPrimitive MakePrimitive(int bone, const V3& a, const V3& b, double r1a, double r2a, double r1b, double r2b) {
  BodyPrimitive p;
  p.bone = bone;
  p.a = a;
  p.b = b;
  const V3 e = (b - a).normalized();
  const V3 up = std::abs(e.dot(V3::UnitZ())) > 0.9 ? V3::UnitY() : V3::UnitZ();
  p.u2 = (up - up.dot(e) * e).normalized();
  p.u1 = p.u2.cross(e).normalized();
  p.r1_a = r1a;
  p.r2_a = r2a;
  p.r1_b = r1b;
  p.r2_b = r2b;
  return p;
}

// The skeleton and the primitives made to `m` (no mesh, no skinning weights).
Result<ParametricBody> BuildSkeleton(const BodyMeasurements& m) {
  if (Status st = ValidateMeasurements(m); !st.ok()) return st;
  ParametricBody body;
  body.measurements = m;
  const double s = m.height_m / 1.70;
  auto& j = body.joint;
  body.parent = {-1, kPelvis, kLumbar, kThorax, kChest, kNeck,
                 kChest, kClavicleL, kUpperArmL, kForearmL, kChest, kClavicleR, kUpperArmR, kForearmR,
                 kPelvis, kThighL, kShankL, kPelvis, kThighR, kShankR};

  // Legs: slightly abducted thighs, knees flexed 5 degrees (the rest pose), ankles at 7.5 cm.
  const double abd = 3 * kDeg, knee0 = 5 * kDeg;
  const double ankle_y = 0.075 * s;
  const double hip_y = ankle_y + m.thigh_length_m * std::cos(abd) + m.shank_length_m * std::cos(abd) * std::cos(knee0);
  const double neck_base_y = m.height_m - 0.245 * s;
  const double torso = neck_base_y - hip_y;
  j[kPelvis] = V3(0, hip_y, 0);
  j[kLumbar] = V3(0, hip_y + 0.115 * torso, -0.005 * s);
  j[kThorax] = V3(0, hip_y + 0.38 * torso, 0);
  j[kChest] = V3(0, hip_y + 0.69 * torso, 0);
  j[kNeck] = V3(0, neck_base_y, -0.01 * s);
  j[kHead] = V3(0, m.height_m - 0.17 * s, 0);
  const double shoulder_y = hip_y + 0.87 * torso;
  const auto [hip_rx, hip_rz] = EllipseFromGirth(m.hip_circumference_m, 0.74);
  const auto [waist_rx, waist_rz] = EllipseFromGirth(m.waist_circumference_m, 0.74);
  const auto [chest_rx, chest_rz] = EllipseFromGirth(m.chest_circumference_m, 0.68);
  const double r_ua = m.upper_arm_circumference_m / (2 * kPi), r_fa = m.forearm_circumference_m / (2 * kPi);
  const double r_th = m.thigh_circumference_m / (2 * kPi), r_ca = m.calf_circumference_m / (2 * kPi);

  auto& prims = body.primitives;
  prims.push_back(MakePrimitive(kPelvis, V3(0, hip_y - 0.07 * s, -0.01 * s), V3(0, j[kLumbar].y(), -0.01 * s), hip_rx, hip_rz, hip_rx, hip_rz));
  prims.push_back(MakePrimitive(kLumbar, V3(0, j[kLumbar].y(), -0.01 * s), V3(0, j[kThorax].y(), 0), hip_rx, hip_rz, waist_rx, waist_rz));
  prims.push_back(MakePrimitive(kThorax, V3(0, j[kThorax].y(), 0), V3(0, j[kChest].y(), 0), waist_rx, waist_rz, chest_rx, chest_rz));
  prims.push_back(MakePrimitive(kChest, V3(0, j[kChest].y(), 0), V3(0, neck_base_y - 0.03 * s, -0.01 * s), chest_rx, chest_rz,
                                0.83 * chest_rx, 0.62 * chest_rz));
  prims.push_back(MakePrimitive(kNeck, V3(0, neck_base_y - 0.05 * s, -0.01 * s), V3(0, m.height_m - 0.17 * s, -0.005 * s),
                                0.055 * s, 0.055 * s, 0.05 * s, 0.05 * s));
  prims.push_back(MakePrimitive(kHead, V3(0, m.height_m - 0.20 * s, 0.01 * s), V3(0, m.height_m - 0.10 * s, 0.01 * s),
                                0.075 * s, 0.092 * s, 0.075 * s, 0.092 * s));

  for (int side = 0; side < 2; ++side) {
    const double x = side == 0 ? 1.0 : -1.0;
    const std::string p = side == 0 ? "l_" : "r_";
    const int clav = side == 0 ? kClavicleL : kClavicleR, upper = side == 0 ? kUpperArmL : kUpperArmR;
    const int fore = side == 0 ? kForearmL : kForearmR, hand = side == 0 ? kHandL : kHandR;
    j[clav] = V3(x * 0.02 * s, shoulder_y, 0.03 * s);
    j[upper] = V3(x * 0.18 * s, shoulder_y, 0);
    const V3 du(x * std::sin(45 * kDeg), -std::cos(45 * kDeg), 0);
    j[fore] = j[upper] + m.upper_arm_length_m * du;
    const V3 df = Eigen::AngleAxisd(15 * kDeg, du.cross(V3::UnitZ()).normalized()) * du;
    j[hand] = j[fore] + m.forearm_length_m * df;
    const V3 hand_end = j[hand] + 0.17 * s * df;
    BodyPrimitive ua = MakePrimitive(upper, j[upper], j[fore], 1.12 * r_ua, 1.12 * r_ua, 0.8 * r_ua, 0.8 * r_ua);
    ua.mid_bulge_m = 0.05 * r_ua;
    ua.bulge_joint = p + "elbow_flex";
    ua.bulge_per_rad = 0.12;  // biceps: +18 % anterior radius at 90 degrees of extra flexion
    ua.bulge_anterior_only = true;
    prims.push_back(ua);
    prims.push_back(MakePrimitive(fore, j[fore], j[hand], 1.0 * r_fa, 1.0 * r_fa, 0.62 * r_fa, 0.62 * r_fa));
    prims.push_back(MakePrimitive(hand, j[hand] + 0.01 * s * df, hand_end, 0.026 * s, 0.042 * s, 0.024 * s, 0.038 * s));

    const int thigh = side == 0 ? kThighL : kThighR, shank = side == 0 ? kShankL : kShankR, foot = side == 0 ? kFootL : kFootR;
    j[thigh] = V3(x * 0.085 * s, hip_y, 0);
    const V3 dt(x * std::sin(abd), -std::cos(abd), 0);
    j[shank] = j[thigh] + m.thigh_length_m * dt;
    const V3 ds = Rx(knee0) * dt;
    j[foot] = j[shank] + m.shank_length_m * ds;
    BodyPrimitive th = MakePrimitive(thigh, j[thigh], j[shank], r_th, r_th, 0.68 * r_th, 0.68 * r_th);
    th.bulge_joint = p + "knee_flex";
    th.bulge_per_rad = 0.05;  // thigh muscles: +8 % radius at 90 degrees of extra flexion
    prims.push_back(th);
    BodyPrimitive sh = MakePrimitive(shank, j[shank], j[foot], 0.8 * r_ca, 0.8 * r_ca, 0.58 * r_ca, 0.58 * r_ca);
    sh.mid_bulge_m = 0.25 * r_ca;
    prims.push_back(sh);
    prims.push_back(MakePrimitive(foot, V3(j[foot].x(), 0.045 * s, j[foot].z() - 0.03 * s),
                                  V3(j[foot].x() * 1.05, 0.03 * s, j[foot].z() + 0.16 * s), 0.035 * s, 0.04 * s, 0.045 * s, 0.028 * s));
  }
  return body;
}

}  // namespace

Result<ParametricBody> BuildParametricBody(const BodyMeasurements& m) {
  Result<ParametricBody> skeleton = BuildSkeleton(m);
  if (!skeleton.ok()) return skeleton.status();
  ParametricBody body = std::move(skeleton).value();
  const double s = m.height_m / 1.70;
  const auto& prims = body.primitives;

  // Rest surface.
  const JointAngles rest_angles = RestAngles();
  const PosedField field(body, rest_angles);
  V3 lo = V3::Constant(1e9), hi = V3::Constant(-1e9);
  for (const BodyPrimitive& p : prims) {
    const double r = std::max({p.r1_a, p.r2_a, p.r1_b, p.r2_b}) + p.mid_bulge_m + 0.05 * s;
    lo = lo.cwiseMin(p.a - V3::Constant(r)).cwiseMin(p.b - V3::Constant(r));
    hi = hi.cwiseMax(p.a + V3::Constant(r)).cwiseMax(p.b + V3::Constant(r));
  }
  lo -= V3::Constant(3 * m.resolution_m);
  hi += V3::Constant(3 * m.resolution_m);
  // Surface nets can pinch where two sheets pass through one cell (the armpits) or make a sliver where
  // the surface passes through a grid node; a shifted grid usually does not, so try a few offsets.
  Status mesh_ok = Status::Ok();
  for (int attempt = 0; attempt < 4; ++attempt) {
    const V3 shift = V3::Constant(attempt * m.resolution_m / 4.0);
    body.rest = SurfaceNets([&](const V3& x) { return field(x); }, lo - shift, hi, m.resolution_m);
    mesh_ok = CheckClosedOrientedManifold(body.rest.faces, "parametric body (resolution " + std::to_string(m.resolution_m) + " m)");
    if (!mesh_ok.ok()) {
      // Name where: the first vertex of the offending edge.
      const size_t open = mesh_ok.message().find("edge (");
      if (open != std::string::npos) {
        const int v = std::stoi(mesh_ok.message().substr(open + 6));
        if (v >= 0 && v < body.rest.vertices.rows())
          mesh_ok = Status::Error(mesh_ok.message() + " near (" + std::to_string(body.rest.vertices(v, 0)) + ", " +
                                  std::to_string(body.rest.vertices(v, 1)) + ", " + std::to_string(body.rest.vertices(v, 2)) + ") m");
      }
      continue;
    }
    const Eigen::Index n = body.rest.vertices.rows();
#pragma omp parallel for schedule(static)
    for (Eigen::Index v = 0; v < n; ++v) body.rest.vertices.row(v) = field.Project(body.rest.vertices.row(v).transpose()).transpose();
    mesh_ok = ValidateMesh(body.rest.vertices, body.rest.faces, "parametric body");
    if (mesh_ok.ok()) break;
  }
  if (!mesh_ok.ok()) return Status::Error(mesh_ok.message() + "; try another resolution_m");
  const Eigen::Index nv = body.rest.vertices.rows();
  {
    const auto nbrs = VertexNeighbors(body.rest.faces, static_cast<int>(nv));
    std::vector<int> all(nv);
    std::iota(all.begin(), all.end(), 0);
    field.Relax(&body.rest.vertices, nbrs, all, 10);
  }
  if (Status st = ValidateMesh(body.rest.vertices, body.rest.faces, "parametric body"); !st.ok()) return st;

  // Skinning weights from the distance to each bone's primitives. A bone shares a vertex with the
  // nearest bone when it is the nearest one's neighbour in the skeleton (elbow, knee, hip, spine, ...)
  // over a wide band, so the skin of a bending joint stretches over a wide band as real skin does,
  // not over one narrow ring; other bones (the other thigh, the torso under an arm) only where their
  // surfaces nearly touch.
  auto with_primitive = [&](int b) { return b == kClavicleL || b == kClavicleR ? body.parent[b] : b; };
  auto adjacent = [&](int a, int b) {
    return (body.parent[a] >= 0 && with_primitive(body.parent[a]) == b) || (body.parent[b] >= 0 && with_primitive(body.parent[b]) == a);
  };
  // The hip's band is wider: a crouch turns the thigh by 85 degrees under a large pelvis, and over a
  // narrower band the skin of the buttocks stretches beyond 2x in area (docs/BODIES.md).
  const double band = 0.06 * s, hip_band = 0.25 * s, sigma = 0.012 * s;
  auto is_hip = [](int a, int b) {
    const bool ta = a == kThighL || a == kThighR, tb = b == kThighL || b == kThighR;
    return (ta && (b == kPelvis || b == kLumbar)) || (tb && (a == kPelvis || a == kLumbar));
  };
  std::vector<Prim> pr = Prims(body);
  body.weights.resize(nv);
  body.dominant_bone.resize(nv);
  for (Eigen::Index v = 0; v < nv; ++v) {
    const V3 x = body.rest.vertices.row(v);
    std::array<double, kNumBones> d;
    d.fill(1e9);
    for (const Prim& p : pr) d[p.p.bone] = std::min(d[p.p.bone], PrimitiveValue(p.p, p.cap_a, p.cap_b, 0.0, x));
    const double dmin = *std::min_element(d.begin(), d.end());
    const int nearest = static_cast<int>(std::min_element(d.begin(), d.end()) - d.begin());
    std::vector<std::pair<double, int>> w;
    for (int b = 0; b < kNumBones; ++b) {
      const double gap = d[b] - dmin;
      if (b == nearest) w.emplace_back(1.0, b);
      else if (adjacent(b, nearest) || is_hip(b, nearest)) {
        const double wb = is_hip(b, nearest) ? hip_band : band;
        if (gap < wb) w.emplace_back((1 - gap / wb) * (1 - gap / wb), b);
      }
      else if (gap < 6 * sigma) w.emplace_back(std::exp(-gap / sigma), b);
    }
    std::sort(w.begin(), w.end(), std::greater<>());
    w.resize(std::min<size_t>(w.size(), 4));
    double total = 0;
    for (const auto& e : w) total += e.first;
    auto& out = body.weights[v];
    out.fill({kPelvis, 0.0});
    for (size_t k = 0; k < w.size(); ++k) out[k] = {w[k].second, w[k].first / total};
    body.dominant_bone[v] = w[0].second;
  }
  return body;
}

Result<ParametricBody> ParametricBodyLike(const ParametricBody& like, const BodyMeasurements& m) {
  Result<ParametricBody> skeleton = BuildSkeleton(m);
  if (!skeleton.ok()) return skeleton.status();
  ParametricBody body = std::move(skeleton).value();
  if (body.primitives.size() != like.primitives.size())
    return Status::Error("the body to take the mesh from has " + std::to_string(like.primitives.size()) + " primitives, this one " +
                         std::to_string(body.primitives.size()));
  // Each bone's map from `like` to `body`: along the bone's primitive scaled by the ratio of its
  // lengths, across it by the ratio of its mean radii (a clavicle moves with the chest's primitive).
  std::array<int, kNumBones> primitive_of;
  primitive_of.fill(-1);
  for (size_t i = 0; i < body.primitives.size(); ++i) primitive_of[body.primitives[i].bone] = static_cast<int>(i);
  primitive_of[kClavicleL] = primitive_of[body.parent[kClavicleL]];
  primitive_of[kClavicleR] = primitive_of[body.parent[kClavicleR]];
  auto mean_radius = [](const BodyPrimitive& p) { return 0.25 * (p.r1_a + p.r2_a + p.r1_b + p.r2_b) + 0.5 * p.mid_bulge_m; };
  auto carry = [&](int bone, const V3& x) -> V3 {
    const BodyPrimitive& from = like.primitives[primitive_of[bone]];
    const BodyPrimitive& to = body.primitives[primitive_of[bone]];
    const double from_length = (from.b - from.a).norm(), to_length = (to.b - to.a).norm();
    const V3 from_axis = (from.b - from.a) / from_length, to_axis = (to.b - to.a) / to_length;
    const V3 d = x - from.a;
    const double t = d.dot(from_axis);
    V3 across = d - t * from_axis;
    across -= across.dot(to_axis) * to_axis;
    return to.a + t * (to_length / from_length) * to_axis + (mean_radius(to) / mean_radius(from)) * across;
  };
  const Eigen::Index nv = like.rest.vertices.rows();
  body.rest.faces = like.rest.faces;
  body.rest.vertices.resize(nv, 3);
  body.weights = like.weights;
  body.dominant_bone = like.dominant_bone;
  const PosedField field(body, RestAngles());
#pragma omp parallel for schedule(static)
  for (Eigen::Index v = 0; v < nv; ++v) {
    const V3 x = like.rest.vertices.row(v).transpose();
    V3 y = V3::Zero();
    for (const auto& [bone, w] : like.weights[v])
      if (w > 0) y += w * carry(bone, x);
    body.rest.vertices.row(v) = field.Project(y).transpose();
  }
  const auto nbrs = VertexNeighbors(body.rest.faces, static_cast<int>(nv));
  std::vector<int> all(nv);
  std::iota(all.begin(), all.end(), 0);
  field.Relax(&body.rest.vertices, nbrs, all, 10);
  if (Status st = ValidateMesh(body.rest.vertices, body.rest.faces, "parametric body with the mesh of another"); !st.ok()) return st;
  std::vector<int> faces(body.rest.faces.rows());
  std::iota(faces.begin(), faces.end(), 0);
  // Faces turned into the body (a normal against the field's gradient): no more than on `like` itself.
  const std::vector<int> folded = field.FoldedFaces(body.rest.vertices, body.rest.faces, faces, 0.0);
  const size_t folded_before = PosedField(like, RestAngles()).FoldedFaces(like.rest.vertices, like.rest.faces, faces, 0.0).size();
  if (folded.size() > folded_before)
    return Status::Error("the parametric body's mesh carried to these measurements folds over at " + std::to_string(folded.size()) +
                         " faces (the first: face " + std::to_string(folded.front()) + "; the mesh's own body: " +
                         std::to_string(folded_before) + "); the measurements are too far from the mesh's own");
  return body;
}

}  // namespace kgd
