// The same floating-point results on every x86-64 machine of a level: the libraries that choose their
// kernels by the CPU they run on are pinned to one choice per instruction-set level.
//
// Two libraries choose at run time:
//  - OpenBLAS (DYNAMIC_ARCH in Debian) picks its kernels per CPU (SkylakeX's AVX-512 kernels on an AMD
//    EPYC 4th generation, Sandybridge's on an older Xeon), so CHOLMOD's dense fronts round differently;
//  - glibc's libm picks FMA versions of exp, log, pow, sin, ... where the CPU has FMA and AVX2.
// Either alone changes a design job's iterations and its final design. Both read their choice from the
// environment when the process starts (OPENBLAS_CORETYPE; GLIBC_TUNABLES=glibc.cpu.hwcaps=...), so
// PinNumericKernels sets the two and executes the program again, once, before anything else runs.
//
// The levels (the names are the x86-64 psABI's):
//  - "x86-64-v3" (AVX2 and FMA: Intel since Haswell, 2013; AMD since Excavator/Zen): OpenBLAS's Haswell
//    kernels and libm's FMA paths (AVX-512 masked);
//  - "x86-64" (every x86-64 CPU): OpenBLAS's Prescott (SSE3) kernels and libm's SSE2 paths (FMA masked),
//    about 10 % slower per design iteration on an AMD EPYC (docs/PERFORMANCE.md).
// Designs repeat bit for bit on every machine of one level and differ between levels; a design file
// records its level (store/design_file.h) and a resume runs at the file's level (PinNumericKernelsTo).
//
// The number of threads needs no pin: BLAS runs serially (serial_blas.h), the factorization splits into
// exactly two domains whatever the core count, and assembly reductions are per element.
//
// Environment:
//  - KGD_KERNELS=x86-64: never use a level above it (a lab whose machines differ pins all to x86-64, so
//    that a job gives the same designs on any of them); another value than a level's name stops the
//    program (PinNumericKernels);
//  - KGD_NATIVE_KERNELS=1 (any value but empty or 0): no pin; the machine's own choice (results differ
//    across machines).
#pragma once

#include <string>

#include "core/util/status.h"

namespace kgd {

inline constexpr const char* kKernelsX8664 = "x86-64";
inline constexpr const char* kKernelsX8664V3 = "x86-64-v3";
inline constexpr const char* kKernelsNative = "native";  // KGD_NATIVE_KERNELS: not pinned

// The highest level this machine runs ("x86-64-v3" or "x86-64"), capped by KGD_KERNELS.
std::string MachineKernelLevel();

// The kernels this process runs with: the pinned level's name, "native" under KGD_NATIVE_KERNELS, or
// "unpinned" when the pin did not take (a warning said so).
std::string RunningKernels();

// Call first in main() of a program whose results must not depend on the machine (kgd, kgd-worker).
// Returns when the environment is pinned (to MachineKernelLevel(), or to the level a PinNumericKernelsTo
// of this process chose) or KGD_NATIVE_KERNELS is set; otherwise replaces the process with the same
// program and arguments under the pinned environment. When that fails, prints a warning and returns
// with the machine's own kernels. Exits with status 2, naming the value, when KGD_KERNELS is set to
// something other than a level's name.
void PinNumericKernels(char** argv);

// Runs the process at `level` (a resume at its design file's level): returns Ok when it already does
// (or runs native kernels); an error naming the level when it is unknown or above MachineKernelLevel();
// otherwise executes the program again, with the arguments PinNumericKernels was given, under that
// level's pin (returns only when that fails, with an error). Close files first: nothing of this process
// survives but its open descriptors.
Status PinNumericKernelsTo(const std::string& level);

}  // namespace kgd
