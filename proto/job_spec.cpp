#include "proto/job_spec.h"
#include "core/mesh/mesh_io.h"
#include "core/scene/scene_file.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/paper_scenes.h"
#include "core/beso/quality.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <type_traits>
#include <sstream>

namespace kgd {
namespace fs = std::filesystem;

namespace {

// Paths in a scene bundle stay inside its folder: relative, without "..".
Status CheckBundlePath(const std::string& name) {
  const fs::path p(name);
  if (name.empty() || p.is_absolute()) return Status::Error("spec.scene_files.files: '" + name + "' must be a relative path");
  for (const fs::path& part : p.lexically_normal())
    if (part == "..") return Status::Error("spec.scene_files.files: '" + name + "' leaves the scene's folder");
  return Status::Ok();
}

// Every path a scene names (meshes, and index lists given as files), with its key, for the bundle check.
std::vector<std::pair<std::string, std::string>> FilesNamed(const v1::Scene& s) {
  std::vector<std::pair<std::string, std::string>> out;
  auto add = [&](const char* key, const std::string& path) { out.emplace_back(key, path); };
  auto add_value = [&](const char* key, const google::protobuf::Value& v) {
    if (v.kind_case() == google::protobuf::Value::kStringValue) add(key, v.string_value());
  };
  if (s.garment().has_rest()) add("garment.rest", s.garment().rest());
  if (s.garment().has_initial()) add("garment.initial", s.garment().initial());
  add_value("garment.region", s.garment().region());
  add_value("garment.seams", s.garment().seams());
  add_value("garment.keep_out", s.garment().keep_out());
  add_value("garment.keep_in", s.garment().keep_in());
  const google::protobuf::Value& design = s.garment().design();
  if (design.has_struct_value())
    if (auto f = design.struct_value().fields().find("reinforced_faces"); f != design.struct_value().fields().end())
      add_value("garment.design.reinforced_faces", f->second);
  if (s.body().has_mesh()) add("body.mesh", s.body().mesh());
  if (s.body().has_rest()) add("body.rest", s.body().rest());
  if (s.body().has_deformed()) add("body.deformed", s.body().deformed());
  for (const std::string& f : s.body().frames()) add("body.frames", f);
  for (const v1::SceneMotion& m : s.motions()) {
    if (m.has_deformed()) add("motions.deformed", m.deformed());
    for (const std::string& f : m.frames()) add("motions.frames", f);
  }
  for (const v1::SceneRangeBody& b : s.bodies()) {
    if (b.has_rest()) add("bodies.rest", b.rest());
    if (b.has_deformed()) add("bodies.deformed", b.deformed());
    for (const std::string& f : b.frames()) add("bodies.frames", f);
  }
  add_value("attachments.faces", s.attachments().faces());
  add_value("attachments.body_faces", s.attachments().body_faces());
  for (const v1::SceneClamp& c : s.clamps()) add_value("clamps.vertices", c.vertices());
  return out;
}

}  // namespace

Result<v1::Scene> ParseSceneJson(const std::string& text, const std::string& source) {
  v1::Scene scene;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(text, &scene, options);
  if (!status.ok()) return Status::Error(source + ": not a kgd.v1.Scene: " + std::string(status.message()));
  return scene;
}

std::string SceneJson(const v1::Scene& scene) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  std::string text;
  // Printing a parsed message cannot fail (no Any fields whose types would need resolving).
  (void)google::protobuf::util::MessageToJsonString(scene, &text, options);
  return text;
}

namespace {

std::string WeightText(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// The spec's motion weights, by name in order: each finite and >= 0.
Status CheckMotionWeightValues(const v1::OptimizerSettings& o) {
  const std::map<std::string, double> weights(o.motion_weights().begin(), o.motion_weights().end());
  for (const auto& [name, w] : weights)
    if (!(w >= 0 && std::isfinite(w))) return Status::Error("motion_weights: motion '" + name + "': weight " + WeightText(w) + " must be finite and >= 0");
  return Status::Ok();
}

// ... and each names one of `motions` of scene `scene`, which has several.
Status CheckMotionWeightNames(const v1::OptimizerSettings& o, const std::vector<std::string>& motions, const std::string& scene) {
  if (o.motion_weights().empty()) return Status::Ok();
  const std::map<std::string, double> weights(o.motion_weights().begin(), o.motion_weights().end());
  std::string list;
  for (const std::string& m : motions) list += (list.empty() ? "'" : ", '") + m + "'";
  if (motions.size() < 2)
    return Status::Error("motion_weights: motion '" + weights.begin()->first + "': scene '" + scene +
                         "' has one motion; weights are for a scene of several");
  for (const auto& [name, w] : weights)
    if (std::find(motions.begin(), motions.end(), name) == motions.end())
      return Status::Error("motion_weights: motion '" + name + "': scene '" + scene + "' has no motion of this name (its motions: " + list + ")");
  return Status::Ok();
}

// A built-in scene's motions by name (no body is built).
std::vector<std::string> BuiltinMotionNames(const std::string& scene) {
  for (const BraceScene& b : BraceScenes())
    if (b.name == scene) {
      std::vector<std::string> names;
      for (const BraceMotion& m : b.motions) names.push_back(m.name);
      return names;
    }
  for (const SizedScene& z : SizedScenes())
    if (z.name == scene) {
      std::vector<std::string> names;
      for (const BodySize& b : z.sizes) names.push_back(b.name);
      return names;
    }
  return {scene};
}

template <typename T>
T ReflectedValue(const google::protobuf::Reflection* r, const v1::OptimizerSettings& o, const google::protobuf::FieldDescriptor* f) {
  if constexpr (std::is_same_v<T, int>) return r->GetInt32(o, f);
  else return r->GetDouble(o, f);
}
}  // namespace

Status CheckSettingsFields() {
  using google::protobuf::FieldDescriptor;
  const google::protobuf::Descriptor* d = v1::OptimizerSettings::descriptor();
  auto check = [&](const char* name, FieldDescriptor::CppType type, bool optional) -> Status {
    const FieldDescriptor* f = d->FindFieldByName(name);
    if (!f || f->cpp_type() != type || f->has_presence() != optional)
      return Status::Error(std::string("kgd.v1.OptimizerSettings.") + name + " is missing or of another kind");
    return Status::Ok();
  };
#define KGD_CHECK_VALUE(type, name, default_value, flag, help) \
  KGD_RETURN_IF_ERROR(check(#name, std::is_same_v<type, int> ? FieldDescriptor::CPPTYPE_INT32 : FieldDescriptor::CPPTYPE_DOUBLE, true));
  KGD_BESO_VALUES(KGD_CHECK_VALUE)
#undef KGD_CHECK_VALUE
#define KGD_CHECK_SWITCH(name, default_value, flag, proto_field, help) \
  KGD_RETURN_IF_ERROR(check(#proto_field, FieldDescriptor::CPPTYPE_BOOL, false));
  KGD_BESO_SWITCHES(KGD_CHECK_SWITCH)
#undef KGD_CHECK_SWITCH
  return Status::Ok();
}

Result<BesoSettings> SettingsOfJob(const v1::OptimizerSettings& o, double scene_budget, double scene_max_pressure_Pa) {
  BesoSettings s;
  s.budget = scene_budget < 1 ? scene_budget : s.budget;
  s.max_pressure_Pa = scene_max_pressure_Pa;
  const google::protobuf::Reflection* r = o.GetReflection();
  const google::protobuf::Descriptor* d = o.GetDescriptor();
  // Set values replace the defaults; switches given turn away from them.
#define KGD_VALUE_OF_JOB(type, name, default_value, flag, help)          \
  if (const google::protobuf::FieldDescriptor* f = d->FindFieldByName(#name); f && r->HasField(o, f)) \
    s.name = ReflectedValue<type>(r, o, f);
  KGD_BESO_VALUES(KGD_VALUE_OF_JOB)
#undef KGD_VALUE_OF_JOB
#define KGD_SWITCH_OF_JOB(name, default_value, flag, proto_field, help) \
  if (const google::protobuf::FieldDescriptor* f = d->FindFieldByName(#proto_field); f && r->GetBool(o, f)) s.name = !(default_value);
  KGD_BESO_SWITCHES(KGD_SWITCH_OF_JOB)
#undef KGD_SWITCH_OF_JOB
  if (Status st = ValidateBesoSettings(s); !st.ok()) return st;
  if (o.has_max_newton_iterations() && o.max_newton_iterations() < 1)
    return Status::Error("max_newton_iterations = " + std::to_string(o.max_newton_iterations()) + " must be >= 1");
  if (o.has_grad_tol() && !(o.grad_tol() > 0 && std::isfinite(o.grad_tol())))
    return Status::Error("grad_tol = " + std::to_string(o.grad_tol()) + " must be finite and > 0");
  if (!o.quality().empty())
    if (Result<Quality> q = QualityFromName(o.quality()); !q.ok()) return q.status();
  KGD_RETURN_IF_ERROR(CheckMotionWeightValues(o));
  return s;
}

void ApplySolverOverrides(const v1::OptimizerSettings& o, SolverSettings* solver) {
  if (o.has_max_newton_iterations()) solver->max_iterations = o.max_newton_iterations();
  if (Result<Quality> q = QualityFromName(o.quality()); !o.quality().empty() && q.ok()) solver->grad_tol = PresetOf(*q).grad_tol;
  if (o.has_grad_tol()) solver->grad_tol = o.grad_tol();
}

Status ApplyMotionWeights(const v1::OptimizerSettings& o, SceneSpec* scene) {
  if (o.motion_weights().empty()) return Status::Ok();
  KGD_RETURN_IF_ERROR(CheckMotionWeightValues(o));
  std::vector<std::string> names;
  for (const SceneMotion& m : MotionsOf(*scene)) names.push_back(m.name);
  KGD_RETURN_IF_ERROR(CheckMotionWeightNames(o, names, scene->name));
  // A scene of several bodies weighs its bodies as motions (MotionsOf).
  for (SceneMotion& m : scene->motions)
    if (const auto it = o.motion_weights().find(m.name); it != o.motion_weights().end()) m.weight = it->second;
  for (SceneBody& b : scene->bodies)
    if (const auto it = o.motion_weights().find(b.name); it != o.motion_weights().end()) b.weight = it->second;
  KGD_RETURN_IF_ERROR(ValidateSceneBodies(*scene).WithContext("motion_weights: "));
  return ValidateSceneMotions(*scene).WithContext("motion_weights: ");
}

Status ValidateJobSpec(const v1::JobSpec& spec) {
  switch (spec.scene_case()) {
    case v1::JobSpec::kBuiltinScene: {
      bool known = false;
      std::string list;
      for (const std::string& n : BuiltinSceneNames()) {
        known |= n == spec.builtin_scene();
        list += (list.empty() ? "" : ", ") + n;
      }
      if (!known) return Status::Error("spec.builtin_scene: '" + spec.builtin_scene() + "' is not a built-in scene (one of: " + list + ")");
      std::vector<std::string> body(spec.body().begin(), spec.body().end());
      Result<std::optional<BodyMeasurements>> m = ParseBodyMeasurements(body);
      if (!m.ok()) return m.status().WithContext("spec.body: ");
      // Each within its range (the parametric body's rule: the worker would refuse the body later).
      if (*m)
        if (Status st = ValidateMeasurements(**m); !st.ok()) return st.WithContext("spec.body: ");
      if (Status st = CheckMotionWeightValues(spec.optimizer()); !st.ok()) return st.WithContext("spec.optimizer: ");
      if (Status st = CheckMotionWeightNames(spec.optimizer(), BuiltinMotionNames(spec.builtin_scene()), spec.builtin_scene()); !st.ok())
        return st.WithContext("spec.optimizer: ");
      break;
    }
    case v1::JobSpec::kSceneFiles: {
      if (spec.body_size() > 0) return Status::Error("spec.body: body overrides apply to built-in scenes, not to scene files");
      if (!spec.scene_files().has_scene()) return Status::Error("spec.scene_files.scene: missing");
      for (const auto& [name, content] : spec.scene_files().files())
        if (Status st = CheckBundlePath(name); !st.ok()) return st;
      for (const auto& [key, path] : FilesNamed(spec.scene_files().scene()))
        if (spec.scene_files().files().count(path) == 0)
          return Status::Error("spec.scene_files.scene." + key + ": '" + path + "' is not among the files sent");
      // What the scene loader would refuse before reading a file: no garment; and meshes that are not
      // meshes (a photo sent as body.obj), by their first bytes.
      if (Status st = CheckSceneHasGarment(SceneJson(spec.scene_files().scene()), "spec.scene_files.scene"); !st.ok()) return st;
      for (const auto& [key, path] : FilesNamed(spec.scene_files().scene()))
        if (key.rfind("body.", 0) == 0 || key.rfind("motions.", 0) == 0 || key.rfind("bodies.", 0) == 0 || key == "garment.rest" ||
            key == "garment.initial")
          if (Status st = CheckMeshBytes(spec.scene_files().files().at(path), path); !st.ok())
            return st.WithContext("spec.scene_files.scene." + key + ": ");
      break;
    }
    default:
      return Status::Error("spec.scene: give builtin_scene or scene_files");
  }
  if (Result<BesoSettings> s = SettingsOfJob(spec.optimizer(), 1.0); !s.ok()) return s.status().WithContext("spec.optimizer: ");
  return Status::Ok();
}

Result<SceneSpec> SceneOfJob(const v1::JobSpec& spec) {
  if (Status st = ValidateJobSpec(spec); !st.ok()) return st;
  if (spec.scene_case() == v1::JobSpec::kBuiltinScene)
    return ResolveScene(spec.builtin_scene(), std::vector<std::string>(spec.body().begin(), spec.body().end()));
  const std::string json = SceneJson(spec.scene_files().scene());
  SceneBundle bundle;
  bundle.scene_json = json;
  for (const auto& [name, content] : spec.scene_files().files()) bundle.files[name] = content;
  Result<SceneSpec> scene = LoadScene(bundle);
  if (!scene.ok()) return Status::Error("spec.scene_files: " + scene.message());
  return scene;
}

Result<v1::SceneFiles> ReadSceneFiles(const std::string& scene_path) {
  std::vector<std::string> names;
  Result<SceneSpec> scene = LoadScene(scene_path, &names);
  if (!scene.ok()) return scene.status();
  v1::SceneFiles files;
  auto read = [](const fs::path& p, std::string* out) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    *out = s.str();
    return static_cast<bool>(in);
  };
  std::string text;
  if (!read(scene_path, &text)) return Status::Error(scene_path + ": cannot read");
  // The loader has accepted it, so a refusal here means the loader and the schema disagree.
  Result<v1::Scene> parsed = ParseSceneJson(text, scene_path);
  if (!parsed.ok()) return parsed.status();
  *files.mutable_scene() = std::move(parsed).value();
  const fs::path dir = fs::path(scene_path).parent_path();
  for (const std::string& name : names) {
    if (Status st = CheckBundlePath(name); !st.ok())
      return Status::Error(scene_path + ": '" + name + "' is outside the scene's folder; a submitted scene sends its folder's files only");
    std::string content;
    if (!read(dir / name, &content)) return Status::Error((dir / name).string() + ": cannot read");
    (*files.mutable_files())[name] = std::move(content);
  }
  return files;
}

std::string JobSceneName(const v1::JobSpec& spec) {
  if (spec.scene_case() == v1::JobSpec::kBuiltinScene) return spec.builtin_scene();
  if (spec.scene_files().scene().has_name()) return spec.scene_files().scene().name();
  return "(scene file)";
}

}  // namespace kgd
