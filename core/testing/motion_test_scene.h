// A small scene of several motions for tests (scene files, the job path): a sleeve cut from a capsule
// limb (16 vertices around) with three motions over its rest pose: the joint flexing (resisted),
// extending (allowed, weight 0.5, through two frames) and flexing further (allowed, weight 0).
#pragma once

#include <algorithm>
#include <string>
#include <tuple>
#include <vector>

#include "core/scene/scene.h"
#include "core/scene/shapes.h"

namespace kgd {

// The test sleeve on a limb: the faces within 9 cm of the joint along the limb (`axial`: each vertex's
// coordinate along it, m), attached on the outer 2 cm at either end, cut from the scene's motion.
inline Status CutTestSleeve(const Faces& faces, const std::vector<double>& axial, SceneSpec* s) {
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    double lo = 1e300, hi = -1e300;
    for (int k = 0; k < 3; ++k) lo = std::min(lo, axial[faces(f, k)]), hi = std::max(hi, axial[faces(f, k)]);
    if (lo < -0.09 || hi > 0.09) continue;
    s->garment_region.push_back(static_cast<int>(f));
    if (lo < -0.07 || hi > 0.07) s->attachment_body_faces.push_back(static_cast<int>(f));
  }
  s->effects.contact = ContactModel::kUnilateral;
  s->effects.attachments = true;
  return CutGarmentFromMotion(s);
}

inline Result<SceneSpec> ThreeMotionSleeve() {
  LimbShape shape;
  shape.around = 16;
  std::vector<double> axial;
  const TriMesh rest = LimbRest(shape, &axial);
  SceneSpec s;
  s.name = "three_motion_sleeve";
  const std::vector<std::tuple<std::string, MotionRole, double, std::vector<double>>> motions = {
      {"flex", MotionRole::kResist, 1.0, {0.8}}, {"extend", MotionRole::kAllow, 0.5, {-0.3, -0.6}}, {"flex_more", MotionRole::kAllow, 0.0, {1.1}}};
  for (const auto& [name, role, weight, angles] : motions) {
    SceneMotion m{name, role, weight, BodyMotion{rest.faces, rest.vertices, {}, {}}};
    for (double angle : angles) m.pose.frames.push_back(LimbPosed(shape, rest.vertices, angle));
    m.pose.deformed = m.pose.frames.back();
    s.motions.push_back(std::move(m));
  }
  s.motion = s.motions.front().pose;
  KGD_RETURN_IF_ERROR(CutTestSleeve(rest.faces, axial, &s));
  KGD_RETURN_IF_ERROR(ValidateSceneMotions(s));
  return s;
}

}  // namespace kgd
