// The garment model: what a GarmentSystem (garment_system.h) simulates. The mesh, its design and
// materials, the effects (which energy terms are on: one switch per term of term_list.h) and the data
// the terms read. Terms include this header; it includes no term.
//
// Units: positions m, stiffnesses N/m, moduli Pa.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/body/body_field.h"
#include "core/mesh/trimesh.h"
#include "core/sim/term_list.h"

namespace kgd {

// Materials of the membrane (membrane.h).
enum class LameConversion {
  kSolid3D,      // lambda = E nu / ((1 + nu)(1 - 2 nu)): the authors' code; in-plane nu_eff = 0.4925 at nu = 0.33
  kPlaneStress,  // lambda = E nu / (1 - nu^2): the thin-sheet reduction; in-plane nu_eff = nu
};

enum class Relaxation { kExact, kAuthors, kNone };

struct Material {
  double youngs_modulus_Pa = 0.5e6;
  double poisson_ratio = 0.33;
  double thickness_m = 0.27e-3;
};

// The paper's two materials (section "Material Parameters and 2D Validation").
inline Material ClothMaterial() { return {0.5e6, 0.33, 0.27e-3}; }
inline Material ReinforcedMaterial() { return {5.7e6, 0.33, 0.35e-3}; }

// Contact with the body (contact.h).
enum class ContactModel { kNone, kUnilateral, kBilateral };
inline constexpr double kDefaultContactStiffness = 5000.0;  // N/m

// Attachments (attachment.h).
inline constexpr double kDefaultAttachmentStiffness = 3000.0;  // N/m
struct Attachments {
  std::vector<int> faces;  // garment face indices
  Positions anchors;       // one anchor per attached face (m)
  double stiffness_N_per_m = kDefaultAttachmentStiffness;
};

// Friction (friction.h): the slip distance eps.
inline constexpr double kDefaultFrictionSlip = 1e-4;  // m

// A set of vertices with prescribed positions, e.g. the jaws of a pull tester. Only the coordinates
// marked in `axes` are prescribed: target = initial position + displacement.
struct Clamp {
  std::string name;
  std::vector<int> vertices;
  std::array<bool, 3> axes = {true, true, true};
  Eigen::Vector3d displacement_m = Eigen::Vector3d::Zero();
};

// What the system simulates: the membrane's relaxation, the clamps, and one switch per energy term
// (term_list.h: membrane, contact, attachments, fold_barrier, friction, bending, ...). Extensions of
// the paper's model: the fold barrier (on), friction (0: frictionless) and bending (off).
struct Effects {
  Relaxation relaxation = Relaxation::kExact;
  bool clamps = false;
#define KGD_EFFECT_MEMBER(Y, Class, key, sum_place, Type, effect, value, effect_what, time_what) Type effect = value;
  KGD_ENERGY_TERMS(KGD_EFFECT_MEMBER, )
#undef KGD_EFFECT_MEMBER
};

// Design values per face.
enum : uint8_t { kCloth = 0, kReinforced = 1 };

struct GarmentModel {
  Faces faces;
  Positions rest;                  // rest positions; each triangle's rest shape is taken in its own plane
  std::vector<uint8_t> design;     // per face: kCloth or kReinforced
  Material cloth = ClothMaterial();
  Material reinforced = ReinforcedMaterial();
  LameConversion lame = LameConversion::kSolid3D;
  Effects effects;
  std::shared_ptr<const BodyField> body;  // required when effects.contact != kNone
  double contact_stiffness_N_per_m = kDefaultContactStiffness;
  Attachments attachments;                // used when effects.attachments
  std::vector<Clamp> clamps;              // used when effects.clamps
  // Orientation the fold barrier measures folds against (the garment on the body); empty: the
  // positions the system is constructed with.
  Positions fold_reference;
  // Friction: where each vertex was put on the body (anchors); empty: the construction positions.
  Positions friction_anchor;
  double friction_slip_m = kDefaultFrictionSlip;
};

}  // namespace kgd
