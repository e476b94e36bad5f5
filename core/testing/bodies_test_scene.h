// A small scene of several bodies for tests (the design loop, scene files): a sleeve cut from a capsule
// limb whose joint flexes by 0.8 rad, worn by limbs of other radii with the same mesh topology.
#pragma once

#include <algorithm>
#include <string>
#include <tuple>
#include <vector>

#include "core/testing/motion_test_scene.h"
#include "core/scene/scene.h"
#include "core/scene/shapes.h"

namespace kgd {

// A limb of radius `radius_m` whose joint flexes by 0.8 rad, meshed with rings every 1.5 cm whatever
// its radius, so limbs of other radii (same `around`) share its topology.
inline BodyMotion FlexingLimb(double radius_m, int around = 16, std::vector<double>* axial = nullptr) {
  LimbShape shape;
  shape.radius_m = radius_m;
  shape.around = around;
  shape.spacing_m = 0.015;
  const TriMesh rest = LimbRest(shape, axial);
  return BodyMotion{rest.faces, rest.vertices, LimbPosed(shape, rest.vertices, 0.8), {}};
}

// The flexing sleeve on a range of limbs (name, radius, weight): the first is the scene's own.
inline Result<SceneSpec> SleeveForBodies(const std::vector<std::tuple<std::string, double, double>>& bodies, BodyObjective objective) {
  std::vector<double> axial;
  SceneSpec s;
  s.name = "sleeve_for_bodies";
  s.motion = FlexingLimb(std::get<1>(bodies.front()), 16, &axial);
  KGD_RETURN_IF_ERROR(CutTestSleeve(s.motion->faces, axial, &s));
  for (const auto& [name, radius, weight] : bodies) s.bodies.push_back({name, weight, FlexingLimb(radius)});
  s.body_objective = objective;
  return s;
}

}  // namespace kgd
