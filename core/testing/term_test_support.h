// For tests that make one energy term of the garment system on its own (MakeAttachmentTerm,
// FrictionTerm, ...): the data a TermContext refers to, owned in one place. Set the model (and the
// initial positions, where the term reads them) first, then make the term from Context().
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/body/body_field.h"
#include "core/mesh/topology.h"
#include "core/sim/energy_terms.h"
#include "core/sim/garment_model.h"

namespace kgd::testing {

struct TermContextStorage {
  GarmentModel model;
  Positions initial;
  std::vector<NeighborCache> caches;
  Hinges hinges;

  TermContext Context() { return TermContext{model, initial, caches, hinges}; }
};

}  // namespace kgd::testing
