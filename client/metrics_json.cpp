#include "client/metrics_json.h"

namespace kgd::cli {

nlohmann::ordered_json MetricsJson(const v1::IterationMetrics& m) {
  nlohmann::ordered_json j;
  j["iteration"] = m.iteration();
  j["area_fraction"] = m.area_fraction();
  j["target_area_m2"] = m.target_area_m2();
  j["energy_J"] = m.energy_j();
  j["reinforced_energy_J"] = m.reinforced_energy_j();
  j["reinforced_density_J_per_m2"] = m.reinforced_density_j_per_m2();
  j["density_ratio"] = m.density_ratio();
  j["status"] = m.solve_status();
  j["solver_iterations"] = m.solver_iterations();
  j["cold_restart"] = m.cold_restart();
  j["simulation_s"] = m.simulation_s();
  j["sensitivity_s"] = m.sensitivity_s();
  j["filter_s"] = m.filter_s();
  j["update_s"] = m.update_s();
  j["total_s"] = m.total_s();
  return j;
}

}  // namespace kgd::cli
