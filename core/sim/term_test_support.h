// For tests that make one energy term of the garment system on its own (MakeAttachmentTerm,
// MakeFrictionTerm, ...): the data a TermContext refers to, owned in one place. Set the model (and
// the lagged friction data) first, then make the term from Context().
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/sim/energy_terms.h"
#include "core/sim/garment_system.h"

namespace kgd::testing {

struct TermContextStorage {
  GarmentModel model;
  std::vector<MembraneElement> elements;
  Lame lame[2];
  double thickness[2] = {0, 0};
  std::vector<Eigen::Vector3d> fold_reference;
  std::vector<NeighborCache> caches;
  std::vector<FrictionVertex> friction;
  Hinges hinges;

  TermContext Context() { return TermContext{model, elements, lame, thickness, fold_reference, caches, friction, hinges}; }
};

}  // namespace kgd::testing
