// The scenes built into the program: the paper's seven on the parametric body (core/scene/paper_scenes.h),
// the pull test of the paper's 2D validation and a sleeve on a flexing limb; and the one way a scene
// argument (a file or a built-in name) becomes a scene.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/body/parametric_body.h"
#include "core/scene/scene.h"
#include "core/util/status.h"

namespace kgd {

// A scene argument: a scene file if it exists, else the name of a built-in scene (on a parametric body
// made to the `name=value` measurements `body_items`, when given). The scenes on the parametric body
// (IsCachedBuiltinScene) are kept in the scene cache (core/scene/scene_cache.h) in `cache_dir`: by
// default the user's (SceneCacheDir), "" off.
Result<SceneSpec> ResolveScene(const std::string& arg, const std::vector<std::string>& body_items = {},
                               const std::optional<std::string>& cache_dir = std::nullopt);

// The built-in scenes kept in the scene cache: every scene on the parametric body (the paper's, the
// braces and shirt of several motions, the sized ones), whose build takes seconds to a minute; the
// quick simulator checks are built every time.
bool IsCachedBuiltinScene(const std::string& name);

// A built-in scene by name only (`kgd scene export`): files and folders of the same name are ignored.
Result<SceneSpec> ResolveBuiltinScene(const std::string& name, const std::vector<std::string>& body_items = {},
                                      const std::optional<std::string>& cache_dir = std::nullopt);

// Scenes built into the program (no files needed).
std::vector<std::string> BuiltinSceneNames();
// What `kgd scenes` and the service's ListScenes show of each, in BuiltinSceneNames order; cheap (no
// body is built).
struct BuiltinSceneInfo {
  std::string name;
  std::string garment;       // the paper's garment region; empty for the simulator checks
  std::string description;
  double budget = 1.0;       // reinforced fraction of the garment area
  int frames = 0;            // frames of the motion, summed over its motions and bodies; 0: a static scene
  int subdivisions = 0;
  bool parametric_body = false;  // made to body measurements (--body, JobSpec.body)
  int garment_faces = 0;         // the garment's size on the default body
  double garment_area_m2 = 0;
  // The motions a design weighs (MotionsOf), the scene's own first.
  struct Motion {
    std::string name;
    MotionRole role = MotionRole::kResist;
    double weight = 1.0;
  };
  std::vector<Motion> motions;
  // A scene designed for a range of bodies: what it weighs of them (its `motions` are then the bodies,
  // as MotionsOf gives them); empty for a scene of one body.
  std::string body_objective;
  // The garment is mirror symmetric about the body's sagittal plane (x = 0), so that a design job may
  // ask for symmetric designs (--symmetric): the shirt and the shorts, not the one-limb sleeves.
  bool symmetric = false;
};
std::vector<BuiltinSceneInfo> BuiltinSceneInfos();
Result<SceneSpec> BuiltinScene(const std::string& name);
// The same with the paper's scenes on a parametric body made to these measurements.
Result<SceneSpec> BuiltinScene(const std::string& name, const BodyMeasurements& body);

// Pieces of the built-in scenes, for tests and benchmarks.
// Pull test of the paper's 2D validation: 10 x 14 cm, 2.5 mm grid, 2 cm clamp strips, the far one moved
// by `pull_m` along +z. design: "all_cloth", "all_reinforced", "line" (4 cm centred band) or "x".
Result<SceneSpec> PullTestScene(const std::string& design, double pull_m = 0.01);
// Sleeve on a flexing limb: garment = the limb surface within `sleeve_halflength_m` of the joint. Its rest
// shape is a straight tube of the limb's nominal radius times `hoop_tightness` (it does not follow the
// waist: a concavity the cloth can bridge), shortened along the limb by `axial_tightness` (so it is in
// tension between its attachment bands at both ends). It starts on the body surface in the flexed pose.
struct SleeveOptions {
  int around = 32;
  double flex_angle_rad = 0.8;
  double sleeve_halflength_m = 0.12;
  double axial_tightness = 0.85;
  double hoop_tightness = 1.0;
  // Paper-like instead: the garment's rest shape is the limb surface in the rest pose itself (tightness
  // ignored), so it is strained only by the flexion, as the paper initializes garments on STAR bodies.
  bool rest_on_body = false;
  ContactModel contact = ContactModel::kUnilateral;
  bool reinforced = false;
};
SceneSpec SleeveOnLimbScene(const SleeveOptions& options);

}  // namespace kgd
