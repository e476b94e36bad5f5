// Quasi-static simulation: x* = argmin E(x) over the free coordinates of a GarmentSystem.
//
// Methods:
//  - kNewton (default): projected Newton. Analytic PSD-projected Hessian in a fixed sparse pattern,
//    CHOLMOD supernodal Cholesky with the symbolic analysis done once per Simulator, backtracking
//    Armijo line search on E, adaptive Levenberg-Marquardt damping H + delta I that shrinks after full
//    steps and vanishes at convergence (it guards the singular modes: slack triangles, sliding on the
//    body, free translations) and carries over to warm re-solves, and (optional,
//    SolverSettings::reuse_factorization) reuse of the solve's last factorization as a preconditioner
//    for conjugate gradients when the Hessian has changed little; (SolverSettings::local_steps) local
//    steps where the residual has gathered in a small region (their trials re-evaluate only the region:
//    GarmentSystem::EvaluateFrom, bit-identical to a full evaluation); with unilateral contact the line
//    search puts vertices that a trial step carries into the body back on its surface.
//  - kLbfgs: L-BFGS with a strong Wolfe line search, the paper's method, for comparison.
//
// Convergence (scale-aware): || dE/dx over free coordinates ||_2 <= tolerance_N, with
//   tolerance_N = grad_tol * force_scale_N * sqrt(free vertices),
// i.e. the RMS residual force per vertex is grad_tol times the force that stretches a typical element of
// the stiffest material by 100 % (E t times the mean edge length), whatever the mesh size or material.
// Default grad_tol = 1e-4: the paper's |g| < 1e-7 is in MPa-based units (MN), i.e. 0.1 N, which on the
// paper's 7.1k-vertex arm sleeve (E t = 1995 N/m, mean edge 4.8 mm) is grad_tol = 1.2e-4. What tighter
// values cost and buy: docs/PERFORMANCE.md, "Simulator".
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/sim/garment_system.h"

namespace kgd {

enum class SolverMethod { kNewton, kLbfgs };

// The values are stored in design files (/iterations/status): append new ones, never renumber.
enum class SolveStatus {
  kConverged,
  kLineSearchFailed,        // no step decreased the energy; the residual is reported
  kNotPositiveDefinite,     // factorization failed even after raising the regularization
  kIterationLimit,
  kInvalidState,            // energy undefined (non-finite) at the start
  kStalled,                 // steps kept being cut and the energy stopped falling (round-off) with the
                            // residual above tolerance: a minimum on a gradient jump (the authors'
                            // relaxation) or a tolerance below what double precision resolves
};
// The last value: code that walks or range-checks every status (design files, the protocol's names)
// follows it. Move it when appending.
inline constexpr SolveStatus kLastSolveStatus = SolveStatus::kStalled;
const char* ToString(SolveStatus status);

// What a Newton step did beyond its length, for diagnosing slow convergence (SolverSettings::
// diagnose_steps; NaN and empty otherwise).
struct StepDiagnostics {
  // The step's energy change over the change its quadratic model predicted (1 where the model holds;
  // NaN where it predicted no decrease).
  double model_ratio = std::numeric_limits<double>::quiet_NaN();
  // Per built term (GarmentSystem::term_names() order), how many of its elements the step
  // switched on or off, their energy going from zero to positive or back: membrane faces between slack
  // and stretched, vertices between free and touching the body, fold barriers between idle and active.
  // Where steps keep switching elements the energy's curvature jumps under them and Newton's local
  // convergence is lost (docs/PERFORMANCE.md, "Newton's tail").
  std::vector<int> switched_elements;
  const std::vector<const char*>* term_names = nullptr;  // names for switched_elements
};

// Progress of one iteration, for logging (`kgd simulate --verbose`).
struct IterationInfo {
  int iteration = 0;
  double energy_J = 0;
  double grad_norm_N = 0;
  double step_length = 0;       // line-search alpha of the step just taken
  double regularization = 0;    // delta (N/m) of the step just taken (Newton)
  bool used_pcg = false;
  bool local = false;           // a local step (SolverSettings::local_steps), no global factorization
  StepDiagnostics diagnostics;  // Newton with SolverSettings::diagnose_steps
};

// One line for a progress log (`kgd simulate -v`, `kgd design -v`), without the iteration number:
// "E 0.597104613 J  |g| 2.600e-05 N  alpha 1  delta 0.0061  model 0.98  switched membrane 7, contact 14".
std::string DescribeIteration(const IterationInfo& info);

struct SolverSettings {
  SolverMethod method = SolverMethod::kNewton;
  double grad_tol = 1e-4;
  int max_iterations = 0;           // 0: 200 for Newton, 50000 for L-BFGS
  // Newton: after a solve's first step (always factorized: it meets the caller's change), try PCG
  // preconditioned by that factorization before factorizing again. Off by default: on the relaxed
  // garment-on-body scenes the Hessian moves too much between steps (regimes switch, contact changes)
  // and the PCG attempts fail and are wasted. On smooth problems (bilateral contact, no relaxation) a
  // re-solve then factorizes once instead of twice (docs/PERFORMANCE.md, "Solver options").
  bool reuse_factorization = false;
  int max_pcg_iterations = 25;
  // Newton with unilateral contact: the line search corrects its trial points where the linear model of
  // the skin fails (GarmentSystem::ProjectCrossingsOntoBody). A vertex the step carries from off the body
  // into it goes back to the surface (the Hessian has no contact stiffness off the body, so the penalty
  // would cut the step to a sliver); a vertex in contact that slides along the curved skin goes to the
  // depth the linear model predicted (else the next steps undo micrometre penetrations and lift-offs).
  // It saves most Newton iterations of a BESO re-solve on a sleeve (docs/PERFORMANCE.md, "Solver
  // options"). The equilibrium is unchanged: only trial points differ.
  bool project_contact_crossings = true;
  // Newton: when 99 % of the squared residual sits on coordinates within two rings of the few whose
  // residual is at least 1 % of the largest, and those rings hold at most a third of the unknowns, the
  // step is taken on that region alone (the rest held still): its Hessian block is factorized instead
  // of the whole. The last iterations of a BESO re-solve are often like this -- a pleat opening against
  // the fold barrier, a contact hop -- and converge linearly over a few iterations on ~100 vertices.
  // A local step that the line search rejects falls back to the global one. Equilibria are unchanged
  // (same tolerance on the whole residual); what it saves: docs/PERFORMANCE.md, "Solver options".
  bool local_steps = true;
  int lbfgs_history = 20;
  // The paper's fixed budget: a solve that reaches max_iterations ends there (status kIterationLimit)
  // and its state is taken as the equilibrium (SolveReport::at_equilibrium), as the authors took their
  // 800 L-BFGS iterations. For the accuracy study; off by default.
  bool accept_iteration_limit = false;
  std::function<void(const IterationInfo&)> on_iteration;  // optional
  // Newton, with on_iteration: fill IterationInfo::diagnostics (a Hessian product and a pass over the
  // elements per iteration; for `-v`, not for timed runs).
  bool diagnose_steps = false;
};

struct SolveReport {
  SolveStatus status = SolveStatus::kIterationLimit;
  std::string message;
  int iterations = 0;
  double energy_J = 0;
  EnergyBreakdown energies;
  double grad_norm_N = 0;
  double tolerance_N = 0;
  double seconds = 0;
  // Newton breakdown (seconds) and counters.
  double assembly_s = 0, factorization_s = 0, solve_s = 0, line_search_s = 0;
  int factorizations = 0, pcg_solves = 0, pcg_iterations = 0, energy_evaluations = 0;
  int local_steps = 0;          // accepted Newton steps on a region (SolverSettings::local_steps)
  // Where the evaluations' time went: per built term (GarmentSystem::term_times, evaluation order; the
  // contact term's includes its body-field queries) over the assembly and the line search's trials, and
  // the body-field queries made outside the terms (the line search's contact projection).
  std::vector<GarmentSystem::TermTime> term_times;
  double body_field_query_s = 0;
  // Entries of the Cholesky factor (Newton; 0 before the first factorization): the analysis tries AMD
  // and METIS orderings once per mesh and keeps the sparser.
  double factor_nonzeros = 0;
  // The energy is only C0 (the authors' relaxation): a stall there is the expected end on a gradient jump.
  bool energy_c0 = false;
  bool accept_iteration_limit = false;  // SolverSettings::accept_iteration_limit of the solve
  bool converged() const { return status == SolveStatus::kConverged; }
  // Converged, or stalled on the gradient jump of a C0 energy, where the energy has converged to round-off
  // and no gradient test can pass. Callers that need an equilibrium (the design loop, baselines,
  // evaluation, `kgd simulate`'s exit code) accept both; the status itself is still reported.
  bool at_equilibrium() const {
    return converged() || (status == SolveStatus::kStalled && energy_c0) ||
           (status == SolveStatus::kIterationLimit && accept_iteration_limit);
  }
};

class Simulator {
 public:
  // The system must outlive the simulator. Solver state (symbolic analysis, last factorization) is kept
  // between calls to Solve, which is what makes warm re-solves cheap.
  explicit Simulator(GarmentSystem* system);
  ~Simulator();

  // Minimizes from *x (a warm start; clamped coordinates are set to their targets) and leaves the result in *x.
  SolveReport Solve(Positions* x, const SolverSettings& settings);

  // Drops the stored factorization and damping (the next Newton solve starts afresh).
  void ResetFactorization();

 private:
  SolveReport SolveNewton(Positions* x, const SolverSettings& settings);
  SolveReport SolveLbfgs(Positions* x, const SolverSettings& settings);

  GarmentSystem* system_;
  struct Newton;
  struct NewtonSolve;
  std::unique_ptr<Newton> newton_;
};

// Adds the work of `later` (iterations, times, counters) to `*total`, which then reports `later`'s
// outcome (status, energy, residual): the account of solves made one after another.
void AccumulateSolve(SolveReport* total, const SolveReport& later);

// A solve with friction's lagged data (friction.h) brought up to date: takes them at *x and solves,
// then takes them at the equilibrium and solves again (one of IPC's lagged iterations). Without
// friction, one Solve. Iterations, times and counters add up over the solves.
SolveReport SolveLagged(Simulator& sim, GarmentSystem& system, Positions* x, const SolverSettings& settings);

}  // namespace kgd
