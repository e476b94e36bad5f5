// The BESO design loop (paper section "BESO Procedure"): from the fully reinforced garment, simulate,
// rank, update the design towards the target area, warm re-solve, until the budget is reached and the
// objective is flat. Every iteration's design is binary and simulated to equilibrium.
//
// Determinism: an iteration depends only on the previous iteration's record (design, positions,
// averaged sensitivities, target area) and the energies so far; the solver starts each iteration
// from a fresh factorization. So a run resumed from stored records gives the same designs, bit for
// bit, as an uninterrupted one.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/beso/beso.h"
#include "core/scene/scene.h"
#include "core/sim/simulator.h"

namespace kgd {

// The scalar figures of a BESO iteration, listed once: X(type, name, what). Every encoding reads this
// list: the BesoIteration members below, the design file's datasets (store/design_file.cpp), and the
// kgd.v1.IterationMetrics fields of the same names (proto/records.cpp, checked by its test), from which
// the job store's SQLite columns and the CLI's JSON follow. A new figure is one line here, one field
// in the proto, and its computation. Times are wall seconds.
#define KGD_BESO_METRICS(X)                                                                                  \
  X(double, target_area_m2, "the reinforced area the design update aimed at")                               \
  X(double, area_fraction, "reinforced rest area / garment rest area")                                      \
  X(double, energy_J, "total potential energy at equilibrium (the objective)")                              \
  X(double, reinforced_energy_J, "membrane energy of the reinforced triangles")                             \
  X(double, reinforced_density_J_per_m2, "reinforced energy / reinforced rest area")                        \
  X(double, density_ratio, "reinforced density / that of the fully reinforced design")                      \
  X(int, solver_iterations, "Newton (or L-BFGS) iterations of the equilibrium solve")                       \
  X(int, cold_restart, "1: the warm-started solve failed and the garment was re-solved from the body")      \
  X(double, simulation_s, "equilibrium solve")                                                              \
  X(double, sensitivity_s, "sensitivities (W and the two-material formula)")                                \
  X(double, filter_s, "filter and temporal averaging")                                                      \
  X(double, update_s, "design update (ranking, threshold, admission)")                                      \
  X(double, total_s, "the whole iteration")                                                                 \
  KGD_BESO_PROFILE_METRICS(X)                                                                                \
  KGD_BESO_PRESSURE_METRICS(X)

// With a pressure limit (BesoSettings::max_pressure_Pa, core/beso/pressure_limit.h; 0 without one).
// Design files written before these existed read 0.
#define KGD_BESO_PRESSURE_METRICS(X)                                                                         \
  X(double, peak_pressure_Pa, "the highest skin pressure over the resisted motions' deformed poses")       \
  X(double, pressure_kept_out_fraction, "garment area fraction the pressure limit keeps cloth")

// Where an iteration's equilibrium solve spent its time (s; Newton's parts, then each energy term's
// evaluations, <key>_s for each term of the term list, core/sim/term_list.h: 0 for a term the scene
// does not build). Design files written before these existed read 0.
#define KGD_BESO_PROFILE_METRICS(X)                                                                          \
  X(double, assembly_s, "energy, gradient and Hessian assembly of the solve (Newton)")                      \
  X(double, factorization_s, "Cholesky factorizations of the solve (Newton)")                               \
  X(double, linear_solve_s, "triangular and conjugate-gradient solves (Newton)")                            \
  X(double, line_search_s, "line search (energy trials, contact projection)")                               \
  X(double, body_field_query_s, "body-field queries outside the contact term (the contact projection)")     \
  KGD_ENERGY_TERMS(KGD_BESO_TERM_TIME_METRIC, X)
#define KGD_BESO_TERM_TIME_METRIC(X, Class, key, sum_place, Type, effect, value, effect_what, time_what) X(double, key##_s, time_what)

// One motion's figures in an iteration (docs/MODEL.md, "Motions with roles"): the design simulated in
// that motion. density_ratio: against the motion's own fully reinforced design (iteration 0).
struct MotionMetrics {
  std::string name;
  MotionRole role = MotionRole::kResist;
  double weight = 1.0;
  double energy_J = 0;                     // total potential energy at equilibrium
  double reinforced_energy_J = 0;
  double reinforced_density_J_per_m2 = 0;
  double density_ratio = 0;
  double simulation_s = 0;                 // its equilibrium solve (wall s)
  int solver_iterations = 0;
  bool operator==(const MotionMetrics&) const = default;
};

struct BesoIteration {
  int iteration = 0;  // 0: the fully reinforced design
  SolveStatus status = SolveStatus::kConverged;
#define KGD_DECLARE_METRIC(type, name, what) type name = 0;
  KGD_BESO_METRICS(KGD_DECLARE_METRIC)
#undef KGD_DECLARE_METRIC
  std::vector<uint8_t> design;         // per face: kCloth / kReinforced
  Positions positions;                 // equilibrium (m)
  Eigen::VectorXd energy_density_Pa;   // W per face at equilibrium
  Eigen::VectorXd sensitivity;         // filtered sensitivities carried to the next iteration's temporal averaging
                                       // (the averaged ones that ranked this design; with average_with_raw, the
                                       // filtered ones before averaging); empty at iteration 0
  // Every motion of the scene (MotionsOf), in its order; motions[0] gives the metrics above. Empty only
  // in records from before motions were stored.
  std::vector<MotionMetrics> motions;
  // The equilibria of motions 2..K (MotionsOf order; m), each on its own garment rest shape: where a
  // resumed run warm-starts them, so that it continues bit for bit. Empty with one motion, and in
  // records from before they were stored (a resumed run then solves them again from the body).
  std::vector<Positions> motion_positions;
};

// The metric that holds the evaluation time of the energy term named `term` (the registry's key,
// energy_terms.h), or null for a name the registry does not have.
double BesoIteration::*TermTimeMetric(std::string_view term);
// Puts a solve's time breakdown (Newton's parts, each term's evaluations) into the profile metrics.
void RecordSolveProfile(const SolveReport& report, BesoIteration* it);

// `it` with its arrays (design, positions, densities, sensitivities) dropped: the metrics alone, which
// are all the stop rule and summaries read.
BesoIteration MetricsOnly(BesoIteration it);

// The motions a job on `scene` weighs: name, role and weight of each of MotionsOf(scene), the allowed
// ones at weight 0 with settings.resist_only (the figures 0).
std::vector<MotionMetrics> MotionsOfJob(const SceneSpec& scene, const BesoSettings& settings);

// The weight of each of `motions` (MotionsOf(scene)) in an iteration's sensitivities: its own, but for
// a range of bodies weighed by the worst (docs/MODEL.md, "Range of bodies") w_b exp(-(q_b - q_min) / T)
// over the bodies of weight > 0, q_b the body's density ratio in `before` (the iteration whose
// equilibria rank the next design), T = kWorstBodyTemperature, scaled to the weights' sum.
std::vector<double> CaseWeights(const SceneSpec& scene, const std::vector<SceneMotion>& motions, const BesoIteration& before);

// Runs BESO on `scene` (its design is ignored: the loop starts fully reinforced). `on_iteration`
// (optional) sees every iteration as it lands; returning false stops the run. `resume` (optional):
// records of an earlier run of the same scene and settings (iterations 0..k, complete for the last);
// the run continues with iteration k + 1 and returns only the new records.
// With settings.max_pressure_Pa (pressure_limit.h) the run converges only on a design that keeps the
// limit; a resumed run re-derives the faces the limit keeps out from the last stored equilibrium (they
// are not stored), so it keeps the limit but may part from the uninterrupted run.
// Errors: bad settings, a scene that cannot be built, resume records that do not fit the scene, a
// simulation that fails to converge (the message names the iteration), a pressure limit the fully
// cloth garment already breaks (the message names the limit, the peak and the motion).
Result<std::vector<BesoIteration>> RunBeso(const SceneSpec& scene, const BesoSettings& settings,
                                           const std::function<bool(const BesoIteration&)>& on_iteration = {},
                                           const std::vector<BesoIteration>* resume = nullptr);

// How a run stands after `history` (iterations 0..k): still running, or why it ended.
enum class BesoEnd {
  kRunning,
  kConverged,        // target area reached and the objective flat over the window
  kIterationLimit,   // settings.max_iterations reached
  kNothingToResist,  // the motion puts no energy into the fully reinforced garment (iteration 0)
};

// Below this reinforced energy at iteration 0 (J) a motion has nothing for a design to resist: a body
// that does not move, or moves rigidly, leaves a garment at rest with (numerically) zero energy.
inline constexpr double kNothingToResist_J = 1e-9;

// True when `it` is iteration 0 and its fully reinforced garment takes at most kNothingToResist_J.
bool NothingToResist(const BesoIteration& it);

BesoEnd BesoEndOf(const std::vector<BesoIteration>& history, const BesoSettings& settings, double garment_area_m2);

// True when `history` has ended (any BesoEnd but kRunning).
bool BesoFinished(const std::vector<BesoIteration>& history, const BesoSettings& settings, double garment_area_m2);

// One line for people: "converged", "iteration limit (400)", "nothing to resist: ...".
std::string DescribeBesoEnd(BesoEnd end, const std::vector<BesoIteration>& history, const BesoSettings& settings);

}  // namespace kgd
