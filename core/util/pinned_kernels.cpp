#include "core/util/pinned_kernels.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace kgd {
namespace {

constexpr const char* kBlasCore = "Prescott";
constexpr const char* kHwcaps = "glibc.cpu.hwcaps=-FMA,-FMA4";

bool Has(const char* name, const std::string& text) {
  const char* v = std::getenv(name);
  return v && std::string(v).find(text) != std::string::npos;
}

bool Pinned() {
  const char* core = std::getenv("OPENBLAS_CORETYPE");
  return core && std::strcmp(core, kBlasCore) == 0 && Has("GLIBC_TUNABLES", kHwcaps);
}

}  // namespace

void PinNumericKernels(char** argv) {
  if (Pinned() || std::getenv("KGD_NATIVE_KERNELS")) return;
  // Set by the first execution: never loop when the pinned environment does not take.
  if (std::getenv("KGD_PINNED_KERNELS")) {
    std::fprintf(stderr, "kgd: warning: could not pin the numeric kernels; results may differ between machines\n");
    return;
  }
  setenv("OPENBLAS_CORETYPE", kBlasCore, 1);
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  // GLIBC_TUNABLES is a colon-separated list; a later hwcaps entry would replace ours, so ours goes last.
  const std::string pinned = tunables && *tunables ? std::string(tunables) + ":" + kHwcaps : std::string(kHwcaps);
  setenv("GLIBC_TUNABLES", pinned.c_str(), 1);
  setenv("KGD_PINNED_KERNELS", "1", 1);
  execv("/proc/self/exe", argv);
  std::fprintf(stderr, "kgd: warning: could not pin the numeric kernels (exec: %s); results may differ between machines\n",
               std::strerror(errno));
}

}  // namespace kgd
