#include "core/beso/design_loop.h"

#include <chrono>

#include "core/scene/simulate.h"

namespace kgd {

Result<std::vector<BesoIteration>> RunBeso(const SceneSpec& scene_in, const BesoSettings& settings,
                                           const std::function<bool(const BesoIteration&)>& on_iteration) {
  if (Status st = ValidateBesoSettings(settings); !st.ok()) return st;
  SceneSpec scene = scene_in;
  const int nf = static_cast<int>(scene.garment.faces.rows());
  std::vector<uint8_t> design(nf, kReinforced);
  scene.design = design;
  Result<GarmentModel> model = BuildGarmentModel(scene);
  if (!model.ok()) return model.status();
  GarmentSystem sys(std::move(model).value(), scene.initial);
  Simulator sim(&sys);
  Positions x = scene.initial;
  const Positions& reference = scene.on_body.rows() ? scene.on_body : scene.initial;

  Eigen::VectorXd area(nf);
  for (int f = 0; f < nf; ++f) area[f] = sys.elements()[f].rest_area_m2;
  const double total_area = area.sum(), final_area = settings.budget * total_area;
  std::vector<uint8_t> locked;
  if (settings.keep_attachments) {
    locked.assign(nf, 0);
    for (int f : scene.attachment_faces) locked[f] = 1;
  }

  std::vector<BesoIteration> history;
  std::vector<double> objective;
  Eigen::VectorXd previous;
  double target = total_area;
  double full_density = 0;
  for (int it = 0; it <= settings.max_iterations; ++it) {
    if (it > 0) {
      // Rank on the last equilibrium and move the design towards the next target area.
      Eigen::VectorXd density;
      sys.FaceDensities(x, &density, nullptr);
      const Eigen::VectorXd s = Sensitivities(density, design, scene.reinforced.youngs_modulus_Pa, scene.cloth.youngs_modulus_Pa,
                                              settings.d_min, settings.penalty);
      Eigen::VectorXd filtered = FilterSensitivities(s, scene.garment.faces, sys.num_vertices(), area);
      if (settings.temporal_averaging && previous.size() == filtered.size()) filtered = 0.5 * (filtered + previous);
      previous = filtered;
      target = NextTargetArea(target, final_area, settings.evolutionary_ratio);
      design = UpdateDesign(filtered, area, design, target, settings.admission_ratio * total_area,
                            settings.keep_attachments ? &locked : nullptr);
      sys.SetDesign(design);
    }
    const auto t0 = std::chrono::steady_clock::now();
    const SolveReport report = sim.Solve(&x, scene.solver);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const SimulationResult r = Summarize(sys, x, reference, report);
    BesoIteration b;
    b.iteration = it;
    b.target_area_m2 = target;
    b.area_fraction = r.reinforced_area_m2 / total_area;
    b.energy_J = report.energy_J;
    b.reinforced_energy_J = r.reinforced_energy_J;
    b.reinforced_density_J_per_m2 = r.reinforced_density_J_per_m2;
    if (it == 0) full_density = r.reinforced_density_J_per_m2;
    b.density_ratio = full_density > 0 ? r.reinforced_density_J_per_m2 / full_density : 0.0;
    b.status = report.status;
    b.solver_iterations = report.iterations;
    b.seconds = seconds;
    b.design = design;
    b.positions = x;
    history.push_back(b);
    if (!report.converged())
      return Status::Error("BESO iteration " + std::to_string(it) + ": the simulation did not converge (" + ToString(report.status) +
                           (report.message.empty() ? "" : ": " + report.message) + ")");
    if (on_iteration && !on_iteration(history.back())) break;
    objective.push_back(report.energy_J);
    if (BesoConverged(objective, target <= final_area * (1 + 1e-12), settings.tau, settings.converge_window)) break;
  }
  return history;
}

}  // namespace kgd
