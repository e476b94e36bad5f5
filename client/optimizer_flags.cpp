#include "client/optimizer_flags.h"

#include <cmath>
#include <limits>

namespace kgd::cli {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
bool Given(double v) { return !std::isnan(v); }
bool Given(int v) { return v != OptimizerFlags::kUnset; }
}  // namespace

OptimizerFlags::OptimizerFlags() : budget(kNaN), er(kNaN), ar(kNaN), penalty(kNaN), d_min(kNaN), tau(kNaN), grad_tol(kNaN) {}

void AddOptimizerFlags(CLI::App* d, OptimizerFlags* o) {
  // NaN marks a flag as not given, so "--budget nan" must not pass as one; infinities are no setting either.
  const CLI::Validator finite(
      [](std::string& text) {
        double v = 0;
        return CLI::detail::lexical_cast(text, v) && std::isfinite(v) ? std::string() : "'" + text + "' is not a finite number";
      },
      "FINITE");
  d->add_option("--budget", o->budget, "Reinforced area at the end, as a fraction of the garment area, in (0, 1] (default: the scene's)")
      ->check(finite);
  d->add_option("--iterations", o->iterations, "Stop after this BESO iteration at the latest (default 400)");
  d->add_option("--er", o->er, "Evolutionary ratio ER: the target area shrinks by this fraction per iteration (default 0.015)")
      ->check(finite);
  d->add_option("--ar-max", o->ar, "Admission limit AR_max: at most this fraction of the garment turns reinforced per iteration (default 0.015)")
      ->check(finite);
  d->add_option("--penalty", o->penalty, "Interpolation exponent p, >= 1 (default 1.6)")->check(finite);
  d->add_option("--d-min", o->d_min, "Design value of the soft material in the sensitivity formula (default 0.001)")->check(finite);
  d->add_option("--tau", o->tau, "Stop when the objective changes by less than tau (relative) ... (default 1e-3)")->check(finite);
  d->add_option("--window", o->window, "... over this many iterations, with the budget reached (default 5)");
  d->add_flag("--keep-attachments", o->keep_attachments, "Attachment triangles stay reinforced");
  d->add_flag("--no-averaging", o->no_averaging, "No temporal averaging of the sensitivities");
  d->add_flag("--average-with-raw", o->average_with_raw,
              "Average with the previous iteration's filtered, not averaged, sensitivities (the authors' code)");
  d->add_option("--max-newton", o->max_newton, "Solver iteration limit per BESO iteration (default 200)")->check(CLI::PositiveNumber);
  d->add_option("--grad-tol", o->grad_tol, "Solver gradient tolerance, dimensionless (default 1e-4, see docs/MODEL.md)")
      ->check(CLI::PositiveNumber & finite);
}

v1::OptimizerSettings ToProto(const OptimizerFlags& o) {
  v1::OptimizerSettings s;
  if (Given(o.budget)) s.set_budget(o.budget);
  if (Given(o.er)) s.set_evolutionary_ratio(o.er);
  if (Given(o.ar)) s.set_admission_ratio(o.ar);
  if (Given(o.penalty)) s.set_penalty(o.penalty);
  if (Given(o.d_min)) s.set_d_min(o.d_min);
  if (Given(o.tau)) s.set_tau(o.tau);
  if (Given(o.window)) s.set_converge_window(o.window);
  if (Given(o.iterations)) s.set_max_iterations(o.iterations);
  if (Given(o.max_newton)) s.set_max_newton_iterations(o.max_newton);
  if (Given(o.grad_tol)) s.set_grad_tol(o.grad_tol);
  s.set_keep_attachments(o.keep_attachments);
  s.set_no_temporal_averaging(o.no_averaging);
  s.set_average_with_raw(o.average_with_raw);
  return s;
}

bool AnyDesignFlagGiven(const OptimizerFlags& o) {
  return Given(o.budget) || Given(o.er) || Given(o.ar) || Given(o.penalty) || Given(o.d_min) || Given(o.tau) || Given(o.window) ||
         o.keep_attachments || o.no_averaging || o.average_with_raw;
}

}  // namespace kgd::cli
