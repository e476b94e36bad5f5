// One iteration's figures as the JSON the CLI prints (SI field names), for `kgd design`, `kgd designs`,
// `kgd watch`, `kgd job` and `kgd get` alike: the iteration, the solver's status, and every figure of
// KGD_BESO_METRICS (core/beso/design_loop.h) under its own name, then "motions": one object per motion
// of the scene (name, role, weight, energy_J, reinforced_energy_J, reinforced_density_J_per_m2,
// density_ratio).
#pragma once

#include <nlohmann/json.hpp>

#include "core/beso/design_loop.h"
#include "kgd/v1/kgd.pb.h"

namespace kgd::cli {

nlohmann::ordered_json MetricsJson(const v1::IterationMetrics& m);
// The "motions" array alone (also on the line that ends a design job, for the final design).
nlohmann::ordered_json MotionsJson(const std::vector<MotionMetrics>& motions);

}  // namespace kgd::cli
