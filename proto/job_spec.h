// Job specs (kgd.v1.JobSpec) into what the design engine runs: the scene, the BESO settings and the
// solver overrides. `kgd design` (local), `kgd submit`, the server's validation and the workers all
// go through these functions, so one spec gives one design wherever it runs.
#pragma once

#include <string>

#include "core/beso/beso.h"
#include "core/scene/scene.h"
#include "core/util/status.h"
#include "kgd/v1/kgd.pb.h"

namespace kgd {

// Checks a spec without building its scene (the server's CreateJob): a scene is given, a built-in
// name is known, body overrides parse, every file the scene names is in the bundle and no bundle path
// leaves its folder, optimizer settings are in range. The message starts with the field's name, e.g.
// "spec.optimizer.budget: 1.5 is outside (0, 1]".
Status ValidateJobSpec(const v1::JobSpec& spec);

// Every KGD_BESO_VALUES entry (core/beso/beso.h) has its optional kgd.v1.OptimizerSettings field of
// the same name and type, and every KGD_BESO_SWITCHES entry its bool field.
Status CheckSettingsFields();

// The BESO settings of a spec for a scene whose own budget is `scene_budget` (1: none) and pressure
// limit `scene_max_pressure_Pa` (0: none): unset fields take the defaults, the budget and the pressure
// limit the scene's. Errors name the field (as ValidateJobSpec).
Result<BesoSettings> SettingsOfJob(const v1::OptimizerSettings& optimizer, double scene_budget, double scene_max_pressure_Pa = 0);

// Solver overrides of a spec (Newton iteration limit, gradient tolerance) applied to `solver`.
void ApplySolverOverrides(const v1::OptimizerSettings& optimizer, SolverSettings* solver);

// The spec's motion weights (optimizer.motion_weights) given to the scene's motions of those names.
// Errors name the motion: a weight not finite or below 0, a name the scene does not have, weights for
// a scene of one motion, the first motion at weight 0 (ValidateSceneMotions).
Status ApplyMotionWeights(const v1::OptimizerSettings& optimizer, SceneSpec* scene);

// The scene of a spec: a built-in scene (with body overrides), or the scene files loaded from the
// spec's bundle in memory (messages name the files as the scene does).
Result<SceneSpec> SceneOfJob(const v1::JobSpec& spec);

// A scene file's text as the kgd.v1.Scene message (the schema); errors start with `source`.
Result<v1::Scene> ParseSceneJson(const std::string& text, const std::string& source);

// The scene file a Scene message is the JSON form of (proto field names, indented).
std::string SceneJson(const v1::Scene& scene);

// A scene file and every file it names, read for sending (`kgd submit scene.json`). The scene is
// loaded once to check it and to learn which files it names, then parsed into the schema.
Result<v1::SceneFiles> ReadSceneFiles(const std::string& scene_path);

// A one-line name of a spec for listings: the built-in name or the scene's name.
std::string JobSceneName(const v1::JobSpec& spec);

}  // namespace kgd
