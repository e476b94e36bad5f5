// One simulation of a scene in its given pose, and the figures a designer reads off it.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/scene/scene.h"
#include "core/sim/simulator.h"
#include "core/sim/skin_pressure.h"

namespace kgd {

struct ClampForce {
  std::string name;
  Eigen::Vector3d force_N = Eigen::Vector3d::Zero();  // force the clamp exerts on the garment
};

struct SimulationResult {
  SolveReport solve;
  Positions positions;                  // equilibrium
  Eigen::VectorXd face_density_Pa;      // W per face
  Eigen::VectorXd face_energy_J;        // thickness * rest area * W per face
  double reinforced_energy_J = 0;       // membrane energy of reinforced faces
  double reinforced_area_m2 = 0;        // their rest area
  double reinforced_density_J_per_m2 = 0;
  double garment_area_m2 = 0;
  std::vector<ClampForce> clamp_forces;
  bool has_contact = false;
  double min_phi_m = 0, max_phi_m = 0;  // over vertices within the body field's support
  int inverted_faces = 0;               // faces whose normal turned > 90 degrees from the reference
  // With contact and a body mesh (SimulateScene): the pressure on the skin per body vertex and its
  // peak and 95th percentile (core/sim/skin_pressure.h). Empty pressure_Pa otherwise.
  SkinPressure skin;
};

// Builds the model (and the body field only if contact is on), solves from the scene's initial
// positions and summarizes, with the skin pressure where the scene has contact and a body mesh. With friction its data are lagged at the start and updated once
// (SolveLagged): the garment on the body presses on nothing, so the first pass is frictionless.
Result<SimulationResult> SimulateScene(const SceneSpec& scene);

// Simulates a scene cut from a body through every frame of its motion, in order. Frame 1 starts on
// the body; without friction every later frame starts from the previous equilibrium moved with the
// body, so each solve is warm; with friction every frame starts on the body (the garment put on in
// that pose), as the design loop's deformed pose does. `on_frame` (optional) receives each frame's index (0-based) and result as soon as it is
// solved. Errors if the scene has no frames.
Result<std::vector<SimulationResult>> SimulateFrames(const SceneSpec& scene,
                                                     const std::function<void(int, const SimulationResult&)>& on_frame = {});

// A design on one body of a scene (docs/MODEL.md, "Range of bodies"): simulated in the motion's
// deformed pose from the body, at the design and fully reinforced, as a design job's iteration 0 is.
struct BodyEvaluation {
  std::string name;
  SimulationResult designed, full;
  double density_ratio = 0;  // designed reinforced density / the fully reinforced garment's
};
// `design` (per garment face) on every body of `scene` (SceneOnBody), in order; a scene without
// bodies: its own, named after the scene. Errors: a design of another face count, bodies that
// ValidateSceneBodies refuses, a simulation that fails (named by body).
Result<std::vector<BodyEvaluation>> EvaluateOnBodies(const SceneSpec& scene, const std::vector<uint8_t>& design);

// Figures of a solved system at x (used by SimulateScene and by tests that drive GarmentSystem directly).
// `reference` orients the faces for the inversion count: the garment on the body in the simulated pose
// when the scene has one, else the initial positions.
SimulationResult Summarize(GarmentSystem& system, const Positions& x, const Positions& reference, const SolveReport& report);

// The skin pressure of the garment at x on the scene's body (its mesh `scene.body`, the field of the
// system's model), or an empty one when the scene has no body mesh or the model no contact.
SkinPressure SceneSkinPressure(const SceneSpec& scene, const GarmentModel& model, const Positions& x);

}  // namespace kgd
