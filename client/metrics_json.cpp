#include "client/metrics_json.h"

#include "proto/records.h"

namespace kgd::cli {

nlohmann::ordered_json MotionsJson(const std::vector<MotionMetrics>& motions) {
  nlohmann::ordered_json a = nlohmann::ordered_json::array();
  for (const MotionMetrics& m : motions)
    a.push_back({{"name", m.name}, {"role", ToString(m.role)}, {"weight", m.weight}, {"energy_J", m.energy_J},
                 {"reinforced_energy_J", m.reinforced_energy_J}, {"reinforced_density_J_per_m2", m.reinforced_density_J_per_m2},
                 {"density_ratio", m.density_ratio}, {"solver_iterations", m.solver_iterations}, {"simulation_s", m.simulation_s}});
  return a;
}

nlohmann::ordered_json MetricsJson(const v1::IterationMetrics& m) {
  const BesoIteration it = MetricsFromProto(m);
  nlohmann::ordered_json j;
  j["iteration"] = it.iteration;
  j["status"] = m.solve_status();
#define KGD_METRIC_JSON(type, name, what) j[#name] = it.name;
  KGD_BESO_METRICS(KGD_METRIC_JSON)
#undef KGD_METRIC_JSON
  // The pressure limit's figures only for a job with one (a peak of 0 would read as no pressure).
  if (!(it.peak_pressure_Pa > 0)) {
    j.erase("peak_pressure_Pa");
    j.erase("pressure_kept_out_fraction");
  }
  j["motions"] = MotionsJson(it.motions);
  return j;
}

}  // namespace kgd::cli
