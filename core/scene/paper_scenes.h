// The paper's scenes, built into the program on the parametric body: arm flexion and extension (arm
// sleeve), knee flexion and extension (knee sleeve), slouch (shirt), crouch and lunge (shorts). Each
// has its motion (rest pose, deformed pose, frames), garment region, attachment bands at the garment's
// open ends and the paper's material budget.
#pragma once

#include <string>
#include <vector>

#include "core/body/parametric_body.h"
#include "core/scene/scene.h"

namespace kgd {

struct PaperMotion {
  std::string name;
  std::string garment;      // sleeve_arm, sleeve_knee, shirt or shorts
  std::string description;
  JointAngles rest;         // angles differing from the body's rest pose (rad)
  JointAngles pose;         // the deformed pose (rad); angles not listed keep their rest value
  int frames = 4;           // frame k at t = k / frames from rest to pose; the last is the deformed pose
  double budget = 0.15;
  int subdivisions = 1;
};

std::vector<PaperMotion> PaperMotions();

// A garment region on a parametric body: body faces, and the attachment bands among them (one band
// of `band_width_m` along each open end that is held to the body; the shirt's neckline is not).
struct BodyRegion {
  std::vector<int> faces;
  std::vector<int> attachment_faces;
};
Result<BodyRegion> ParametricGarmentRegion(const ParametricBody& body, const std::string& garment, double band_width_m = 0.025);

// The parametric body for the default measurements, built once per process.
Result<const ParametricBody*> DefaultParametricBody();

// Garment-skin friction of the built-in scenes (Coulomb coefficient; see core/sim/friction.h): none, the
// paper's contact. The parametric body's bent joints keep their girth, so a frictionless sleeve stays
// in place around the joint and all seven scenes run to their budgets without it (docs/RESULTS.md,
// "Sliding"). `"effects": {"friction": 0.1}` in a scene file turns friction on.
inline constexpr double kPaperSceneFriction = 0.0;

// The scene of one paper motion on `body`: the body posed through the motion's frames, the garment cut
// from it (all cloth), unilateral contact (friction kPaperSceneFriction), and attachments.
Result<SceneSpec> PaperScene(const ParametricBody& body, const PaperMotion& motion);

// Scenes with several motions (docs/MODEL.md, "Motions with roles") on the parametric body: one
// garment cut in a common rest pose, each motion from that pose to its own. The first motion is the
// one the garment resists.
struct BraceMotion {
  std::string name;
  MotionRole role = MotionRole::kResist;
  double weight = 1.0;
  JointAngles pose;  // angles not listed keep their value in the common rest pose (rad)
  int frames = 4;
};
struct BraceScene {
  std::string name;
  std::string garment;  // as PaperMotion::garment
  std::string description;
  JointAngles rest;     // the common rest pose: angles differing from the body's rest pose (rad)
  std::vector<BraceMotion> motions;
  double budget = 0.15;
  int subdivisions = 1;
};
// arm_brace, knee_brace, posture_shirt.
std::vector<BraceScene> BraceScenes();
Result<SceneSpec> BraceSceneOn(const ParametricBody& body, const BraceScene& brace);

// Scenes over a range of bodies (docs/MODEL.md, "Range of bodies"): one paper motion performed by
// the parametric body and by bodies of other sizes made with its mesh (ParametricBodyLike), so the
// garment is the same on each.
struct BodySize {
  std::string name;
  double girth_scale = 1.0;   // every circumference
  double height_scale = 1.0;  // the height and every limb length
};
struct SizedScene {
  std::string name;
  std::string motion;         // a PaperMotions() name
  std::string description;
  std::vector<BodySize> sizes;  // sizes[0]: the body the scene is built on (scales 1)
  BodyObjective objective = BodyObjective::kMean;
};
// knee_flexion_sizes (the worst size) and knee_flexion_sizes_mean.
std::vector<SizedScene> SizedScenes();
// `m` with every circumference times girth_scale, the height and limb lengths times height_scale.
BodyMeasurements ScaledMeasurements(const BodyMeasurements& m, const BodySize& size);
// The sized scene on `body` (sizes[0]) and bodies of its other sizes made with its mesh.
Result<SceneSpec> SizedSceneOn(const ParametricBody& body, const SizedScene& sized);

}  // namespace kgd
