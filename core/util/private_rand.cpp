#include "core/util/private_rand.h"

#include <dlfcn.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>

namespace kgd {
namespace {

// glibc's rand() is random() of its default state: TYPE_3, 128 bytes (initstate's size for it).
struct ThreadRand {
  random_data data;
  alignas(int32_t) char state[128];
};
thread_local ThreadRand* current = nullptr;

using RandFn = int (*)();
using SrandFn = void (*)(unsigned);

RandFn LibcRand() {
  static const RandFn f = reinterpret_cast<RandFn>(dlsym(RTLD_NEXT, "rand"));
  return f;
}
SrandFn LibcSrand() {
  static const SrandFn f = reinterpret_cast<SrandFn>(dlsym(RTLD_NEXT, "srand"));
  return f;
}

}  // namespace

PrivateRand::PrivateRand() : previous_(current) {
  auto* r = new ThreadRand;
  std::memset(r, 0, sizeof *r);  // initstate_r reads the old state's type from `data`
  initstate_r(1, r->state, sizeof r->state, &r->data);  // srand(1): libc's state before any srand()
  own_ = current = r;
}

PrivateRand::~PrivateRand() {
  delete static_cast<ThreadRand*>(own_);
  current = static_cast<ThreadRand*>(previous_);
}

bool PrivateRandIsBound() {
  // The definitions a shared library's call reaches: the first in the global scope.
  return reinterpret_cast<void*>(dlsym(RTLD_DEFAULT, "rand")) == reinterpret_cast<void*>(&::rand) &&
         dlsym(RTLD_DEFAULT, "srand") == reinterpret_cast<void*>(&::srand) && LibcRand() != nullptr &&
         reinterpret_cast<void*>(LibcRand()) != reinterpret_cast<void*>(&::rand);
}

}  // namespace kgd

extern "C" int rand() noexcept {
  if (kgd::current) {
    int32_t r = 0;
    random_r(&kgd::current->data, &r);
    return r;
  }
  return kgd::LibcRand()();
}

extern "C" void srand(unsigned seed) noexcept {
  if (kgd::current) {
    srandom_r(seed, &kgd::current->data);
    return;
  }
  kgd::LibcSrand()(seed);
}
