// Scenes: everything one simulation needs, as a plain description (SceneSpec), and the simulator's
// model built from it. Scene files: core/scene/scene_file.h; the built-in scenes:
// core/scene/builtin_scenes.h.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/scene/body_garment.h"
#include "core/sim/garment_system.h"
#include "core/sim/simulator.h"
#include "core/util/status.h"

namespace kgd {

// What a design does with a motion (docs/MODEL.md, "Motions with roles"): resist it (the paper's
// objective: the reinforcement stores the motion's energy) or allow it (the reinforcement's energy in
// the motion is penalized).
enum class MotionRole { kResist, kAllow };
const char* ToString(MotionRole role);  // "resist", "allow"
// "resist" / "allow"; else an error naming `what`.
Result<MotionRole> MotionRoleFromName(const std::string& name, const std::string& what);

// One motion of a scene with several: over the scene's rest body and garment, the body moves to
// `pose.deformed` (through `pose.frames`). `pose.rest` and `pose.faces` are the scene's body's.
struct SceneMotion {
  std::string name;
  MotionRole role = MotionRole::kResist;
  double weight = 1.0;  // >= 0; 0: simulated and reported, no part of the objective
  BodyMotion pose;
};

// One body of a scene designed for a range of bodies (docs/MODEL.md, "Range of bodies"): the scene's
// motion performed by another body whose mesh has the scene body's topology (the same faces), so that
// the garment cut from the scene's region is the same garment (faces) on every body, with its own rest
// shape. Parametric bodies of other measurements get the topology with ParametricBodyLike.
struct SceneBody {
  std::string name;
  double weight = 1.0;  // >= 0; 0: simulated and reported, no part of the objective
  BodyMotion pose;      // rest, deformed and frames of this body; faces: the scene body's
};

// What a design for a range of bodies weighs: the weighted mean of the bodies' density ratios, or
// the worst body (a soft minimum: each iteration weights the bodies by exp(-ratio / T), T =
// kWorstBodyTemperature, with the ratios of the iteration before). T is wide against the bodies'
// ratio gaps (0.1-0.2 on knee_flexion_sizes): a sharper minimum ranks on fewer strain fields and
// left the worst body lower (docs/DECISIONS.md, "Design loop and storage").
enum class BodyObjective { kMean, kWorst };
inline constexpr double kWorstBodyTemperature = 1.0;
const char* ToString(BodyObjective objective);  // "mean", "worst"
// "mean" / "worst"; else an error naming `what`.
Result<BodyObjective> BodyObjectiveFromName(const std::string& name, const std::string& what);

// A mirror plane (garment.symmetry): through `point_m` with unit `normal`. The default is the
// parametric body's sagittal plane, x = 0 (core/body/parametric_body.h: +x is the body's left).
// tolerance_m: how far a face's mirrored rest centroid may lie from its partner's; 0: twice the
// garment's mean rest edge length.
struct SymmetryPlane {
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
  double tolerance_m = 0;
};

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
  // Where the garment is cut into pattern pieces for fabrication: paths of garment vertices along
  // edges (empty: kgd chooses). No effect on the simulation.
  std::vector<std::vector<int>> seams;
  double attachment_stiffness_N_per_m = kDefaultAttachmentStiffness;
  std::vector<Clamp> clamps;
  SolverSettings solver;
  std::string description;
  double budget = 1.0;             // reinforced fraction of the garment area a design job aims at
  // Design constraints of a design job (garment faces; no effect on a simulation): keep_out faces are
  // never reinforced, keep_in faces always are; `symmetry`: every design is mirror symmetric about it.
  std::vector<int> keep_out_faces, keep_in_faces;
  std::optional<SymmetryPlane> symmetry;
  // The skin pressure (core/sim/skin_pressure.h) a design job keeps every resisted motion's deformed
  // pose at or below, Pa (key max_pressure_kPa; the job's default, core/beso/pressure_limit.h); 0: none.
  double max_pressure_Pa = 0;

  // Garments cut from the body (garment.region). Then garment = the cut in the motion's rest pose,
  // initial = the cut in the deformed pose, body = the deformed body.
  std::optional<BodyMotion> motion;
  std::vector<int> garment_region;        // body faces
  int subdivisions = 0;
  std::vector<int> attachment_body_faces;
  Eigen::SparseMatrix<double, Eigen::RowMajor> garment_from_body;  // garment vertices = this * body vertices
  Positions on_body;                      // the cut in the simulated pose (attachment anchors); may be empty
  // The field of `body` where the scene already built it (a cut garment placed on it);
  // BuildGarmentModel builds it when empty.
  std::shared_ptr<const BodyField> body_field;

  // The motions a design weighs (a garment cut from the body only). Empty: one motion, the scene's
  // own, named after the scene, resisted with weight 1. Else motions[0] is the scene's own motion
  // (its pose = `motion`) and must be resisted with a positive weight; the others share its rest pose.
  std::vector<SceneMotion> motions;

  // The bodies a design weighs (a garment cut from the body, one motion). Empty: the scene's own body
  // alone. Else bodies[0] is the scene's own (its pose = `motion`) with a positive weight; every other
  // body performs the same motion with the scene body's faces, and the garment is cut from it by the
  // same region, subdivisions and attachment faces.
  std::vector<SceneBody> bodies;
  BodyObjective body_objective = BodyObjective::kMean;
};

// The scene's motions as a design sees them: `motions`, or the scene's own as one resisted motion.
// A scene of several bodies: one resisted motion per body (named after the body, its weight), so
// that per-body figures travel as per-motion figures do.
std::vector<SceneMotion> MotionsOf(const SceneSpec& spec);

// Ok for a scene without `bodies`; else: a garment cut from the body, one motion, unique non-empty
// names, finite weights >= 0 (the first > 0), the first body the scene's own, every body with the
// scene body's faces and vertex count in every pose. The message names the body.
Status ValidateSceneBodies(const SceneSpec& spec);

// The scene on body b of `bodies` (0: the scene itself): its motion, body, field, the garment cut from
// it by the scene's region (rest shape, on_body = initial, attachment anchors); the design kept.
// Errors name the body (a garment of other faces than the scene's among them).
// Precondition: ValidateSceneBodies(spec) is ok.
Result<SceneSpec> SceneOnBody(const SceneSpec& spec, int b);

// Ok for a scene without `motions`; else: a garment cut from the body, unique non-empty names,
// finite weights >= 0, every pose over the scene's rest body (same topology and rest positions), the
// first motion resisted with a positive weight. The message names the motion.
Status ValidateSceneMotions(const SceneSpec& spec);

// The scene in motion m of MotionsOf(spec) (0: the scene itself): body, its field, the garment on it
// (on_body = initial) and the motion's frames. Precondition: ValidateSceneMotions(spec) is ok.
Result<SceneSpec> SceneInMotion(const SceneSpec& spec, int m);

// Cuts the garment from `spec->motion` (region, subdivisions, attachment body faces) and sets garment,
// initial, body, attachment_faces, garment_from_body and on_body. Resets the design to all cloth.
// With contact, the garment lies on the body's smooth surface (the body field's zero set), not on its
// facets: the rest shape is the cut placed on the rest body's field, and on_body (= initial) the cut
// placed on the deformed body's field. A garment whose body does not move then stores no energy.
// Precondition: spec->effects and spec->body_support_scale are final.
Status CutGarmentFromMotion(SceneSpec* spec, const std::string& region_name = "garment.region",
                            const std::string& attachments_name = "attachments.body_faces");

// The cut garment on the body in one pose of its motion (vertices x 3): with contact placed on that
// pose's body field, which `field` (optional) receives; else the cut moved with the body's facets.
Result<Positions> GarmentOnBody(const SceneSpec& spec, const Positions& body_pose, std::shared_ptr<const BodyField>* field = nullptr);

// The scene in one frame of its motion (0-based): body, its field and the anchors at that frame; the
// start positions are the garment on the body there (callers may replace them, e.g. with the previous
// frame's equilibrium moved with the body). Precondition: motion has frames.
Result<SceneSpec> SceneAtFrame(const SceneSpec& spec, int frame);

// The simulator's model: builds the body field only when the scene's effects use contact.
Result<GarmentModel> BuildGarmentModel(const SceneSpec& spec);

}  // namespace kgd
