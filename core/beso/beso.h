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

// The BESO settings, listed once. Every encoding reads these lists: the BesoSettings members below,
// the design file's settings (store/design_file.cpp), kgd.v1.OptimizerSettings (proto/job_spec.cpp,
// fields of the same names, checked by its test) and the CLI's flags (client/optimizer_flags.cpp).
//
// Values: X(type, name, default, flag, help). Unset in a job spec: the default (the budget: the
// scene's own, if it has one).
#define KGD_BESO_VALUES(X)                                                                                              \
  X(double, budget, 0.15, "--budget", "Reinforced area at the end, as a fraction of the garment area, in (0, 1] (default: the scene's)") \
  X(double, evolutionary_ratio, 0.015, "--er", "Evolutionary ratio ER: the target area shrinks by this fraction per iteration (default 0.015)") \
  X(double, admission_ratio, 0.015, "--ar-max", "Admission limit AR_max: at most this fraction of the garment turns reinforced per iteration (default 0.015)") \
  X(double, d_min, 0.001, "--d-min", "Design value of the soft material in the sensitivity formula (default 0.001)") \
  X(double, penalty, 1.6, "--penalty", "Interpolation exponent p, >= 1 (default 1.6)")                                  \
  X(double, tau, 1e-3, "--tau", "Stop when the objective changes by less than tau (relative) ... (default 1e-3)")      \
  X(int, converge_window, 5, "--window", "... over this many iterations, with the budget reached (default 5)")          \
  X(int, max_iterations, 400, "--iterations", "Stop after this BESO iteration at the latest (default 400)") \
  X(double, max_pressure_Pa, 0.0, "--max-pressure-kPa", "Skin pressure limit in every resisted motion's deformed pose, kPa (default: the scene's max_pressure_kPa; 0: none)") \
  X(double, resolve_tolerance_factor, 20.0, "--resolve-tol-factor", "While the target area shrinks, the re-solves stop at this multiple of the solver tolerance, >= 1 (default 20; 1: every solve at it)")
// Switches: X(name, default, flag, proto field, help). The flag, and the proto field when true, turn
// the switch away from its default.
#define KGD_BESO_SWITCHES(X)                                                                                            \
  X(temporal_averaging, true, "--no-averaging", no_temporal_averaging, "No temporal averaging of the sensitivities")     \
  X(average_with_raw, false, "--average-with-raw", average_with_raw,                                                    \
    "Average with the previous iteration's filtered, not averaged, sensitivities (the authors' code)")                 \
  X(keep_attachments, false, "--keep-attachments", keep_attachments, "Attachment triangles stay reinforced")          \
  X(symmetric, false, "--symmetric", symmetric,                                                                          \
    "Mirror-symmetric designs about the scene's symmetry plane (default: the parametric body's sagittal plane, x = 0)") \
  X(resist_only, false, "--resist-only", resist_only,                                                                    \
    "The scene's allowed motions weigh 0: simulated and reported, no part of the objective (to compare with the design that allows them)")

// budget: target reinforced area A* as a fraction of the garment area. evolutionary_ratio (ER): the
// target area shrinks by this fraction per iteration. admission_ratio (AR_max): at most this fraction
// of the garment area turns reinforced per iteration. d_min: minimum design variable of the soft
// material. penalty (p): SIMP-style interpolation exponent. tau, converge_window: convergence when the
// relative objective change stays below tau over the window, with the target area reached.
// temporal_averaging: average filtered sensitivities with the previous iteration's averaged ones (Huang
// & Xie, the paper) or, with average_with_raw, its filtered-only ones (the authors' code).
// keep_attachments: attachment triangles stay reinforced. symmetric: every design is mirror symmetric
// (core/beso/design_constraints.h; a scene with garment.symmetry is symmetric without it).
// resist_only: the scene's allowed motions get weight 0 (docs/MODEL.md, "Motions with roles").
// max_pressure_Pa: the skin pressure every design's resisted motions may put on the body at most, Pa
// (0: no limit; core/beso/pressure_limit.h). A flag named in kPa (--max-pressure-kPa) takes kPa.
// resolve_tolerance_factor (F): while the target area shrinks, every re-solve after iteration 0 (each
// motion's warm re-solve of a new design) stops at F times the scene's grad_tol; iteration 0 (the
// density ratios' reference) and the iterations at the budget (where the stop rule compares
// objectives) at the scene's own. A design update needs the ranking of the elements near its
// threshold, not the equilibrium to the last digit (what F changes in the next designs against a tight
// solve: bench/decision_benchmark, docs/PERFORMANCE.md "A design iteration in Newton steps"). Design
// files without it ran at 1.
struct BesoSettings {
#define KGD_DECLARE_BESO_VALUE(type, name, default_value, flag, help) type name = default_value;
  KGD_BESO_VALUES(KGD_DECLARE_BESO_VALUE)
#undef KGD_DECLARE_BESO_VALUE
#define KGD_DECLARE_BESO_SWITCH(name, default_value, flag, proto_field, help) bool name = default_value;
  KGD_BESO_SWITCHES(KGD_DECLARE_BESO_SWITCH)
#undef KGD_DECLARE_BESO_SWITCH
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
