// Body measurements: names, ranges, parsing and validation.
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/body/parametric_body.h"

namespace kgd {

namespace {

// Every measurement with its name and the range that keeps the construction meaningful.
struct MeasurementField {
  const char* name;
  double BodyMeasurements::*field;
  double lo, hi;
};
constexpr MeasurementField kMeasurementFields[] = {
    {"height_m", &BodyMeasurements::height_m, 1.2, 2.2},
    {"chest_circumference_m", &BodyMeasurements::chest_circumference_m, 0.6, 1.6},
    {"waist_circumference_m", &BodyMeasurements::waist_circumference_m, 0.5, 1.6},
    {"hip_circumference_m", &BodyMeasurements::hip_circumference_m, 0.6, 1.6},
    {"upper_arm_circumference_m", &BodyMeasurements::upper_arm_circumference_m, 0.18, 0.50},
    {"forearm_circumference_m", &BodyMeasurements::forearm_circumference_m, 0.15, 0.40},
    {"thigh_circumference_m", &BodyMeasurements::thigh_circumference_m, 0.35, 0.85},
    {"calf_circumference_m", &BodyMeasurements::calf_circumference_m, 0.25, 0.55},
    {"upper_arm_length_m", &BodyMeasurements::upper_arm_length_m, 0.2, 0.42},
    {"forearm_length_m", &BodyMeasurements::forearm_length_m, 0.18, 0.36},
    {"thigh_length_m", &BodyMeasurements::thigh_length_m, 0.3, 0.6},
    {"shank_length_m", &BodyMeasurements::shank_length_m, 0.3, 0.6},
    {"resolution_m", &BodyMeasurements::resolution_m, 0.004, 0.013},
};

}  // namespace

Result<std::optional<BodyMeasurements>> ParseBodyMeasurements(const std::vector<std::string>& items) {
  if (items.empty()) return std::optional<BodyMeasurements>();
  BodyMeasurements m;
  for (const std::string& item : items) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos) return Status::Error("--body " + item + ": expected name=value, e.g. upper_arm_circumference_m=0.32");
    const std::string text = item.substr(eq + 1);
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size()) return Status::Error("--body " + item + ": '" + text + "' is not a number");
    if (Status st = SetMeasurement(&m, item.substr(0, eq), v); !st.ok()) return st;
  }
  return std::optional<BodyMeasurements>(m);
}

std::vector<MeasurementRange> BodyMeasurementRanges() {
  const BodyMeasurements defaults;
  std::vector<MeasurementRange> out;
  for (const MeasurementField& f : kMeasurementFields) out.push_back({f.name, defaults.*f.field, f.lo, f.hi});
  return out;
}

Status SetMeasurement(BodyMeasurements* m, const std::string& name, double value) {
  std::string known;
  for (const MeasurementField& f : kMeasurementFields) {
    if (name == f.name) {
      m->*f.field = value;
      return Status::Ok();
    }
    known += (known.empty() ? "" : ", ") + std::string(f.name);
  }
  return Status::Error("body measurement '" + name + "' is not known (known: " + known + ")");
}

Status ValidateMeasurements(const BodyMeasurements& m) {
  for (const MeasurementField& f : kMeasurementFields) {
    const double v = m.*f.field;
    if (!std::isfinite(v) || v < f.lo || v > f.hi)
    {
      char message[160];
      std::snprintf(message, sizeof message, "body measurement %s = %g is outside [%g, %g]", f.name, v, f.lo, f.hi);
      return Status::Error(message);
    }
  }
  const double s = m.height_m / 1.70;
  const double legs = 0.075 * s + m.thigh_length_m + m.shank_length_m;
  const double torso = m.height_m - 0.245 * s - legs;
  if (torso < 0.3 * s)
    return Status::Error("body measurements: thigh_length_m + shank_length_m = " + std::to_string(m.thigh_length_m + m.shank_length_m) +
                         " leave only " + std::to_string(torso) + " m of torso for height_m = " + std::to_string(m.height_m));
  return Status::Ok();
}

}  // namespace kgd
