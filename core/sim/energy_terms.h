// The registry of energy terms: every term of the term list (term_list.h), in its order, with its
// factory. The system makes each registered term whose factory returns one (the scene's effects
// switch it on) and evaluates only those.
#pragma once

#include <memory>
#include <vector>

#include "core/sim/energy_term.h"
#include "core/sim/term_list.h"

namespace kgd {

struct GarmentModel;
struct NeighborCache;

// What a term may read when it is made. `model`, `caches` and `hinges` stay valid for the system's
// life (the model's design changes in place between solves: GarmentSystem::SetDesign); `initial`, the
// positions the system is constructed with, only while the term is made.
struct TermContext {
  const GarmentModel& model;
  const Positions& initial;
  std::vector<NeighborCache>& caches;  // per vertex: the body field's neighbour lists (empty without a body)
  const Hinges& hinges;
};

#define KGD_DECLARE_TERM_FACTORY(Y, Class, key, sum_place, Type, effect, value, effect_what, time_what) \
  std::unique_ptr<EnergyTerm> Make##Class##Term(const TermContext& context);
KGD_ENERGY_TERMS(KGD_DECLARE_TERM_FACTORY, )
#undef KGD_DECLARE_TERM_FACTORY

struct TermRegistration {
  const char* name;  // the term list's key
  int sum_place;     // its place in the order an element sums its stencil's terms
  std::unique_ptr<EnergyTerm> (*make)(const TermContext&);
};
// The term list as a table, in its order.
const std::vector<TermRegistration>& EnergyTermRegistry();

}  // namespace kgd
