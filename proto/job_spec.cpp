#include "proto/job_spec.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
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

}  // namespace

Result<BesoSettings> SettingsOfJob(const v1::OptimizerSettings& o, double scene_budget) {
  BesoSettings s;
  s.budget = o.has_budget() ? o.budget() : (scene_budget < 1 ? scene_budget : s.budget);
  if (o.has_evolutionary_ratio()) s.evolutionary_ratio = o.evolutionary_ratio();
  if (o.has_admission_ratio()) s.admission_ratio = o.admission_ratio();
  if (o.has_penalty()) s.penalty = o.penalty();
  if (o.has_d_min()) s.d_min = o.d_min();
  if (o.has_tau()) s.tau = o.tau();
  if (o.has_converge_window()) s.converge_window = o.converge_window();
  if (o.has_max_iterations()) s.max_iterations = o.max_iterations();
  s.keep_attachments = o.keep_attachments();
  s.temporal_averaging = !o.no_temporal_averaging();
  s.average_with_raw = o.average_with_raw();
  if (Status st = ValidateBesoSettings(s); !st.ok()) return st;
  if (o.has_max_newton_iterations() && o.max_newton_iterations() < 1)
    return Status::Error("max_newton_iterations = " + std::to_string(o.max_newton_iterations()) + " must be >= 1");
  if (o.has_grad_tol() && !(o.grad_tol() > 0))
    return Status::Error("grad_tol = " + std::to_string(o.grad_tol()) + " must be > 0");
  return s;
}

void ApplySolverOverrides(const v1::OptimizerSettings& o, SolverSettings* solver) {
  if (o.has_max_newton_iterations()) solver->max_iterations = o.max_newton_iterations();
  if (o.has_grad_tol()) solver->grad_tol = o.grad_tol();
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
      if (Result<std::optional<BodyMeasurements>> m = ParseBodyMeasurements(body); !m.ok())
        return m.status().WithContext("spec.body: ");
      break;
    }
    case v1::JobSpec::kSceneFiles: {
      if (spec.body_size() > 0) return Status::Error("spec.body: body overrides apply to built-in scenes, not to scene files");
      if (!nlohmann::json::accept(spec.scene_files().scene_json()))
        return Status::Error("spec.scene_files.scene_json: not valid JSON");
      for (const auto& [name, content] : spec.scene_files().files())
        if (Status st = CheckBundlePath(name); !st.ok()) return st;
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
  std::string pattern = (fs::temp_directory_path() / "kgd_scene_XXXXXX").string();
  if (!mkdtemp(pattern.data())) return Status::Error("cannot create a temporary folder for the scene files");
  const fs::path dir(pattern);
  Status written = Status::Ok();
  auto write = [&](const std::string& name, const std::string& content) {
    const fs::path p = dir / name;
    std::error_code ec;
    fs::create_directories(p.parent_path(), ec);
    std::ofstream out(p, std::ios::binary);
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    if (!out) written = Status::Error(p.string() + ": cannot write a scene file");
  };
  write("scene.json", spec.scene_files().scene_json());
  for (const auto& [name, content] : spec.scene_files().files()) write(name, content);
  Result<SceneSpec> scene = written.ok() ? LoadScene((dir / "scene.json").string()) : Result<SceneSpec>(written);
  std::error_code ec;
  fs::remove_all(dir, ec);
  if (!scene.ok()) {
    // The temporary folder means nothing to the user: name the scene by its own key paths.
    std::string message = scene.message();
    const std::string prefix = (dir / "").string();
    for (size_t at; (at = message.find(prefix)) != std::string::npos;) message.replace(at, prefix.size(), "");
    return Status::Error("spec.scene_files: " + message);
  }
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
  if (!read(scene_path, files.mutable_scene_json())) return Status::Error(scene_path + ": cannot read");
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
  const nlohmann::json doc = nlohmann::json::parse(spec.scene_files().scene_json(), nullptr, false);
  if (doc.is_object() && doc.contains("name") && doc["name"].is_string()) return doc["name"].get<std::string>();
  return "(scene file)";
}

}  // namespace kgd
