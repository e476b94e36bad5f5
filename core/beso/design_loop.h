// The BESO design loop (paper section "BESO Procedure"): from the fully reinforced garment, simulate,
// rank, update the design towards the target area, warm re-solve, until the budget is reached and the
// objective is flat. Every iteration's design is binary and simulated to equilibrium.
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
  double energy_J = 0;                 // total potential energy at equilibrium
  double reinforced_energy_J = 0;      // membrane energy of the reinforced triangles
  double reinforced_density_J_per_m2 = 0;
  double density_ratio = 0;            // reinforced density / that of the fully reinforced design
  SolveStatus status = SolveStatus::kConverged;
  int solver_iterations = 0;
  double seconds = 0;                  // simulation wall time
  std::vector<uint8_t> design;
  Positions positions;
};

// Runs BESO on `scene` (its design is ignored: the loop starts fully reinforced). `on_iteration`
// (optional) sees every iteration as it lands; returning false stops the run. Errors: bad settings,
// a scene that cannot be built, a simulation that fails to converge (the message names the iteration).
Result<std::vector<BesoIteration>> RunBeso(const SceneSpec& scene, const BesoSettings& settings,
                                           const std::function<bool(const BesoIteration&)>& on_iteration = {});

}  // namespace kgd
