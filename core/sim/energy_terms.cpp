#include "core/sim/energy_terms.h"

namespace kgd {

const std::vector<TermRegistration>& EnergyTermRegistry() {
#define KGD_REGISTER_TERM(Name, key, place) {key, place, Make##Name},
  static const std::vector<TermRegistration> registry = {KGD_ENERGY_TERMS(KGD_REGISTER_TERM)};
#undef KGD_REGISTER_TERM
  return registry;
}

}  // namespace kgd
