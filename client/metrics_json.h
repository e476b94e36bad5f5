// One iteration's figures as the JSON the CLI prints (SI field names), for `kgd design`, `kgd designs`,
// `kgd watch`, `kgd job` and `kgd get` alike.
#pragma once

#include <nlohmann/json.hpp>

#include "kgd/v1/kgd.pb.h"

namespace kgd::cli {

nlohmann::ordered_json MetricsJson(const v1::IterationMetrics& m);

}  // namespace kgd::cli
