// The steps of soft-kill bi-material BESO (paper section "On-Body Topology Optimization", after Huang &
// Xie 2009), as pure functions on per-element and per-node arrays. The design loop that simulates each
// design and calls these steps is built on top (issue: the design engine).
//
// Vocabulary: a design holds one value per garment triangle (element), kReinforced (material 1) or
// kCloth (material 2); areas are rest areas (m^2); sensitivities are energy densities (Pa) scaled by the
// two-material formula.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

struct BesoSettings {
  double budget = 0.15;               // target reinforced area A* as a fraction of the garment area
  double evolutionary_ratio = 0.015;  // ER: the target area shrinks by this fraction per iteration
  double admission_ratio = 0.015;     // AR_max: at most this fraction of the garment area turns reinforced per iteration
  double d_min = 0.001;               // minimum design variable of the soft material
  double penalty = 1.6;               // p: SIMP-style interpolation exponent
  bool temporal_averaging = true;     // average filtered sensitivities with the previous iteration's ...
  bool average_with_raw = false;      // ... averaged ones (Huang & Xie, the paper), or filtered-only ones (the authors' code)
  bool keep_attachments = false;      // attachment triangles stay reinforced
  double tau = 1e-3;                  // convergence: relative objective change below tau ...
  int converge_window = 5;            // ... over this many iterations, with the target area reached
  int max_iterations = 400;
};

// Budget in (0, 1], ER and AR_max in (0, 1), p >= 1 and finite, d_min in (0, 1), tau > 0 and finite,
// window >= 1. The message names the setting and its value.
Status ValidateBesoSettings(const BesoSettings& s);

// Sensitivity of each element from its strain energy density W (Pa), paper eq. (sensitivity):
//   reinforced: 1/2 (1 - E2/E1) W,   cloth: 1/2 d^(p-1) (E1 - E2) / (d^p E1 + (1 - d^p) E2) W,
// E1 / E2 the Young's moduli of reinforced cloth / cloth.
Eigen::VectorXd Sensitivities(const Eigen::VectorXd& density_Pa, const std::vector<uint8_t>& design,
                              double youngs_reinforced_Pa, double youngs_cloth_Pa, double d_min, double penalty);

// The paper's filter: element values to nodes weighted by element area, then each element takes the
// mean of its three nodes.
Eigen::VectorXd FilterSensitivities(const Eigen::VectorXd& element_values, const Faces& faces, int num_vertices,
                                    const Eigen::VectorXd& element_area);

// Temporal averaging (paper eq. 8, after Huang & Xie 2007): (current + previous) / 2; `previous`
// empty (the first update) leaves `current` as is.
Eigen::VectorXd AverageSensitivities(const Eigen::VectorXd& current, const Eigen::VectorXd& previous);

// The next target area: A (1 - ER), not below the final target A*; A (1 + ER), not above it, when
// below (the bi-directional case).
double NextTargetArea(double current_m2, double final_m2, double evolutionary_ratio);

// One BESO update: the elements with the highest sensitivities form the new design, of total area as
// close to `target_area_m2` as the elements allow (within half the largest element's area), while at
// most `max_admitted_m2` of area turns from cloth to reinforced (Huang & Xie: when the admission limit
// binds, the highest-ranked cloth elements up to the limit are admitted and the removal threshold is
// recomputed for the target). `locked` elements (if given, non-zero) stay reinforced and count toward
// the area. Ties break by element index, so the update is deterministic.
std::vector<uint8_t> UpdateDesign(const Eigen::VectorXd& sensitivity, const Eigen::VectorXd& element_area,
                                  const std::vector<uint8_t>& design, double target_area_m2, double max_admitted_m2,
                                  const std::vector<uint8_t>* locked = nullptr);

// The paper's stop rule: the target area is reached and the objective changed by less than tau
// (relative) between each of the last `window` consecutive iterations.
bool BesoConverged(const std::vector<double>& objective, bool target_reached, double tau, int window);

}  // namespace kgd
