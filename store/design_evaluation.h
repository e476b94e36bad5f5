// A finished design seen beyond the design loop's deformed pose: the design over every frame of the
// motion, and the Line and X baselines of the same reinforced area (core/beso/baselines.h). A design
// job computes it once, after its last iteration (job/design_job.h, EvaluateDesign); it lives in a file
// of its own beside the design file (DIR/job-N.evaluation.h5 on the service, FILE.evaluation.h5 for
// `kgd design FILE`), written whole under a temporary name and renamed, so a reader sees all of it or
// none. Layout (format "kgd design evaluation", format_version 1; SI units; K frames, B baselines):
//
//   /                          attrs iteration (the design evaluated), note (why parts are missing)
//   /frames/positions          (K,V,3) float64, m: the garment's equilibrium in each frame
//   /frames/body               (K,Vb,3) float64, m: the body in each frame (faces: the design file's /body)
//   /frames/energy_density_Pa  (K,F) float64
//   /frames/energy_J           (K) float64; attr status: the solves' statuses, one per line
//   /frames/skin_pressure_Pa   (K,Vb) float64, Pa: the garment's contact pressure per body vertex in each
//                              frame (core/sim/skin_pressure.h; optional: absent without a body or contact)
//   /baselines/design          (B,F) uint8; attr names: "line", "x", one per line
//   /baselines/positions       (B,V,3) float64, m
//   /baselines/energy_density_Pa (B,F) float64
//   /baselines/figures         (B,5) float64: area_fraction, energy_J, reinforced_energy_J,
//                              reinforced_density_J_per_m2, density_ratio (vs iteration 0);
//                              attr status: one per line
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

struct EvaluatedFrame {
  Positions garment;                 // equilibrium (m)
  Positions body;                    // the body in this frame (m); empty when the scene has no body
  Eigen::VectorXd energy_density_Pa; // per face
  double energy_J = 0;
  std::string status;                // the solve's status ("converged", ...)
  Eigen::VectorXd skin_pressure_Pa;  // per body vertex (Pa); empty when the scene has no body or contact
};

struct EvaluatedBaseline {
  std::string name;                  // "line" or "x"
  std::vector<uint8_t> design;
  Positions positions;               // equilibrium in the deformed pose (m)
  Eigen::VectorXd energy_density_Pa;
  double area_fraction = 0, energy_J = 0, reinforced_energy_J = 0, reinforced_density_J_per_m2 = 0;
  double density_ratio = 0;          // reinforced density / that of the fully reinforced design
  std::string status;
};

struct DesignEvaluation {
  int iteration = -1;                // the design evaluated
  std::vector<EvaluatedFrame> frames;        // every frame of the motion; the last is the deformed pose
  std::vector<EvaluatedBaseline> baselines;  // Line and X, when the garment has two attachment bands
  std::string note;                  // why frames or baselines are missing; empty when none is
};

// The evaluation file beside a design file.
std::string EvaluationPath(const std::string& design_file);

// Writes `path` whole (a temporary name, then rename). Errors name the file.
Status WriteDesignEvaluation(const std::string& path, const DesignEvaluation& evaluation);
// Errors name the file and what is wrong with it.
Result<DesignEvaluation> ReadDesignEvaluation(const std::string& path);

}  // namespace kgd
