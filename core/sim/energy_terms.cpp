#include "core/sim/energy_terms.h"

namespace kgd {

const std::vector<TermRegistration>& EnergyTermRegistry() {
#define KGD_REGISTER_TERM(Y, Class, key, sum_place, Type, effect, value, effect_what, time_what) {#key, sum_place, Make##Class##Term},
  static const std::vector<TermRegistration> registry = {KGD_ENERGY_TERMS(KGD_REGISTER_TERM, )};
#undef KGD_REGISTER_TERM
  return registry;
}

}  // namespace kgd
