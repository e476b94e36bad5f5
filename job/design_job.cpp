#include "job/design_job.h"

#include <cmath>
#include <sstream>

#include "proto/job_spec.h"

namespace kgd {
namespace {

// The first difference between the garment `scene` gives and the one stored, or "".
std::string GarmentDifference(const SceneSpec& scene, const DesignFileHeader& h) {
  auto first_row = [](const auto& now, const auto& stored) {
    for (Eigen::Index r = 0; r < now.rows(); ++r)
      if (!(now.row(r) == stored.row(r))) return r;
    return Eigen::Index(-1);
  };
  if (scene.garment.vertices.rows() != h.garment.vertices.rows() || scene.garment.faces.rows() != h.garment.faces.rows() ||
      scene.initial.rows() != h.initial.rows())
    return std::to_string(scene.garment.vertices.rows()) + " vertices and " + std::to_string(scene.garment.faces.rows()) + " faces now, " +
           std::to_string(h.garment.vertices.rows()) + " and " + std::to_string(h.garment.faces.rows()) + " stored";
  if (Eigen::Index f = first_row(scene.garment.faces, h.garment.faces); f >= 0) return "face " + std::to_string(f) + " has other vertices";
  if (Eigen::Index v = first_row(scene.garment.vertices, h.garment.vertices); v >= 0) return "rest vertex " + std::to_string(v) + " moved";
  if (Eigen::Index v = first_row(scene.initial, h.initial); v >= 0) return "initial (on-body) vertex " + std::to_string(v) + " moved";
  return "";
}

}  // namespace

std::string JoinWords(const std::vector<std::string>& words) {
  std::string s;
  for (const std::string& w : words) s += (s.empty() ? "" : " ") + w;
  return s;
}

std::vector<std::string> SplitWords(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

Result<DesignJob> NewDesignJob(SceneSpec scene, const v1::OptimizerSettings& optimizer, std::string scene_name, std::string body) {
  Result<BesoSettings> settings = SettingsOfJob(optimizer, scene.budget);
  if (!settings.ok()) return settings.status();
  ApplySolverOverrides(optimizer, &scene.solver);
  DesignJob job;
  job.header.scene = std::move(scene_name);
  job.header.body = std::move(body);
  job.header.settings = *settings;
  job.header.garment = scene.garment;
  job.header.initial = scene.initial;
  job.header.rest_area_m2 = FaceAreas(scene.garment.vertices, scene.garment.faces);
  job.header.attachment_faces = scene.attachment_faces;
  job.scene = std::move(scene);
  return job;
}

Status CheckStoredGarment(const SceneSpec& scene, const DesignFileHeader& header, const std::string& source) {
  if (const std::string differs = GarmentDifference(scene, header); !differs.empty())
    return Status::Error(source + ": the scene '" + header.scene + "' no longer gives the garment stored in the file (" + differs +
                         "); was the scene file or kgd changed?");
  return Status::Ok();
}

Result<DesignJob> ResumeDesignJob(SceneSpec scene, DesignFileHeader header, std::vector<BesoIteration> history, const std::string& source,
                                  int max_iterations) {
  KGD_RETURN_IF_ERROR(CheckStoredGarment(scene, header, source));
  if (max_iterations > 0) header.settings.max_iterations = max_iterations;
  KGD_RETURN_IF_ERROR(ValidateBesoSettings(header.settings));
  DesignJob job;
  job.scene = std::move(scene);
  job.header = std::move(header);
  job.history = std::move(history);
  return job;
}

Result<std::vector<BesoIteration>> RunDesignJob(const DesignJob& job, const std::function<bool(const BesoIteration&)>& on_iteration) {
  return RunBeso(job.scene, job.settings(), on_iteration, job.history.empty() ? nullptr : &job.history);
}

int IterationsLeft(const DesignJob& job, const BesoIteration& it) {
  const BesoSettings& s = job.settings();
  if (NothingToResist(it)) return 0;
  const double final_area = s.budget * job.header.rest_area_m2.sum();
  int left = s.converge_window;
  if (it.target_area_m2 > final_area * (1 + 1e-12))
    left += static_cast<int>(std::ceil(std::log(final_area / it.target_area_m2) / std::log(1 - s.evolutionary_ratio)));
  return std::min(left, s.max_iterations - it.iteration);
}

}  // namespace kgd
