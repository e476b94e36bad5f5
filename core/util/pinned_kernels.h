// The same floating-point results on every x86-64 machine: the libraries that choose their kernels by
// the CPU they run on are pinned to one choice that every x86-64 CPU runs.
//
// Two libraries choose at run time:
//  - OpenBLAS (DYNAMIC_ARCH in Debian) picks its kernels per CPU (Haswell's FMA kernels on an AMD
//    EPYC, Sandybridge's on an older Xeon), so CHOLMOD's dense fronts round differently;
//  - glibc's libm picks FMA versions of exp, log, pow, sin, ... where the CPU has FMA.
// Either alone changes a design job's iterations and its final design. Both read their choice from the
// environment when the process starts (OPENBLAS_CORETYPE; GLIBC_TUNABLES=glibc.cpu.hwcaps=-FMA,-FMA4),
// so PinNumericKernels sets the two and executes the program again, once, before anything else runs.
// The pinned kernels are OpenBLAS's Prescott (SSE3) kernels and libm's SSE2 paths; on 2 cores of an
// AMD EPYC they cost about 10 % per design iteration (docs/PERFORMANCE.md).
//
// The number of threads needs no pin: BLAS runs serially (serial_blas.h), the factorization splits into
// exactly two domains whatever the core count, and assembly reductions are per element.
//
// KGD_NATIVE_KERNELS=1 in the environment leaves the machine's own choice (faster on some CPUs,
// different results across machines).
#pragma once

namespace kgd {

// Call first in main() of a program whose results must not depend on the machine (kgd, kgd-worker).
// Returns when the environment is pinned (or KGD_NATIVE_KERNELS is set); otherwise replaces the
// process with the same program and arguments under the pinned environment. When that fails, prints a
// warning and returns with the machine's own kernels.
void PinNumericKernels(char** argv);

}  // namespace kgd
