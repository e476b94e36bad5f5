#include "client/metrics_json.h"

#include "proto/records.h"

namespace kgd::cli {

nlohmann::ordered_json MetricsJson(const v1::IterationMetrics& m) {
  const BesoIteration it = MetricsFromProto(m);
  nlohmann::ordered_json j;
  j["iteration"] = it.iteration;
  j["status"] = m.solve_status();
#define KGD_METRIC_JSON(type, name, what) j[#name] = it.name;
  KGD_BESO_METRICS(KGD_METRIC_JSON)
#undef KGD_METRIC_JSON
  return j;
}

}  // namespace kgd::cli
