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
#include <vector>

#include "core/beso/beso.h"
#include "core/scene/scene.h"
#include "core/sim/simulator.h"

namespace kgd {

struct BesoIteration {
  int iteration = 0;                   // 0: the fully reinforced design
  double target_area_m2 = 0;
  double area_fraction = 0;            // reinforced rest area / garment rest area
  double energy_J = 0;                 // total potential energy at equilibrium (the objective)
  double reinforced_energy_J = 0;      // membrane energy of the reinforced triangles
  double reinforced_density_J_per_m2 = 0;
  double density_ratio = 0;            // reinforced density / that of the fully reinforced design
  SolveStatus status = SolveStatus::kConverged;
  int solver_iterations = 0;
  int cold_restart = 0;                // 1: the warm-started solve failed and the garment was re-solved from the body
  // Wall time (s): simulation; sensitivities (W and the two-material formula); filter and temporal
  // averaging; design update (ranking, threshold, admission); total of the iteration.
  double simulation_s = 0, sensitivity_s = 0, filter_s = 0, update_s = 0, total_s = 0;
  std::vector<uint8_t> design;         // per face: kCloth / kReinforced
  Positions positions;                 // equilibrium (m)
  Eigen::VectorXd energy_density_Pa;   // W per face at equilibrium
  Eigen::VectorXd sensitivity;         // filtered sensitivities carried to the next iteration's temporal averaging
                                       // (the averaged ones that ranked this design; with average_with_raw, the
                                       // filtered ones before averaging); empty at iteration 0
};

// Runs BESO on `scene` (its design is ignored: the loop starts fully reinforced). `on_iteration`
// (optional) sees every iteration as it lands; returning false stops the run. `resume` (optional):
// records of an earlier run of the same scene and settings (iterations 0..k, complete for the last);
// the run continues with iteration k + 1 and returns only the new records.
// Errors: bad settings, a scene that cannot be built, resume records that do not fit the scene, a
// simulation that fails to converge (the message names the iteration).
Result<std::vector<BesoIteration>> RunBeso(const SceneSpec& scene, const BesoSettings& settings,
                                           const std::function<bool(const BesoIteration&)>& on_iteration = {},
                                           const std::vector<BesoIteration>* resume = nullptr);

// True when `history` (iterations 0..k) has met the stop rule: target area reached and flat objective.
bool BesoFinished(const std::vector<BesoIteration>& history, const BesoSettings& settings, double garment_area_m2);

}  // namespace kgd
