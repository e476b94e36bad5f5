// Scene files: a SceneSpec loaded from and exported to a JSON scene file with meshes and index lists
// beside it. The file is the JSON form of
// the kgd.v1.Scene message (proto/kgd/v1/kgd.proto), the schema the service shares; this loader reads
// it without protobuf and checks what a schema cannot, and proto/job_spec_test keeps the two in step.
//
// A scene file holds either a garment mesh of its own (garment.rest, with clamps, or on one body pose
// with contact: body.mesh) or a garment cut from a body motion (garment.region on body.rest, with
// body.deformed and optional body.frames, attachments as body faces; then optionally `motions`, the
// motions a design weighs: the first the body's own, every other with its deformed pose and frames over
// body.rest, docs/MODEL.md "Motions with roles"). Every key, what it holds and
// its unit: core/scene/scene_keys.h (`kgd scene keys` prints them); unknown keys are errors; units
// SI; paths are relative to the scene file.
// Attachment anchors are the centroids of the attached faces on the body in the simulated pose (for a
// garment of its own: in the initial positions). Clamp boxes select vertices by rest position.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/scene/scene.h"
#include "core/util/status.h"

namespace kgd {

// Reads and validates a scene file; errors name the file, the key or the element. `files_read`
// (optional) receives every file the scene names, as written in it (relative to the scene's folder).
Result<SceneSpec> LoadScene(const std::string& path, std::vector<std::string>* files_read = nullptr);

// A scene file and the files it names, in memory (a job sent to the service): `files` maps each path as
// the scene names it (relative to the scene file) to the file's bytes. The views must outlive the load.
struct SceneBundle {
  std::string name = "scene.json";  // the scene file's name in messages; its stem names an unnamed scene
  std::string_view scene_json;
  std::map<std::string, std::string_view> files;
};

// LoadScene on a bundle: the same checks and messages, file names as the scene gives them; a file the
// scene names but the bundle lacks is an error that names it.
Result<SceneSpec> LoadScene(const SceneBundle& bundle, std::vector<std::string>* files_read = nullptr);

// What a scene needs before any file it names is read: a garment (garment.rest, or garment.region),
// with LoadScene's message when it has none. The design service checks it when a job is submitted
// (proto/job_spec.h, ValidateJobSpec), so that a scene without a garment is refused before it queues.
Status CheckSceneHasGarment(std::string_view scene_json, const std::string& path);

// Writes `spec` as DIR/scene.json plus meshes (OBJ, coordinates exact) and index lists, its motions
// with their poses (motions/M/deformed.obj, motions/M/frame_NN.obj); creates DIR if needed. A scene
// whose motions ValidateSceneMotions refuses is refused.
Status ExportScene(const SceneSpec& spec, const std::string& dir);

}  // namespace kgd
