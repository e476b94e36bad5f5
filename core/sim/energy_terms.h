// The registry of energy terms: every term the garment system knows, the order an element sums them
// in, and the order the energy breakdown lists them in. The system makes each registered term whose
// factory returns one (the scene's effects switch it on) and evaluates only those.
#pragma once

#include <memory>
#include <vector>

#include "core/sim/energy_term.h"

namespace kgd {

struct GarmentModel;
struct Lame;
struct MembraneElement;
struct NeighborCache;
struct FrictionVertex;

// What a term may read when it is made. The references stay valid for the system's life; the model's
// design changes in place between solves (GarmentSystem::SetDesign), the lagged friction data with
// GarmentSystem::LagFriction.
struct TermContext {
  const GarmentModel& model;
  const std::vector<MembraneElement>& elements;         // per face: rest shape and rest area
  const Lame* lame;                                      // per material: cloth, reinforced
  const double* thickness_m;                             // per material
  const std::vector<Eigen::Vector3d>& fold_reference;    // per face: unit normal folds are measured against
  std::vector<NeighborCache>& caches;                    // per vertex: the body field's neighbour lists
  const std::vector<FrictionVertex>& friction;           // per vertex, lagged (empty until lagged)
  const Hinges& hinges;
};

// Every term, in the order an element sums the terms of its stencil: X(Name, "key", breakdown place).
// A term's factory MakeName (beside the term, in its own .cpp) returns nullptr when the model leaves
// it off. "key" names it in the energy breakdown (messages print it with spaces); the breakdown lists
// the terms, and its total sums them, by their place.
#define KGD_ENERGY_TERMS(X)               \
  X(MembraneTerm, "membrane", 0)          \
  X(FoldBarrierTerm, "fold_barrier", 3)   \
  X(AttachmentTerm, "attachment", 2)      \
  X(ContactTerm, "contact", 1)            \
  X(FrictionTerm, "friction", 4)          \
  X(BendingTerm, "bending", 5)            \
  /* a new term: one line above this one */

#define KGD_DECLARE_TERM_FACTORY(Name, key, place) std::unique_ptr<EnergyTerm> Make##Name(const TermContext& context);
KGD_ENERGY_TERMS(KGD_DECLARE_TERM_FACTORY)
#undef KGD_DECLARE_TERM_FACTORY

struct TermRegistration {
  const char* name;
  int breakdown_order;
  std::unique_ptr<EnergyTerm> (*make)(const TermContext&);
};
// KGD_ENERGY_TERMS as a table, in its order.
const std::vector<TermRegistration>& EnergyTermRegistry();

}  // namespace kgd
