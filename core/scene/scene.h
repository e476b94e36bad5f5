// Scenes: everything one simulation needs, as a plain description (SceneSpec), loaded from and
// exported to a JSON scene file with meshes and index lists beside it. The file is the JSON form of
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
//               "attachments": false, "clamps": false},
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

#include <optional>
#include <string>
#include <vector>

#include "core/body/parametric_body.h"
#include "core/mesh/trimesh.h"
#include "core/scene/body_garment.h"
#include "core/sim/garment_system.h"
#include "core/sim/simulator.h"
#include "core/util/status.h"

namespace kgd {

struct SceneSpec {
  std::string name;
  TriMesh garment;                 // rest positions and connectivity
  Positions initial;               // start positions (same rows as garment.vertices)
  std::vector<uint8_t> design;     // per face
  Material cloth = ClothMaterial();
  Material reinforced = ReinforcedMaterial();
  LameConversion lame = LameConversion::kSolid3D;
  Effects effects;
  std::optional<TriMesh> body;     // body surface in the simulated pose
  double body_support_scale = 2.0;
  double contact_stiffness_N_per_m = kDefaultContactStiffness;
  std::vector<int> attachment_faces;
  double attachment_stiffness_N_per_m = kDefaultAttachmentStiffness;
  std::vector<Clamp> clamps;
  SolverSettings solver;
  std::string description;
  double budget = 1.0;             // reinforced fraction of the garment area a design job aims at

  // Garments cut from the body (garment.region). Then garment = the cut in the motion's rest pose,
  // initial = the cut in the deformed pose, body = the deformed body.
  std::optional<BodyMotion> motion;
  std::vector<int> garment_region;        // body faces
  int subdivisions = 0;
  std::vector<int> attachment_body_faces;
  Eigen::SparseMatrix<double, Eigen::RowMajor> garment_from_body;  // garment vertices = this * body vertices
  Positions on_body;                      // the cut in the simulated pose (attachment anchors); may be empty
};

// Cuts the garment from `spec->motion` (region, subdivisions, attachment body faces) and sets garment,
// initial, body, attachment_faces, garment_from_body and on_body. Resets the design to all cloth.
Status CutGarmentFromMotion(SceneSpec* spec, const std::string& region_name = "garment.region",
                            const std::string& attachments_name = "attachments.body_faces");

// The scene in one frame of its motion (0-based): body and anchors at that frame, start positions
// `start` (e.g. the previous frame's equilibrium moved with the body). Precondition: motion has frames.
SceneSpec SceneAtFrame(const SceneSpec& spec, int frame, const Positions& start);

// Reads and validates a scene file; errors name the file, the key or the element. `files_read`
// (optional) receives every file the scene names, as written in it (relative to the scene's folder).
Result<SceneSpec> LoadScene(const std::string& path, std::vector<std::string>* files_read = nullptr);

// A scene argument: a scene file if it exists, else the name of a built-in scene (on a parametric body
// made to the `name=value` measurements `body_items`, when given).
Result<SceneSpec> ResolveScene(const std::string& arg, const std::vector<std::string>& body_items = {});

// A built-in scene by name only (`kgd scene export`): files and folders of the same name are ignored.
Result<SceneSpec> ResolveBuiltinScene(const std::string& name, const std::vector<std::string>& body_items = {});

// Writes `spec` as DIR/scene.json plus meshes (OBJ) and index lists; creates DIR if needed.
Status ExportScene(const SceneSpec& spec, const std::string& dir);

// The simulator's model: builds the body field only when the scene's effects use contact.
Result<GarmentModel> BuildGarmentModel(const SceneSpec& spec);

// Scenes built into the program (no files needed).
std::vector<std::string> BuiltinSceneNames();
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
