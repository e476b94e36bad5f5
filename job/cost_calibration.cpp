#include "job/cost_calibration.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "core/scene/scene_cache.h"

namespace kgd {

std::string LocalCostCalibrationFile() {
  const std::string dir = SceneCacheDir();
  return dir.empty() ? "" : (std::filesystem::path(dir) / "cost_calibration.json").string();
}

MachineFactor ReadMachineFactor(const std::string& path) {
  if (path.empty()) return {};
  std::ifstream in(path);
  if (!in) return {};
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object() || !j.contains("factor") || !j.contains("jobs") || !j["factor"].is_number() || !j["jobs"].is_number_integer()) return {};
  const double factor = j["factor"].get<double>();
  const int jobs = j["jobs"].get<int>();
  const double weight_s = j.contains("weight_s") && j["weight_s"].is_number() ? j["weight_s"].get<double>() : 0;
  if (!(factor >= 1.0 / 20 && factor <= 20) || jobs < 0 || !(weight_s >= 0 && weight_s < 1e12)) return {};
  return {.factor = factor, .jobs = jobs, .weight_s = weight_s};
}

Quality QualityOfJob(const std::string& name) {
  const Result<Quality> q = QualityFromName(name);
  return q.ok() ? *q : Quality::kStandard;
}

double PredictedSolvesSeconds(int garment_faces, Quality quality, int later, int simulations) {
  // The solves' share does not depend on the budget (BesoSettings): only the iteration count would.
  return PredictJobCost({.garment_faces = garment_faces, .frames = 0, .builtin_body = false, .quality = quality, .simulations = simulations}, {})
      .solves_s(later);
}

std::map<std::string, double> PredictedSceneSeconds(const BuiltinSceneInfo& scene, double machine_factor) {
  BesoSettings settings;
  settings.budget = scene.budget < 1 ? scene.budget : settings.budget;
  std::map<std::string, double> out;
  for (const QualityPreset& q : QualityPresets())
    out[q.name] = PredictJobCost({.garment_faces = scene.garment_faces,
                                  .frames = scene.frames,
                                  .builtin_body = scene.parametric_body,
                                  .quality = q.quality,
                                  .simulations = static_cast<int>(scene.motions.size())},
                                 settings)
                      .total_s(machine_factor);
  return out;
}

void RecordDesignTime(const std::string& path, double predicted_s, double measured_s) {
  if (path.empty()) return;
  const MachineFactor f = LearnMachineFactor(ReadMachineFactor(path), predicted_s, measured_s);
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
  // Another kgd may write at the same time: each writes its own temporary file, and the last rename wins.
  const std::string tmp = path + ".tmp" + std::to_string(getpid());
  {
    std::ofstream out(tmp);
    out << nlohmann::json{{"factor", f.factor}, {"jobs", f.jobs}, {"weight_s", f.weight_s}}.dump() << "\n";
    if (!out) {
      std::filesystem::remove(tmp, ec);
      return;
    }
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) std::filesystem::remove(tmp, ec);
}

}  // namespace kgd
