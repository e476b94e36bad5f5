// A built-in scene of the paper's set for tests that look at its garment only: built on the default
// parametric body with the motion cut short to its rest pose, the pose the garment is cut in. The
// garment, the rest body and the start are the built-in scene's bit for bit, without posing the body
// through the motion's frames (most of the time of a scene's build).
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include "core/scene/paper_scenes.h"

namespace kgd {

inline Result<SceneSpec> PaperSceneAtRest(const std::string& name) {
  Result<const ParametricBody*> body = DefaultParametricBody();
  if (!body.ok()) return body.status();
  const std::vector<PaperMotion> motions = PaperMotions();
  auto motion = std::find_if(motions.begin(), motions.end(), [&](const PaperMotion& m) { return m.name == name; });
  if (motion == motions.end()) return Status::Error("no built-in scene of the paper's set is named '" + name + "'");
  PaperMotion at_rest = *motion;
  at_rest.pose = at_rest.rest;
  at_rest.frames = 0;
  return PaperScene(**body, at_rest);
}

}  // namespace kgd
