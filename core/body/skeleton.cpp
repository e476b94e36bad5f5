// The parametric body's skeleton: bones, joint angles, bone transforms of a pose, motion keyframes.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/body/implicit_body.h"
#include "core/body/parametric_body.h"

namespace kgd {
namespace body_internal {
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

}  // namespace body_internal

namespace {
using namespace body_internal;
const char* const kAngleNames[] = {
    "trunk_pitch", "spine01_flex", "spine02_flex", "spine03_flex", "spine04_flex", "spine05_flex",
    "neck01_flex", "neck02_flex", "head_flex",
    "l_clav_protr", "l_clav_elev", "l_shoulder_abd", "l_shoulder_flex", "l_elbow_flex",
    "r_clav_protr", "r_clav_elev", "r_shoulder_abd", "r_shoulder_flex", "r_elbow_flex",
    "l_hip_flex", "l_knee_flex", "l_ankle_flex", "r_hip_flex", "r_knee_flex", "r_ankle_flex"};

Eigen::Isometry3d RotationAbout(const V3& pivot, const Eigen::Matrix3d& r) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = r;
  t.translation() = pivot - r * pivot;
  return t;
}

}  // namespace
using body_internal::Angle;
using body_internal::kDeg;
using body_internal::V3;

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

Eigen::Vector3d BoneEnd(const ParametricBody& body, int bone) {
  for (int c = 0; c < kNumBones; ++c)
    if (body.parent[c] == bone) return body.joint[c];  // the first child: spine, limbs
  for (const BodyPrimitive& p : body.primitives)       // hands, feet, head: the tip
    if (p.bone == bone) return p.b;
  return body.joint[bone];
}

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

}  // namespace kgd
