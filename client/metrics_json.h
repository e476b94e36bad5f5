// One iteration's figures as the JSON the CLI prints (SI field names), for `kgd design`, `kgd designs`,
// `kgd watch`, `kgd job` and `kgd get` alike: the iteration, the solver's status, and every figure of
// KGD_BESO_METRICS (core/beso/design_loop.h) under its own name.
#pragma once

#include <nlohmann/json.hpp>

#include "kgd/v1/kgd.pb.h"

namespace kgd::cli {

nlohmann::ordered_json MetricsJson(const v1::IterationMetrics& m);

}  // namespace kgd::cli
