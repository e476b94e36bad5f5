#include "job/design_job.h"

#include <cmath>
#include <sstream>
#include <tuple>

#include "core/beso/baselines.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/simulate.h"
#include "core/util/pinned_kernels.h"
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
  Result<BesoSettings> settings = SettingsOfJob(optimizer, scene.budget, scene.max_pressure_Pa);
  if (!settings.ok()) return settings.status();
  ApplySolverOverrides(optimizer, &scene.solver);
  KGD_RETURN_IF_ERROR(ApplyMotionWeights(optimizer, &scene));
  DesignJob job;
  job.header.scene = std::move(scene_name);
  job.header.body = std::move(body);
  job.header.kernels = RunningKernels();
  job.header.grad_tol = scene.solver.grad_tol;
  job.header.max_newton_iterations = scene.solver.max_iterations;
  job.header.settings = *settings;
  job.header.garment = scene.garment;
  job.header.initial = scene.initial;
  job.header.rest_area_m2 = FaceAreas(scene.garment.vertices, scene.garment.faces);
  job.header.attachment_faces = scene.attachment_faces;
  job.header.cloth_thickness_m = scene.cloth.thickness_m;
  job.header.reinforced_thickness_m = scene.reinforced.thickness_m;
  if (scene.body) job.header.body_mesh = *scene.body;
  job.header.motions = MotionsOfJob(scene, *settings);
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
  // The solves as the job ran them (its quality), not the rebuilt scene's defaults.
  if (header.grad_tol > 0) scene.solver.grad_tol = header.grad_tol;
  if (header.max_newton_iterations > 0) scene.solver.max_iterations = header.max_newton_iterations;
  // The motions weigh what the job gave them (the stored /job motions), not the rebuilt scene's defaults.
  for (SceneMotion& m : scene.motions)
    for (const MotionMetrics& stored : header.motions)
      if (stored.name == m.name) m.weight = stored.weight;
  DesignJob job;
  job.scene = std::move(scene);
  job.header = std::move(header);
  job.history = std::move(history);
  return job;
}

Result<SceneSpec> RebuildSceneOfDesignFile(const std::string& path, const DesignFileHeader& h) {
  Result<SceneSpec> scene = ResolveScene(h.scene, SplitWords(h.body));
  if (!scene.ok()) return Status::Error(path + ": the job's scene '" + h.scene + "' cannot be rebuilt: " + scene.message());
  return scene;
}

Result<SceneSpec> SceneOfDesignFile(const std::string& path, const DesignFileHeader& h) {
  Result<SceneSpec> scene = RebuildSceneOfDesignFile(path, h);
  if (scene.ok()) KGD_RETURN_IF_ERROR(CheckStoredGarment(*scene, h, path));
  return scene;
}

Result<std::vector<BesoIteration>> RunDesignJob(const DesignJob& job, const std::function<bool(const BesoIteration&)>& on_iteration) {
  return RunBeso(job.scene, job.settings(), on_iteration, job.history.empty() ? nullptr : &job.history);
}

Result<DesignEvaluation> EvaluateDesign(const DesignJob& job, const BesoIteration& first, const BesoIteration& last) {
  DesignEvaluation e;
  e.iteration = last.iteration;
  if (first.iteration != 0) return Status::Error("evaluate: `first` is iteration " + std::to_string(first.iteration) + ", not 0");
  const double full_density = first.reinforced_density_J_per_m2;
  SceneSpec scene = job.scene;
  scene.design = last.design;
  std::vector<std::string> notes;
  if (scene.motion && !scene.motion->frames.empty()) {
    const bool body = scene.body && scene.body->faces.rows() == scene.motion->faces.rows();
    Result<std::vector<SimulationResult>> frames = SimulateFrames(scene);
    if (!frames.ok()) return frames.status().WithContext("evaluate over the motion: ");
    for (size_t k = 0; k < frames->size(); ++k) {
      const SimulationResult& r = (*frames)[k];
      e.frames.push_back({r.positions, body ? scene.motion->frames[k] : Positions(), r.face_density_Pa, r.solve.energy_J, ToString(r.solve.status),
                          body ? r.skin.pressure_Pa : Eigen::VectorXd()});
    }
  } else {
    notes.push_back("no motion frames: the scene has one pose");
  }
  if (NothingToResist(first)) {
    notes.push_back("no baselines: the fully reinforced design stores no energy");
  } else {
    // The bands centre where the fully reinforced garment works hardest (as `kgd baselines` does). A
    // resumed job holds iteration 0's metrics only: its energies are simulated again.
    Eigen::VectorXd weight;
    if (first.energy_density_Pa.size() == job.header.rest_area_m2.size()) {
      weight = first.energy_density_Pa.cwiseProduct(job.header.rest_area_m2);
    } else {
      SceneSpec full = job.scene;
      full.design.assign(full.garment.faces.rows(), 1);
      Result<SimulationResult> r = SimulateScene(full);
      if (!r.ok()) return r.status().WithContext("evaluate: the fully reinforced design: ");
      weight = r->face_energy_J;
    }
    Result<BaselineComparison> cmp = CompareWithBaselines(scene, last.design, weight);
    if (!cmp.ok()) {
      notes.push_back("no baselines: " + cmp.message());
    } else {
      const double garment_area = job.header.rest_area_m2.sum();
      for (const auto& [name, design, r] : {std::tuple{"line", &cmp->line, &cmp->line_result}, std::tuple{"x", &cmp->x, &cmp->x_result}}) {
        EvaluatedBaseline b;
        b.name = name;
        b.design = *design;
        b.positions = r->positions;
        b.energy_density_Pa = r->face_density_Pa;
        b.area_fraction = r->reinforced_area_m2 / garment_area;
        b.energy_J = r->solve.energy_J;
        b.reinforced_energy_J = r->reinforced_energy_J;
        b.reinforced_density_J_per_m2 = r->reinforced_density_J_per_m2;
        b.density_ratio = full_density > 0 ? r->reinforced_density_J_per_m2 / full_density : 0;
        b.status = ToString(r->solve.status);
        e.baselines.push_back(std::move(b));
      }
    }
  }
  for (size_t i = 0; i < notes.size(); ++i) e.note += (i ? "; " : "") + notes[i];
  return e;
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
