#include "core/util/pinned_kernels.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>

namespace kgd {
namespace {

struct KernelPin {
  const char* level;
  const char* blas_core;  // OPENBLAS_CORETYPE
  const char* hwcaps;     // glibc.cpu.hwcaps
};

constexpr KernelPin kPins[] = {
    {kKernelsX8664V3, "Haswell", "-AVX512F,-FMA4"},
    {kKernelsX8664, "Prescott", "-FMA,-FMA4"},
};
constexpr const char* kHwcapsKey = "glibc.cpu.hwcaps=";
constexpr const char* kPinnedMarker = "KGD_PINNED_KERNELS";  // the level this program pinned itself to
char** g_argv = nullptr;                                     // PinNumericKernels's, for PinNumericKernelsTo

const KernelPin* PinOf(const std::string& level) {
  for (const KernelPin& p : kPins)
    if (level == p.level) return &p;
  return nullptr;
}

// Levels in order; -1 for an unknown name.
int Rank(const std::string& level) {
  if (level == kKernelsX8664) return 0;
  if (level == kKernelsX8664V3) return 1;
  return -1;
}

std::string Env(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

// GLIBC_TUNABLES without its glibc.cpu.hwcaps entries (a colon-separated list).
std::string TunablesWithoutHwcaps() {
  std::stringstream in(Env("GLIBC_TUNABLES"));
  std::string item, out;
  while (std::getline(in, item, ':'))
    if (!item.empty() && item.rfind(kHwcapsKey, 0) != 0) out += (out.empty() ? "" : ":") + item;
  return out;
}

// The environment is `pin`'s: the core type, and the only hwcaps entry ours.
bool EnvironmentIs(const KernelPin& pin) {
  if (Env("OPENBLAS_CORETYPE") != pin.blas_core) return false;
  std::stringstream in(Env("GLIBC_TUNABLES"));
  std::string item, hwcaps;
  while (std::getline(in, item, ':'))
    if (item.rfind(kHwcapsKey, 0) == 0) hwcaps = item.substr(std::strlen(kHwcapsKey));
  return hwcaps == pin.hwcaps;
}

// KGD_NATIVE_KERNELS is set to something other than "" or "0".
bool Native() {
  const std::string v = Env("KGD_NATIVE_KERNELS");
  return !v.empty() && v != "0";
}

std::string CpuLevel() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("x86-64-v3") ? kKernelsX8664V3 : kKernelsX8664;
}

// Sets `pin`'s environment and executes the program again; returns the exec's error.
std::string Exec(const KernelPin& pin, char** argv) {
  setenv("OPENBLAS_CORETYPE", pin.blas_core, 1);
  const std::string rest = TunablesWithoutHwcaps();
  const std::string tunables = (rest.empty() ? "" : rest + ":") + kHwcapsKey + pin.hwcaps;
  setenv("GLIBC_TUNABLES", tunables.c_str(), 1);
  setenv(kPinnedMarker, pin.level, 1);
  execv("/proc/self/exe", argv);
  return std::strerror(errno);
}

}  // namespace

std::string MachineKernelLevel() {
  const std::string cpu = CpuLevel(), cap = Env("KGD_KERNELS");
  return Rank(cap) >= 0 && Rank(cap) < Rank(cpu) ? cap : cpu;
}

std::string RunningKernels() {
  if (Native()) return kKernelsNative;
  const KernelPin* pin = PinOf(Env(kPinnedMarker));
  return pin && EnvironmentIs(*pin) ? pin->level : "unpinned";
}

void PinNumericKernels(char** argv) {
  g_argv = argv;
  if (Native()) return;
  // A lab that caps its machines must not get another level's designs from a typo.
  if (const std::string cap = Env("KGD_KERNELS"); !cap.empty() && Rank(cap) < 0) {
    std::fprintf(stderr, "kgd: KGD_KERNELS=%s is not a kernel level: give x86-64 or x86-64-v3, or unset it\n", cap.c_str());
    std::exit(2);
  }
  const std::string marker = Env(kPinnedMarker);
  const KernelPin* pinned = PinOf(marker);
  // Already pinned by this program (at start, or to a design file's level), at a level this machine runs.
  if (pinned && Rank(pinned->level) <= Rank(MachineKernelLevel())) {
    if (EnvironmentIs(*pinned)) return;
    // The marker is set but the environment is not the pin's: the exec did not take; never loop.
    std::fprintf(stderr, "kgd: warning: could not pin the numeric kernels; results may differ between machines\n");
    return;
  }
  const std::string error = Exec(*PinOf(MachineKernelLevel()), argv);
  std::fprintf(stderr, "kgd: warning: could not pin the numeric kernels (exec: %s); results may differ between machines\n",
               error.c_str());
}

Status PinNumericKernelsTo(const std::string& level) {
  const KernelPin* pin = PinOf(level);
  if (!pin) return Status::Error("kernel level '" + level + "' is not one this kgd knows (x86-64, x86-64-v3)");
  const std::string running = RunningKernels();
  if (running == level || running == kKernelsNative) return Status::Ok();
  if (Rank(level) > Rank(MachineKernelLevel()))
    return Status::Error(Env("KGD_KERNELS").empty() ? "this machine does not run the " + level + " kernels (its CPU lacks AVX2 or FMA)"
                                                    : "KGD_KERNELS=" + Env("KGD_KERNELS") + " keeps this machine below the " + level + " kernels");
  if (!g_argv) return Status::Error("cannot run the " + level + " kernels: the program did not pin its kernels at start");
  return Status::Error("cannot run the " + level + " kernels (exec: " + Exec(*pin, g_argv) + ")");
}

}  // namespace kgd
