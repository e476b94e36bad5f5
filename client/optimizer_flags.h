// The optimizer's command-line flags, shared by `kgd design` (local) and `kgd submit` (service): both
// turn them into a kgd.v1.OptimizerSettings and from there into BESO settings (proto/job_spec.h), so a
// job gives the same design run either way.
#pragma once

#include <CLI/CLI.hpp>

#include "kgd/v1/kgd.pb.h"

namespace kgd::cli {

struct OptimizerFlags {
  // Unset: NaN / unset_int (a value given, even a bad one, is passed on and then validated).
  static constexpr int kUnset = -2147483647 - 1;
  double budget, er, ar, penalty, d_min, tau, grad_tol;
  int iterations = kUnset, window = kUnset, max_newton = kUnset;
  bool keep_attachments = false, no_averaging = false, average_with_raw = false;
  OptimizerFlags();
};

void AddOptimizerFlags(CLI::App* command, OptimizerFlags* flags);
v1::OptimizerSettings ToProto(const OptimizerFlags& flags);
// True when any flag other than --iterations, --max-newton and --grad-tol was given.
bool AnyDesignFlagGiven(const OptimizerFlags& flags);

}  // namespace kgd::cli
