#include "core/body/parametric_body.h"

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <numbers>

#include "core/mesh/surface_nets.h"
#include "core/mesh/topology.h"

namespace kgd {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

using V3 = Eigen::Vector3d;

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

double SmoothMin(double a, double b, double k) {
  if (k <= 0) return std::min(a, b);
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

const char* const kAngleNames[] = {
    "trunk_pitch", "spine01_flex", "spine02_flex", "spine03_flex", "spine04_flex", "spine05_flex",
    "neck01_flex", "neck02_flex", "head_flex",
    "l_clav_protr", "l_clav_elev", "l_shoulder_abd", "l_shoulder_flex", "l_elbow_flex",
    "r_clav_protr", "r_clav_elev", "r_shoulder_abd", "r_shoulder_flex", "r_elbow_flex",
    "l_hip_flex", "l_knee_flex", "l_ankle_flex", "r_hip_flex", "r_knee_flex", "r_ankle_flex"};

double Angle(const JointAngles& angles, const std::string& name) {
  auto it = angles.find(name);
  if (it != angles.end()) return it->second;
  static const JointAngles rest = RestAngles();
  auto r = rest.find(name);
  return r == rest.end() ? 0.0 : r->second;
}
// Angle relative to the rest pose: what the skeleton rotates by.
double Rel(const JointAngles& angles, const std::string& name) {
  static const JointAngles rest = RestAngles();
  auto r = rest.find(name);
  return Angle(angles, name) - (r == rest.end() ? 0.0 : r->second);
}

Eigen::Isometry3d RotationAbout(const V3& pivot, const Eigen::Matrix3d& r) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = r;
  t.translation() = pivot - r * pivot;
  return t;
}
Eigen::Matrix3d Rx(double a) { return Eigen::AngleAxisd(a, V3::UnitX()).toRotationMatrix(); }
Eigen::Matrix3d Ry(double a) { return Eigen::AngleAxisd(a, V3::UnitY()).toRotationMatrix(); }
Eigen::Matrix3d Rz(double a) { return Eigen::AngleAxisd(a, V3::UnitZ()).toRotationMatrix(); }

}  // namespace

const char* BoneName(int bone) {
  static const char* const kNames[kNumBones] = {
      "pelvis", "lumbar", "thorax", "chest", "neck", "head",
      "l_clavicle", "l_upper_arm", "l_forearm", "l_hand", "r_clavicle", "r_upper_arm", "r_forearm", "r_hand",
      "l_thigh", "l_shank", "l_foot", "r_thigh", "r_shank", "r_foot"};
  return bone >= 0 && bone < kNumBones ? kNames[bone] : "?";
}

std::vector<std::string> JointAngleNames() { return {std::begin(kAngleNames), std::end(kAngleNames)}; }

JointAngles RestAngles() {
  return {{"l_shoulder_abd", 45 * kDeg}, {"r_shoulder_abd", 45 * kDeg}, {"l_elbow_flex", 15 * kDeg},
          {"r_elbow_flex", 15 * kDeg},   {"l_knee_flex", 5 * kDeg},     {"r_knee_flex", 5 * kDeg}};
}

Status ValidateJointAngles(const JointAngles& angles) {
  const std::vector<std::string> names = JointAngleNames();
  for (const auto& [name, value] : angles) {
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      std::string list;
      for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
      return Status::Error("joint angle '" + name + "' is not known (known: " + list + ")");
    }
    if (!std::isfinite(value) || std::abs(value) > 3.2)
    {
      char value_text[32];
      std::snprintf(value_text, sizeof value_text, "%g", value);
      return Status::Error("joint angle '" + name + "' = " + value_text + " rad is not a finite angle in [-pi, pi]");
    }
  }
  return Status::Ok();
}

namespace {

// Every measurement with its name and the range that keeps the construction meaningful.
struct MeasurementField {
  const char* name;
  double BodyMeasurements::*field;
  double lo, hi;
};
constexpr MeasurementField kMeasurementFields[] = {
    {"height_m", &BodyMeasurements::height_m, 1.2, 2.2},
    {"chest_circumference_m", &BodyMeasurements::chest_circumference_m, 0.6, 1.6},
    {"waist_circumference_m", &BodyMeasurements::waist_circumference_m, 0.5, 1.6},
    {"hip_circumference_m", &BodyMeasurements::hip_circumference_m, 0.6, 1.6},
    {"upper_arm_circumference_m", &BodyMeasurements::upper_arm_circumference_m, 0.18, 0.50},
    {"forearm_circumference_m", &BodyMeasurements::forearm_circumference_m, 0.15, 0.40},
    {"thigh_circumference_m", &BodyMeasurements::thigh_circumference_m, 0.35, 0.85},
    {"calf_circumference_m", &BodyMeasurements::calf_circumference_m, 0.25, 0.55},
    {"upper_arm_length_m", &BodyMeasurements::upper_arm_length_m, 0.2, 0.42},
    {"forearm_length_m", &BodyMeasurements::forearm_length_m, 0.18, 0.36},
    {"thigh_length_m", &BodyMeasurements::thigh_length_m, 0.3, 0.6},
    {"shank_length_m", &BodyMeasurements::shank_length_m, 0.3, 0.6},
    {"resolution_m", &BodyMeasurements::resolution_m, 0.004, 0.013},
};

}  // namespace

Result<std::optional<BodyMeasurements>> ParseBodyMeasurements(const std::vector<std::string>& items) {
  if (items.empty()) return std::optional<BodyMeasurements>();
  BodyMeasurements m;
  for (const std::string& item : items) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos) return Status::Error("--body " + item + ": expected name=value, e.g. upper_arm_circumference_m=0.32");
    const std::string text = item.substr(eq + 1);
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size()) return Status::Error("--body " + item + ": '" + text + "' is not a number");
    if (Status st = SetMeasurement(&m, item.substr(0, eq), v); !st.ok()) return st;
  }
  return std::optional<BodyMeasurements>(m);
}

Status SetMeasurement(BodyMeasurements* m, const std::string& name, double value) {
  std::string known;
  for (const MeasurementField& f : kMeasurementFields) {
    if (name == f.name) {
      m->*f.field = value;
      return Status::Ok();
    }
    known += (known.empty() ? "" : ", ") + std::string(f.name);
  }
  return Status::Error("body measurement '" + name + "' is not known (known: " + known + ")");
}

Status ValidateMeasurements(const BodyMeasurements& m) {
  for (const MeasurementField& f : kMeasurementFields) {
    const double v = m.*f.field;
    if (!std::isfinite(v) || v < f.lo || v > f.hi)
    {
      char message[160];
      std::snprintf(message, sizeof message, "body measurement %s = %g is outside [%g, %g]", f.name, v, f.lo, f.hi);
      return Status::Error(message);
    }
  }
  const double s = m.height_m / 1.70;
  const double legs = 0.075 * s + m.thigh_length_m + m.shank_length_m;
  const double torso = m.height_m - 0.245 * s - legs;
  if (torso < 0.3 * s)
    return Status::Error("body measurements: thigh_length_m + shank_length_m = " + std::to_string(m.thigh_length_m + m.shank_length_m) +
                         " leave only " + std::to_string(torso) + " m of torso for height_m = " + std::to_string(m.height_m));
  return Status::Ok();
}

namespace {

// Everything about a primitive the evaluation needs, including its cap semi-axes.
struct Prim {
  BodyPrimitive p;
  double cap_a, cap_b;
  std::string group;  // primitives of one group are joined first (a chain), groups then blend
};

// Distance-like value of one primitive at rest-space point q; `bulge` >= 0 widens it.
double PrimitiveValue(const BodyPrimitive& p, double cap_a, double cap_b, double bulge, const V3& q) {
  const V3 ab = p.b - p.a;
  const double len = ab.norm();
  const V3 e = ab / len;
  const double s = (q - p.a).dot(e);
  const double t = std::clamp(s / len, 0.0, 1.0);
  const V3 v = q - (p.a + t * len * e);
  const double v_ax = s - t * len;
  const double v1 = v.dot(p.u1), v2 = v.dot(p.u2);
  const double sine = std::sin(kPi * t);
  const double mid = p.mid_bulge_m * sine;
  const double growth = 1.0 + bulge * sine;
  double r1 = (1 - t) * p.r1_a + t * p.r1_b + mid;
  double r2 = (1 - t) * p.r2_a + t * p.r2_b + mid;
  if (!p.bulge_anterior_only) r1 *= growth;
  if (!p.bulge_anterior_only || v2 > 0) r2 *= growth;
  const double cap = v_ax < 0 ? cap_a : cap_b;
  const double q1 = v1 / r1, q2 = v2 / r2, q3 = v_ax / cap;
  const double qn = std::sqrt(q1 * q1 + q2 * q2 + q3 * q3);
  const double vn = std::sqrt(v1 * v1 + v2 * v2 + v_ax * v_ax);
  if (qn < 1e-12) return -std::min(r1, r2);
  return vn / qn * (qn - 1.0);
}

}  // namespace

namespace {

// The full primitive records: cap semi-axes and blend groups follow from the bone kind, so that
// BodyPrimitive stays a plain description.
std::vector<Prim> Prims(const ParametricBody& body) {
  std::vector<Prim> out;
  for (const BodyPrimitive& p : body.primitives) {
    Prim q{p, std::sqrt(p.r1_a * p.r2_a), std::sqrt(p.r1_b * p.r2_b), ""};
    const double s = body.measurements.height_m / 1.70;
    switch (p.bone) {
      case kPelvis: q.cap_a = 0.07 * s; q.group = "torso"; break;
      case kLumbar: case kThorax: q.cap_a = q.cap_b = 0.6 * std::min({p.r1_a, p.r2_a, p.r1_b, p.r2_b}); q.group = "torso"; break;
      case kChest: q.cap_a = 0.6 * std::min(p.r1_a, p.r2_a); q.cap_b = 0.045 * s; q.group = "torso"; break;
      case kNeck: q.group = "neck"; break;
      case kHead: q.cap_a = 0.07 * s; q.cap_b = 0.09 * s; q.group = "head"; break;
      case kUpperArmL: case kForearmL: q.group = "arm_l"; break;
      case kUpperArmR: case kForearmR: q.group = "arm_r"; break;
      case kHandL: case kHandR: q.cap_b = 0.03 * s; q.group = p.bone == kHandL ? "hand_l" : "hand_r"; break;
      case kThighL: case kShankL: q.group = "leg_l"; break;
      case kThighR: case kShankR: q.group = "leg_r"; break;
      case kFootL: case kFootR: q.cap_a = 0.04 * s; q.cap_b = 0.03 * s; q.group = p.bone == kFootL ? "foot_l" : "foot_r"; break;
      default: q.group = BoneName(p.bone);
    }
    out.push_back(q);
  }
  return out;
}

// Bend of a joint (rad): the rotation between the two bones' frames, 0 for a straight chain.
double Bend(const Eigen::Isometry3d& parent, const Eigen::Isometry3d& child) {
  return Eigen::AngleAxisd(parent.linear().transpose() * child.linear()).angle();
}

// Blend radius inside a chain grows with the joint's bend away from rest: a fillet where the inner
// sides of a bent elbow or knee meet, nothing (a plain union) for a straight chain.
double ChainBlend(const Eigen::Isometry3d& parent, const Eigen::Isometry3d& child) {
  return 0.04 * (1.0 - std::cos(Bend(parent, child)));
}

// Blend radii between groups (m, before scaling by height).
double GroupBlend(const std::string& g) {
  if (g == "neck") return 0.03;
  if (g == "head") return 0.02;
  if (g.rfind("arm", 0) == 0) return 0.05;
  if (g.rfind("hand", 0) == 0) return 0.015;
  if (g.rfind("leg", 0) == 0) return 0.04;
  if (g.rfind("foot", 0) == 0) return 0.02;
  return 0.03;
}

}  // namespace

std::array<Eigen::Isometry3d, kNumBones> BoneTransforms(const ParametricBody& body, const JointAngles& angles) {
  std::array<Eigen::Isometry3d, kNumBones> t;
  const auto& j = body.joint;
  auto rel = [&](const char* n) { return Rel(angles, n); };
  t[kPelvis] = RotationAbout(j[kPelvis], Rx(rel("trunk_pitch")));
  t[kLumbar] = t[kPelvis] * RotationAbout(j[kLumbar], Rx(rel("spine05_flex") + rel("spine04_flex")));
  t[kThorax] = t[kLumbar] * RotationAbout(j[kThorax], Rx(rel("spine03_flex")));
  t[kChest] = t[kThorax] * RotationAbout(j[kChest], Rx(rel("spine02_flex") + rel("spine01_flex")));
  t[kNeck] = t[kChest] * RotationAbout(j[kNeck], Rx(rel("neck01_flex") + rel("neck02_flex")));
  t[kHead] = t[kNeck] * RotationAbout(j[kHead], Rx(rel("head_flex")));
  for (int side = 0; side < 2; ++side) {
    const double m = side == 0 ? 1.0 : -1.0;  // left (+x) or right (-x)
    const std::string p = side == 0 ? "l_" : "r_";
    const int clav = side == 0 ? kClavicleL : kClavicleR, upper = side == 0 ? kUpperArmL : kUpperArmR;
    const int fore = side == 0 ? kForearmL : kForearmR, hand = side == 0 ? kHandL : kHandR;
    t[clav] = t[kChest] * RotationAbout(j[clav], Ry(-m * rel((p + "clav_protr").c_str())) * Rz(m * rel((p + "clav_elev").c_str())));
    t[upper] = t[clav] * RotationAbout(j[upper], Rx(-rel((p + "shoulder_flex").c_str())) * Rz(m * rel((p + "shoulder_abd").c_str())));
    const V3 upper_dir = (j[fore] - j[upper]).normalized();
    const V3 elbow_axis = upper_dir.cross(V3::UnitZ()).normalized();
    t[fore] = t[upper] * RotationAbout(j[fore], Eigen::AngleAxisd(rel((p + "elbow_flex").c_str()), elbow_axis).toRotationMatrix());
    t[hand] = t[fore];
    const int thigh = side == 0 ? kThighL : kThighR, shank = side == 0 ? kShankL : kShankR, foot = side == 0 ? kFootL : kFootR;
    t[thigh] = t[kPelvis] * RotationAbout(j[thigh], Rx(-rel((p + "hip_flex").c_str())));
    t[shank] = t[thigh] * RotationAbout(j[shank], Rx(rel((p + "knee_flex").c_str())));
    t[foot] = t[shank] * RotationAbout(j[foot], Rx(rel((p + "ankle_flex").c_str())));
  }
  return t;
}

namespace {

// The implicit body with everything precomputed for one pose.
class PosedField {
 public:
  PosedField(const ParametricBody& body, const JointAngles& angles) : prims_(Prims(body)) {
    const auto t = BoneTransforms(body, angles);
    const double s = body.measurements.height_m / 1.70;
    for (const Prim& p : prims_) {
      inverse_.push_back(t[p.p.bone].inverse());
      bulge_.push_back(p.p.bulge_joint.empty() ? 0.0 : p.p.bulge_per_rad * std::max(0.0, Rel(angles, p.p.bulge_joint)));
    }
    // Groups in order of first appearance; inside a group, blend radius from the bend between
    // consecutive members.
    for (size_t i = 0; i < prims_.size(); ++i) {
      int g = -1;
      for (size_t k = 0; k < groups_.size(); ++k)
        if (group_names_[k] == prims_[i].group) g = static_cast<int>(k);
      if (g < 0) {
        g = static_cast<int>(groups_.size());
        groups_.emplace_back();
        group_names_.push_back(prims_[i].group);
        double k = GroupBlend(prims_[i].group);
        // The groin: a fillet that widens as the hip flexes, like the crease of the real body.
        if (prims_[i].p.bone == kThighL || prims_[i].p.bone == kThighR) k += 0.06 * (1.0 - std::cos(Bend(t[kPelvis], t[prims_[i].p.bone])));
        group_blend_.push_back(k * s);
      }
      ChainLink link;
      if (!groups_[g].empty()) {
        const Prim& prev = prims_[groups_[g].back().index];
        link.blend = ChainBlend(t[prev.p.bone], t[prims_[i].p.bone]) * s;
        // Posed joint and the bisector of the joint's concave side: where the fillet belongs.
        link.joint = t[prims_[i].p.bone] * prims_[i].p.a;
        const V3 toward = t[prev.p.bone].linear() * (prev.p.b - prev.p.a).normalized();
        const V3 away = t[prims_[i].p.bone].linear() * (prims_[i].p.b - prims_[i].p.a).normalized();
        const V3 inner = away - toward;
        link.inner = inner.norm() > 1e-9 ? V3(inner.normalized()) : V3::Zero();
        const V3 along = away + toward;
        link.along = along.norm() > 1e-9 ? V3(along.normalized()) : V3::Zero();
        // The crease flattens: where forearm meets biceps (calf meets thigh) the flesh gives way, so
        // the girth round a bent joint stays what it was. Two rigid round limbs meeting at a bend
        // theta have a concave side reaching r / cos(theta / 2) from the joint instead of r, and the
        // fillet swells it by a quarter of its radius more; the pinch takes both back, fading over
        // 1.25 r on either side of the bisector plane. Without it the sleeve of a bent elbow is
        // stretched 1.2-1.35 all round (the MakeHuman elbow: 1.00-1.03), see docs/RESULTS.md.
        const double bend = std::min(Bend(t[prev.p.bone], t[prims_[i].p.bone]), 150 * kDeg);
        const double r = 0.5 * (prev.cap_b + prims_[i].cap_a);
        link.pinch = r * (1.0 / std::cos(0.5 * bend) - 1.0) + 0.25 * link.blend;
        link.pinch_width = 1.25 * r;
      }
      link.index = static_cast<int>(i);
      groups_[g].push_back(link);
    }
  }
  double operator()(const V3& x) const {
    double f = 0;
    for (size_t g = 0; g < groups_.size(); ++g) {
      double gv = 0;
      for (size_t m = 0; m < groups_[g].size(); ++m) {
        const ChainLink& link = groups_[g][m];
        const Prim& p = prims_[link.index];
        const double v = PrimitiveValue(p.p, p.cap_a, p.cap_b, bulge_[link.index], inverse_[link.index] * x);
        if (m == 0) {
          gv = v;
          continue;
        }
        const double concave = ConcaveWeight(link, x);
        gv = SmoothMin(gv, v, link.blend * concave);
        const double a = (x - link.joint).dot(link.along) / link.pinch_width;
        if (link.pinch > 0 && std::abs(a) < 1) gv += link.pinch * concave * (1 - a * a) * (1 - a * a);
      }
      f = g == 0 ? gv : SmoothMin(f, gv, group_blend_[g]);
    }
    return f;
  }
  V3 Gradient(const V3& x) const {
    const double h = 1e-6;
    V3 g;
    for (int k = 0; k < 3; ++k) {
      V3 a = x, b = x;
      a[k] += h;
      b[k] -= h;
      g[k] = ((*this)(a) - (*this)(b)) / (2 * h);
    }
    return g;
  }
  // Tangential smoothing on the level set: each active vertex moves halfway to its neighbours' mean,
  // within the tangent plane, and is projected back. Evens out triangle sizes and unfolds pinches.
  // With `rest`, each vertex moves instead towards where its edges would have their rest lengths
  // (a spring relaxation): the skin keeps its metric where it slides, rather than evening out
  // triangle sizes, which stretches compressed skin sideways.
  void Relax(Positions* x, const std::vector<std::vector<int>>& nbrs, const std::vector<int>& active, int iterations,
             const Positions* rest = nullptr) const {
    Positions next = *x;
    for (int it = 0; it < iterations; ++it) {
#pragma omp parallel for schedule(static)
      for (size_t i = 0; i < active.size(); ++i) {
        const int v = active[i];
        if (nbrs[v].empty()) continue;
        const V3 p = x->row(v).transpose();
        V3 mean = V3::Zero();
        for (int w : nbrs[v]) {
          const V3 q = x->row(w).transpose();
          if (rest == nullptr) {
            mean += q;
            continue;
          }
          const V3 e = p - q;
          const double len = e.norm();
          mean += len > 1e-12 ? V3(q + (rest->row(v) - rest->row(w)).norm() / len * e) : p;
        }
        mean /= static_cast<double>(nbrs[v].size());
        V3 n = Gradient(p);
        if (n.norm() < 1e-9) continue;
        n.normalize();
        V3 d = mean - p;
        d -= d.dot(n) * n;
        next.row(v) = Project(p + 0.5 * d).transpose();
      }
      for (int v : active) x->row(v) = next.row(v);
    }
  }
  // Of the faces `candidates`, those whose normal points into the body (folded over) or that have
  // collapsed.
  std::vector<int> FoldedFaces(const Positions& x, const Faces& faces, const std::vector<int>& candidates, double min_area) const {
    std::vector<char> bad(candidates.size(), 0);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < candidates.size(); ++i) {
      const int f = candidates[i];
      const V3 a = x.row(faces(f, 0)), b = x.row(faces(f, 1)), c = x.row(faces(f, 2));
      const V3 n = (b - a).cross(c - a);
      bad[i] = 0.5 * n.norm() < min_area || n.dot(Gradient((a + b + c) / 3.0)) <= 0;
    }
    std::vector<int> out;
    for (size_t i = 0; i < candidates.size(); ++i)
      if (bad[i]) out.push_back(candidates[i]);
    return out;
  }
  // Newton steps along the gradient onto the zero level set.
  V3 Project(V3 x) const {
    for (int it = 0; it < 8; ++it) {
      const double f = (*this)(x);
      if (std::abs(f) < 1e-9) break;
      const V3 g = Gradient(x);
      const double g2 = g.squaredNorm();
      if (g2 < 1e-12) break;
      x -= f * g / g2;
    }
    return x;
  }

 private:
  std::vector<Prim> prims_;
  std::vector<Eigen::Isometry3d> inverse_;
  std::vector<double> bulge_;
  // A chain member: its primitive and the fillet joining it to the previous member.
  struct ChainLink {
    int index = 0;
    double blend = 0;            // fillet radius (m) at the concave side
    V3 joint = V3::Zero();       // posed joint centre
    V3 inner = V3::Zero();       // unit bisector of the concave side; zero for a straight joint
    V3 along = V3::Zero();       // unit normal of the plane bisecting the bend
    double pinch = 0;            // depth (m) the concave side is drawn in by, at the bisecting plane
    double pinch_width = 1;      // distance (m) from that plane over which the pinch fades out
  };
  // The fillet is confined to the concave side of a bent joint. A blend radius applied all around
  // would swell the joint: where two round cones overlap, smooth-min pushes the surface out by up to
  // a quarter of the radius on every side, and a sleeve over a bent elbow would be stretched 30-40 %
  // around its circumference (the MakeHuman elbow: ~0 %).
  static double ConcaveWeight(const ChainLink& link, const V3& x) {
    const V3 d = x - link.joint;
    const double n = d.norm();
    if (n < 1e-12) return 1.0;
    const double c = link.inner.dot(d) / n;
    return std::max(0.0, c) * std::max(0.0, c);
  }
  std::vector<std::vector<ChainLink>> groups_;
  std::vector<std::string> group_names_;
  std::vector<double> group_blend_;
};

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

}  // namespace

Eigen::Vector3d BoneEnd(const ParametricBody& body, int bone) {
  for (int c = 0; c < kNumBones; ++c)
    if (body.parent[c] == bone) return body.joint[c];  // the first child: spine, limbs
  for (const BodyPrimitive& p : body.primitives)       // hands, feet, head: the tip
    if (p.bone == bone) return p.b;
  return body.joint[bone];
}

Result<ParametricBody> BuildParametricBody(const BodyMeasurements& m) {
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
  // The hip's band is wider: a crouch turns the thigh by 85 degrees under a large pelvis.
  const double band = 0.06 * s, hip_band = 0.10 * s, sigma = 0.012 * s;
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

namespace {

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
const int kSkinRelaxIterations = 40;

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
  if (!active.empty()) field.Relax(x, nbrs, active, kSkinRelaxIterations, &rest);
}

}  // namespace

std::vector<JointAngles> MotionKeyframes(const JointAngles& rest, const JointAngles& pose, int frames) {
  JointAngles r;
  for (const std::string& n : JointAngleNames()) r[n] = Angle(rest, n);
  JointAngles p = r;
  for (const auto& [n, v] : pose) p[n] = v;
  std::vector<JointAngles> keys = {r};
  const int steps = std::max(frames, 1);
  for (int k = 1; k <= steps; ++k) {
    JointAngles f;
    for (const auto& [n, v] : r) f[n] = v + (p.at(n) - v) * k / steps;
    keys.push_back(f);
  }
  return keys;
}

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

namespace {

// Length of the loop where the plane through `c` with unit normal `n` cuts the posed surface, keeping
// the pieces within `cutoff` of c (the loop round one limb, not the other limbs the plane also cuts).
double SectionLength(const Positions& posed, const Faces& f, const V3& c, const V3& n, double cutoff) {
  double length = 0;
  for (Eigen::Index i = 0; i < f.rows(); ++i) {
    V3 pts[2];
    int np = 0;
    for (int k = 0; k < 3 && np < 2; ++k) {
      const V3 p = posed.row(f(i, k)), q = posed.row(f(i, (k + 1) % 3));
      const double dp = (p - c).dot(n), dq = (q - c).dot(n);
      if ((dp < 0) != (dq < 0)) pts[np++] = p + dp / (dp - dq) * (q - p);
    }
    if (np != 2) continue;
    const V3 mid = 0.5 * (pts[0] + pts[1]);
    if ((mid - c).norm() > cutoff) continue;
    length += (pts[1] - pts[0]).norm();
  }
  return length;
}

double LargestRadius(const ParametricBody& body, int bone) {
  double rmax = 0;
  for (const BodyPrimitive& p : body.primitives)
    if (p.bone == bone) rmax = std::max({rmax, p.r1_a, p.r2_a, p.r1_b, p.r2_b});
  return rmax;
}

}  // namespace

double LimbGirth(const ParametricBody& body, const JointAngles& angles, const Positions& posed, int bone, double t) {
  const auto tr = BoneTransforms(body, angles);
  const V3 a = tr[bone] * body.joint[bone], b = tr[bone] * BoneEnd(body, bone);
  return SectionLength(posed, body.rest.faces, a + t * (b - a), (b - a).normalized(), 1.5 * LargestRadius(body, bone));
}

double JointGirth(const ParametricBody& body, const JointAngles& angles, const Positions& posed, int bone) {
  const auto tr = BoneTransforms(body, angles);
  const int parent = body.parent[bone];
  const V3 joint = tr[bone] * body.joint[bone];
  const V3 toward = (joint - tr[parent] * body.joint[parent]).normalized();
  const V3 away = (tr[bone] * BoneEnd(body, bone) - joint).normalized();
  return SectionLength(posed, body.rest.faces, joint, (toward + away).normalized(),
                       1.5 * std::max(LargestRadius(body, bone), LargestRadius(body, parent)));
}

}  // namespace kgd
