// The keys of a scene file, each once: section, key, and what it holds (units SI). A section is an
// object of the file, named after its kgd.v1 message (proto/kgd/v1/kgd.proto) where it has one;
// SceneDesign and SceneClampBox are the object forms of the garment's design and of a clamp's
// vertices, which the message holds as a google.protobuf.Value.
//
// The scene loader accepts exactly these keys (an unknown key is an error that lists them), the
// exporter writes only these, and proto/job_spec_test checks the list against the message fields:
// a key added here without its field, or a field without its key, fails there.
#pragma once

#include <string>
#include <vector>

#include "core/sim/term_list.h"

// X(section, key, what)
#define KGD_SCENE_KEYS(X)                                                                             \
  X(Scene, name, "the scene's name")                                                                  \
  X(Scene, description, "free text")                                                                  \
  X(Scene, budget, "fraction of the garment's area a design job reinforces, in (0, 1]")               \
  X(Scene, garment, "SceneGarment: a mesh of its own, or a region cut from the body")                 \
  X(Scene, materials, "SceneMaterials: cloth and reinforcement")                                      \
  X(Scene, effects, "SceneEffects: the energy terms the scene simulates")                             \
  X(Scene, body, "SceneBody: one pose (contact), or a motion (rest, deformed, frames)")               \
  X(Scene, motions, "[SceneMotion, ...]: with garment.region, the motions a design weighs (the first: the body's own)") \
  X(Scene, contact, "SceneContact: garment-body contact")                                             \
  X(Scene, attachments, "SceneAttachments: faces held to the body (straps, silicone)")                \
  X(Scene, clamps, "[SceneClamp, ...]: prescribed vertices")                                          \
  X(Scene, solver, "SceneSolver: the static solve")                                                   \
  X(Scene, max_pressure_kPa, "design jobs keep the skin pressure of every resisted motion's deformed pose at or below this, kPa") \
  X(Scene, bodies, "[SceneRangeBody, ...]: with garment.region, the bodies a design weighs, each in the scene's motion (the first: the scene's own)") \
  X(Scene, body_objective, "with bodies: \"mean\" (default) or \"worst\", what a design weighs of the bodies' density ratios") \
  X(SceneGarment, rest, "a garment mesh of its own: OBJ or PLY, relative to the scene file")          \
  X(SceneGarment, initial, "its start positions (the deformed pose); default: the rest mesh")         \
  X(SceneGarment, region, "or: body faces of the rest pose, \"faces.txt\" or [0, 1, ...], 0-based")   \
  X(SceneGarment, subdivisions, "midpoint subdivisions of the region (each turns 1 face into 4)")     \
  X(SceneGarment, design, "\"all_cloth\", \"all_reinforced\" or a SceneDesign object")                \
  X(SceneGarment, seams, "where kgd export cuts the pattern: [[v, v, ...], ...] or \"seams.txt\"")    \
  X(SceneGarment, keep_out, "design jobs never reinforce these garment faces: \"faces.txt\" or [0, 1, ...]") \
  X(SceneGarment, keep_in, "design jobs always reinforce these garment faces (counted in the budget)") \
  X(SceneGarment, symmetry, "SceneSymmetry: design jobs keep every design mirror symmetric")         \
  X(SceneSymmetry, point_m, "[x, y, z] on the mirror plane, m (default [0, 0, 0])")                  \
  X(SceneSymmetry, normal, "[nx, ny, nz], the plane's normal (default [1, 0, 0]: the body's sagittal plane)") \
  X(SceneSymmetry, tolerance_m, "mirrored face centroids lie within this of their partners' (default: 2 mean edges), m") \
  X(SceneDesign, reinforced_faces, "garment faces (after subdivision), \"faces.txt\" or [0, 1, ...]") \
  X(SceneMaterials, lame, "\"solid3d\" (the authors' code, default) or \"plane_stress\"")             \
  X(SceneMaterials, cloth, "SceneMaterial: the garment fabric")                                       \
  X(SceneMaterials, reinforced, "SceneMaterial: the reinforcement")                                   \
  X(SceneMaterial, youngs_modulus_Pa, "Young's modulus, Pa")                                          \
  X(SceneMaterial, poisson_ratio, "Poisson's ratio")                                                  \
  X(SceneMaterial, thickness_m, "thickness, m")                                                       \
  X(SceneEffects, relaxation, "\"exact\" (default), \"authors\" or \"none\"")                         \
  X(SceneEffects, clamps, "the clamps (default false)")                                               \
  KGD_ENERGY_TERMS(KGD_SCENE_EFFECT_KEY, X) /* one switch per energy term: core/sim/term_list.h */  \
  X(SceneBody, mesh, "the body in the simulated pose (a garment of its own, with contact)")           \
  X(SceneBody, rest, "with garment.region: the motion's rest pose")                                   \
  X(SceneBody, deformed, "with garment.region: its deformed pose")                                    \
  X(SceneBody, frames, "with garment.region: its frames, each with the topology of rest")             \
  X(SceneBody, support_scale, "the body field's support radius in mean body edge lengths")            \
  X(SceneMotion, name, "the motion's name (unique in the scene)")                                     \
  X(SceneMotion, role, "\"resist\" (default) or \"allow\"; the first motion is resisted")              \
  X(SceneMotion, weight, "its weight in the objective, >= 0 (default 1; 0: simulated and reported only)") \
  X(SceneMotion, deformed, "its deformed pose, the topology of body.rest (the first motion's: body.deformed)") \
  X(SceneMotion, frames, "its frames, each the topology of body.rest (the first motion's: body.frames)") \
  X(SceneRangeBody, name, "the body's name (unique in the scene, e.g. a size)")                       \
  X(SceneRangeBody, weight, "its weight in the objective, >= 0 (default 1; 0: simulated and reported only)") \
  X(SceneRangeBody, rest, "its rest pose, the topology of body.rest (the first body's: body.rest)")   \
  X(SceneRangeBody, deformed, "its deformed pose in the scene's motion (the first body's: body.deformed)") \
  X(SceneRangeBody, frames, "its frames, each the topology of body.rest (the first body's: body.frames)") \
  X(SceneContact, stiffness_N_per_m, "contact penalty stiffness, N/m")                                \
  X(SceneAttachments, faces, "garment faces, \"faces.txt\" or [0, 1, ...]")                           \
  X(SceneAttachments, body_faces, "with garment.region: body faces inside the region")                \
  X(SceneAttachments, stiffness_N_per_m, "attachment spring stiffness, N/m")                          \
  X(SceneClamp, name, "a name for reports")                                                           \
  X(SceneClamp, vertices, "\"vertices.txt\", [0, 1, ...] or a SceneClampBox object")                  \
  X(SceneClamp, axes, "the prescribed coordinates, e.g. \"xyz\" or \"z\"")                            \
  X(SceneClamp, displacement_m, "[dx, dy, dz], m")                                                    \
  X(SceneClampBox, box_min, "[x, y, z] of the box that selects vertices by rest position, m")         \
  X(SceneClampBox, box_max, "[x, y, z], m")                                                           \
  X(SceneSolver, method, "\"newton\" (default) or \"lbfgs\"")                                         \
  X(SceneSolver, grad_tol, "gradient tolerance, dimensionless")                                       \
  X(SceneSolver, max_iterations, "iteration limit of a solve")                                        \
  X(SceneSolver, reuse_factorization, "reuse the Cholesky factorization across Newton steps")         \
  X(SceneSolver, lbfgs_history, "L-BFGS history length")                                              \
  X(SceneSolver, project_contact_crossings, "project vertices that cross the body back out")          \
  X(SceneSolver, local_steps, "local Newton steps on the few vertices that still move")
// (the list ends here)
#define KGD_SCENE_EFFECT_KEY(X, Class, key, sum_place, Type, effect, value, effect_what, time_what) X(SceneEffects, effect, effect_what)

namespace kgd {

// Every key as a constant, scene_key::SECTION::KEY (e.g. scene_key::SceneMaterial::thickness_m): the
// loader and the exporter spell keys only through these, so a key they use is a key of the list.
namespace scene_key {
#define KGD_SCENE_KEY_CONSTANT(section, key, what) \
  namespace section {                              \
  inline constexpr char key[] = #key;              \
  }
KGD_SCENE_KEYS(KGD_SCENE_KEY_CONSTANT)
#undef KGD_SCENE_KEY_CONSTANT
}  // namespace scene_key

struct SceneKey {
  const char* section;
  const char* key;
  const char* what;
};

// Every key of KGD_SCENE_KEYS, in its order.
const std::vector<SceneKey>& SceneKeys();

// The keys of one section, in order; empty for an unknown section.
std::vector<std::string> SceneKeysOf(const std::string& section);

}  // namespace kgd
