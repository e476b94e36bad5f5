#include "core/body/implicit_body.h"

#include <algorithm>
#include <cmath>

namespace kgd::body_internal {

double SmoothMin(double a, double b, double k) {
  if (k <= 0) return std::min(a, b);
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

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

}  // namespace kgd::body_internal
