// The optimizer's command-line flags, shared by `kgd design` (local) and `kgd submit` (service): both
// turn them into a kgd.v1.OptimizerSettings and from there into BESO settings (proto/job_spec.h), so a
// job gives the same design run either way. The BESO flags come from the settings lists of
// core/beso/beso.h (KGD_BESO_VALUES, KGD_BESO_SWITCHES); two solver flags follow them.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "core/beso/beso.h"
#include "kgd/v1/kgd.pb.h"

namespace kgd::cli {

struct OptimizerFlags {
  // Unset: NaN / kUnset (a value given, even a bad one, is passed on and then validated).
  static constexpr int kUnset = -2147483647 - 1;
#define KGD_DECLARE_VALUE_FLAG(type, name, default_value, flag, help) type name;
  KGD_BESO_VALUES(KGD_DECLARE_VALUE_FLAG)
#undef KGD_DECLARE_VALUE_FLAG
  // A switch's member is true when its flag was given (the switch turned away from its default).
#define KGD_DECLARE_SWITCH_FLAG(name, default_value, flag, proto_field, help) bool name = false;
  KGD_BESO_SWITCHES(KGD_DECLARE_SWITCH_FLAG)
#undef KGD_DECLARE_SWITCH_FLAG
  double grad_tol;
  int max_newton = kUnset;
  std::string quality;  // empty: not given
  // --motion-weight NAME=W (repeatable): the weight of the scene's motion NAME; the last given wins.
  std::vector<std::string> motion_weights;
  OptimizerFlags();
};

void AddOptimizerFlags(CLI::App* command, OptimizerFlags* flags);
v1::OptimizerSettings ToProto(const OptimizerFlags& flags);
// True when any BESO flag other than --iterations, a motion weight or a solver flag (--quality,
// --grad-tol, --max-newton) was given.
bool AnyDesignFlagGiven(const OptimizerFlags& flags);

}  // namespace kgd::cli
