// Scene files: a SceneSpec loaded from and exported to a JSON scene file with meshes and index lists
// beside it. The file is the JSON form of
// the kgd.v1.Scene message (proto/kgd/v1/kgd.proto), the schema the service shares; this loader reads
// it without protobuf and checks what a schema cannot, and proto/job_spec_test keeps the two in step.
//
// Scene file (all keys optional unless marked; unknown keys are errors; units SI):
// {
//   "name": "pull_test_line",
//   "description": "free text",
//   "budget": 0.15,                      // fraction of the garment's area to reinforce (design jobs)
//   "garment": {
//     "rest": "sample.obj",              // a garment mesh of its own: OBJ or PLY, relative to this file
//     "initial": "sample_deformed.obj",  // start positions (deformed pose); default: the rest mesh
//     -- or, a garment cut from the body (then body.rest and body.deformed are required):
//     "region": "garment.faces.txt" | [..],  // body faces, 0-based, one per line
//     "subdivisions": 2,                  // midpoint subdivisions of the region (each 1 -> 4 faces)
//     "design": "all_cloth" | "all_reinforced" | {"reinforced_faces": "line.txt" | [0, 1, ...]}
//   },                                   // (design indices are garment faces, after subdivision)
//   "materials": {"lame": "solid3d" | "plane_stress",
//                 "cloth": {"youngs_modulus_Pa": 5e5, "poisson_ratio": 0.33, "thickness_m": 2.7e-4},
//                 "reinforced": {...}},
//   "effects": {"membrane": true, "relaxation": "exact" | "authors" | "none", "fold_barrier": true,
//               "contact": "none" | "unilateral" | "bilateral", "friction": 0.0 (Coulomb mu; needs contact),
//               "attachments": false, "clamps": false, "bending": false},
//   "body": {"mesh": "body_deformed.obj", "support_scale": 2.0},    // read only when contact is on
//   -- or, with garment.region: the body's motion, every pose with the topology of "rest":
//   "body": {"rest": "rest.obj", "deformed": "pose.obj", "frames": ["frames/frame_01.obj", ...]},
//   "contact": {"stiffness_N_per_m": 5000},
//   "attachments": {"faces": "attach.txt" | [..],        // garment faces, or with garment.region:
//                   "body_faces": "attach.txt" | [..],   // body faces inside the region
//                   "stiffness_N_per_m": 3000},
//   "clamps": [{"name": "moving", "vertices": "moving.txt" | [..] | {"box_min": [x,y,z], "box_max": [x,y,z]},
//               "axes": "xyz", "displacement_m": [0, 0, 0.01]}],
//   "solver": {"method": "newton" | "lbfgs", "grad_tol": 1e-7, "max_iterations": 200,
//              "reuse_factorization": false, "lbfgs_history": 20, "project_contact_crossings": true,
//              "local_steps": true}
// }
// Attachment anchors are the centroids of the attached faces on the body in the simulated pose (for a
// garment of its own: in the initial positions). Clamp boxes select vertices by rest position.
#pragma once

#include <string>
#include <vector>

#include "core/scene/scene.h"
#include "core/util/status.h"

namespace kgd {

// Reads and validates a scene file; errors name the file, the key or the element. `files_read`
// (optional) receives every file the scene names, as written in it (relative to the scene's folder).
Result<SceneSpec> LoadScene(const std::string& path, std::vector<std::string>* files_read = nullptr);

// Writes `spec` as DIR/scene.json plus meshes (OBJ) and index lists; creates DIR if needed.
Status ExportScene(const SceneSpec& spec, const std::string& dir);

}  // namespace kgd
