// Built scenes kept on disk, so that a job on a built-in scene starts in a fraction of a second instead
// of building and posing the parametric body again.
//
// A built-in scene of the paper's motions is written once (ExportScene: meshes at full precision) to a
// folder named by a key: the scene name, the body measurements and the identity of the running program
// (its size and modification time, so a rebuilt kgd never reads another's scenes) and the numeric kernels it
// runs (core/util/pinned_kernels.h: a scene built at another level differs in its last bits). A manifest holds a
// content hash (64-bit FNV-1a) of every file; a folder whose files do not match it is ignored and
// written again. Loading a cached scene gives the same scene bit for bit (builtin_scenes_test).
//
// The folder: $KGD_CACHE_DIR, else $XDG_CACHE_HOME/kgd, else $HOME/.cache/kgd; KGD_CACHE_DIR=off turns
// the cache off. A cache that cannot be written is skipped silently: it only saves time. Each scene
// name keeps its six most recently used entries (other measurements, other builds of the program).
#pragma once

#include <optional>
#include <string>

#include "core/body/parametric_body.h"
#include "core/scene/scene.h"

namespace kgd {

// The user's cache folder from the environment (above), or empty when the cache is off or no folder
// can be named.
std::string SceneCacheDir();

// The cached scene `name` on a body of `measurements` in the cache folder `cache_dir` (empty: off),
// when present and intact.
std::optional<SceneSpec> LoadCachedScene(const std::string& cache_dir, const std::string& name, const BodyMeasurements& measurements);

// Writes `scene` to the cache folder `cache_dir` (atomically: a temporary folder renamed into place).
// Errors are returned for tests; callers may ignore them.
Status StoreCachedScene(const std::string& cache_dir, const std::string& name, const BodyMeasurements& measurements,
                        const SceneSpec& scene);

}  // namespace kgd
