// The parametric body of a built-in scene, posed as the scene poses it, for the studio page's
// "built-in body" (GET /v1/scenes/{name}/body/{rest,deformed,frame_K}.obj, server/http_gateway.h).
// The scene is built as a job builds it (ResolveBuiltinScene, core/scene/builtin_scenes.h, through the
// scene cache: the first request for a scene and measurements takes as long as a job's set-up, later
// ones read the cache), and its motion's poses are kept in memory for the last few (scene,
// measurements) asked for; requests for the same one while it is built wait for it. Geometry only.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/scene/scene.h"
#include "server/job_service.h"

namespace kgd::server {

class SceneBodies {
 public:
  // How a scene is built: ResolveBuiltinScene by default (a test gives its own).
  using Builder = std::function<Result<SceneSpec>(const std::string& name, const std::vector<std::string>& measurements)>;
  explicit SceneBodies(Builder build = nullptr);
  ~SceneBodies();

  // The OBJ of `pose` ("rest", "deformed" or "frame_K", K = 1.. the scene's frames) of scene `name`'s
  // body made to `measurements` ("name=value", as JobSpec.body). NOT_FOUND: an unknown scene, one
  // without the parametric body, a frame it does not have; INVALID_ARGUMENT: a bad measurement.
  ServiceStatus Obj(const std::string& name, const std::vector<std::string>& measurements, const std::string& pose, std::string* obj);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kgd::server
