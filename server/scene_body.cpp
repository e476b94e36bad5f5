#include "server/scene_body.h"

#include <algorithm>
#include <future>
#include <list>
#include <mutex>
#include <sstream>

#include "core/mesh/mesh_io.h"
#include "core/scene/builtin_scenes.h"

namespace kgd::server {
namespace {

using Poses = std::shared_ptr<const BodyMotion>;
struct Built {
  Poses poses;
  std::string error;
};
constexpr size_t kKept = 4;  // (scene, measurements) kept in memory

}  // namespace

struct SceneBodies::Impl {
  Builder build;
  std::mutex mu;
  std::list<std::pair<std::string, std::shared_future<Built>>> kept;  // most recent first
};

SceneBodies::SceneBodies(Builder build) : impl_(std::make_unique<Impl>()) {
  impl_->build = build ? std::move(build) : [](const std::string& name, const std::vector<std::string>& measurements) {
    return ResolveBuiltinScene(name, measurements);
  };
}
SceneBodies::~SceneBodies() = default;

ServiceStatus SceneBodies::Obj(const std::string& name, const std::vector<std::string>& measurements, const std::string& pose, std::string* obj) {
  const std::vector<BuiltinSceneInfo> infos = BuiltinSceneInfos();
  const auto info = std::find_if(infos.begin(), infos.end(), [&](const BuiltinSceneInfo& i) { return i.name == name; });
  if (info == infos.end()) return {ServiceCode::kNotFound, "there is no built-in scene '" + name + "'"};
  if (!info->parametric_body) return {ServiceCode::kNotFound, "scene '" + name + "' has no parametric body"};
  Result<std::optional<BodyMeasurements>> parsed = ParseBodyMeasurements(measurements);
  if (!parsed.ok()) return {ServiceCode::kInvalidArgument, parsed.message()};

  std::vector<std::string> sorted = measurements;
  std::sort(sorted.begin(), sorted.end());
  std::string key = name;
  for (const std::string& m : sorted) key += " " + m;
  std::shared_future<Built> built;
  bool mine = false;
  std::promise<Built> promise;
  {
    std::lock_guard lock(impl_->mu);
    auto it = std::find_if(impl_->kept.begin(), impl_->kept.end(), [&](const auto& e) { return e.first == key; });
    if (it != impl_->kept.end()) {
      impl_->kept.splice(impl_->kept.begin(), impl_->kept, it);
    } else {
      impl_->kept.emplace_front(key, promise.get_future().share());
      if (impl_->kept.size() > kKept) impl_->kept.pop_back();
      mine = true;
    }
    built = impl_->kept.front().second;
  }
  if (mine) {
    Built b;
    Result<SceneSpec> scene = impl_->build(name, measurements);
    if (!scene.ok())
      b.error = scene.message();
    else if (!scene->motion)
      b.error = "scene '" + name + "' has no body motion";
    else
      b.poses = std::make_shared<const BodyMotion>(std::move(*scene->motion));
    if (!b.poses) {  // not kept: a later request tries again
      std::lock_guard lock(impl_->mu);
      impl_->kept.remove_if([&](const auto& e) { return e.first == key; });
    }
    promise.set_value(std::move(b));
  }
  const Built& b = built.get();
  if (!b.poses) return {ServiceCode::kInvalidArgument, "scene '" + name + "': " + b.error};

  const Positions* x = nullptr;
  if (pose == "rest") {
    x = &b.poses->rest;
  } else if (pose == "deformed") {
    x = &b.poses->deformed;
  } else if (pose.rfind("frame_", 0) == 0) {
    char* end = nullptr;
    const long k = std::strtol(pose.c_str() + 6, &end, 10);
    if (pose.size() > 6 && *end == '\0' && k >= 1 && k <= static_cast<long>(b.poses->frames.size())) x = &b.poses->frames[k - 1];
  }
  if (!x)
    return {ServiceCode::kNotFound, "scene '" + name + "' has no pose '" + pose + "' (rest, deformed, frame_1..frame_" +
                                        std::to_string(b.poses->frames.size()) + ")"};
  std::ostringstream out;
  const std::string file = name + "-" + pose + ".obj";
  out << "# kgd: the parametric body of scene " << name << ", " << pose << " pose (m)\n";
  if (Status st = WriteObj(out, file, *x, b.poses->faces); !st.ok()) return {ServiceCode::kInternal, st.message()};
  *obj = out.str();
  return ServiceStatus::Ok();
}

}  // namespace kgd::server
