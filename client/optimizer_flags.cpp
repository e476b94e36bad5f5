#include "client/optimizer_flags.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>

namespace kgd::cli {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
bool Given(double v) { return !std::isnan(v); }
bool Given(int v) { return v != OptimizerFlags::kUnset; }
void Unset(double* v) { *v = kNaN; }
void Unset(int* v) { *v = OptimizerFlags::kUnset; }

void Set(const google::protobuf::FieldDescriptor* f, double v, v1::OptimizerSettings* s) { s->GetReflection()->SetDouble(s, f, v); }
void Set(const google::protobuf::FieldDescriptor* f, int v, v1::OptimizerSettings* s) { s->GetReflection()->SetInt32(s, f, v); }

}  // namespace

OptimizerFlags::OptimizerFlags() {
#define KGD_UNSET_FLAG(type, name, default_value, flag, help) Unset(&name);
  KGD_BESO_VALUES(KGD_UNSET_FLAG)
#undef KGD_UNSET_FLAG
  Unset(&grad_tol);
}

void AddOptimizerFlags(CLI::App* d, OptimizerFlags* o) {
  // NaN marks a flag as not given, so "--budget nan" must not pass as one; infinities are no setting either.
  const CLI::Validator finite(
      [](std::string& text) {
        double v = 0;
        return CLI::detail::lexical_cast(text, v) && std::isfinite(v) ? std::string() : "'" + text + "' is not a finite number";
      },
      "FINITE");
  // A flag named in kPa (--max-pressure-kPa) takes kPa for a setting held in Pa.
  auto kpa = [](const char* flag) { const std::string f = flag; return f.size() > 4 && f.compare(f.size() - 4, 4, "-kPa") == 0; };
#define KGD_ADD_VALUE_FLAG(type, name, default_value, flag, help)                                                          \
  if constexpr (std::is_same_v<type, double>) {                                                                           \
    if (kpa(flag)) d->add_option_function<double>(flag, [o](double v) { o->name = 1e3 * v; }, help)->check(finite);      \
    else d->add_option(flag, o->name, help)->check(finite);                                                               \
  } else {                                                                                                                \
    d->add_option(flag, o->name, help);                                                                                   \
  }
  KGD_BESO_VALUES(KGD_ADD_VALUE_FLAG)
#undef KGD_ADD_VALUE_FLAG
#define KGD_ADD_SWITCH_FLAG(name, default_value, flag, proto_field, help) d->add_flag(flag, o->name, help);
  KGD_BESO_SWITCHES(KGD_ADD_SWITCH_FLAG)
#undef KGD_ADD_SWITCH_FLAG
  d->add_option("--max-newton", o->max_newton, "Solver iteration limit per BESO iteration (default 200)")->check(CLI::PositiveNumber);
  d->add_option("--grad-tol", o->grad_tol, "Solver gradient tolerance, dimensionless (default 1e-4, see docs/MODEL.md); overrides --quality")
      ->check(CLI::PositiveNumber & finite);
  d->add_option("--quality", o->quality,
                "Accuracy preset: draft (grad_tol 1e-3), standard (1e-4) or precise (1e-6); what each costs and buys: docs/ACCURACY.md")
      ->check(CLI::IsMember({"draft", "standard", "precise"}));
  // NAME=W: the weight is a finite number here; whether it is >= 0 and the scene has NAME is the job
  // spec's check (proto/job_spec.h), with the same message as the service's.
  d->add_option("--motion-weight", o->motion_weights,
                "Weight of one of the scene's motions (or bodies), NAME=W with W >= 0 (repeatable), in place of the scene's own; `kgd scenes` lists them")
      ->check(CLI::Validator(
          [](std::string& item) {
            const size_t eq = item.rfind('=');
            double w = 0;
            if (eq == std::string::npos || eq == 0 || !CLI::detail::lexical_cast(item.substr(eq + 1), w) || !std::isfinite(w))
              return "'" + item + "' is not NAME=W with a finite number W";
            return std::string();
          },
          "NAME=W"));
}

v1::OptimizerSettings ToProto(const OptimizerFlags& o) {
  v1::OptimizerSettings s;
  const google::protobuf::Descriptor* d = s.GetDescriptor();
#define KGD_VALUE_TO_PROTO(type, name, default_value, flag, help) \
  if (Given(o.name)) Set(d->FindFieldByName(#name), o.name, &s);
  KGD_BESO_VALUES(KGD_VALUE_TO_PROTO)
#undef KGD_VALUE_TO_PROTO
#define KGD_SWITCH_TO_PROTO(name, default_value, flag, proto_field, help) s.set_##proto_field(o.name);
  KGD_BESO_SWITCHES(KGD_SWITCH_TO_PROTO)
#undef KGD_SWITCH_TO_PROTO
  if (Given(o.max_newton)) s.set_max_newton_iterations(o.max_newton);
  if (Given(o.grad_tol)) s.set_grad_tol(o.grad_tol);
  if (!o.quality.empty()) s.set_quality(o.quality);
  // Each item was checked to be NAME=W with a finite W (AddOptimizerFlags).
  for (const std::string& item : o.motion_weights) {
    const size_t eq = item.rfind('=');
    double w = 0;
    CLI::detail::lexical_cast(item.substr(eq + 1), w);
    (*s.mutable_motion_weights())[item.substr(0, eq)] = w;
  }
  return s;
}

bool AnyDesignFlagGiven(const OptimizerFlags& o) {
  bool any = false;
#define KGD_VALUE_GIVEN(type, name, default_value, flag, help) any |= std::strcmp(#name, "max_iterations") != 0 && Given(o.name);
  KGD_BESO_VALUES(KGD_VALUE_GIVEN)
#undef KGD_VALUE_GIVEN
#define KGD_SWITCH_GIVEN(name, default_value, flag, proto_field, help) any |= o.name;
  KGD_BESO_SWITCHES(KGD_SWITCH_GIVEN)
#undef KGD_SWITCH_GIVEN
  return any || !o.motion_weights.empty() || Given(o.max_newton) || Given(o.grad_tol) || !o.quality.empty();
}

}  // namespace kgd::cli
