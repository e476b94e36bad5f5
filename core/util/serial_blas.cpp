#include "core/util/serial_blas.h"

#include <dlfcn.h>

#include <mutex>

namespace kgd {

void UseSerialBlas() {
  static std::once_flag once;
  std::call_once(once, [] {
    // Looked up, not linked: the BLAS behind libblas.so.3 may be another implementation.
    using SetThreads = void (*)(int);
    using Shutdown = int (*)();
    if (auto set = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) {
      set(1);
      // With one thread OpenBLAS never hands work to its pool again, so stopping the pool is safe; it
      // is what OpenBLAS itself does before a fork.
      if (auto shutdown = reinterpret_cast<Shutdown>(dlsym(RTLD_DEFAULT, "blas_thread_shutdown_"))) shutdown();
    }
  });
}

}  // namespace kgd
