// The BLAS runs on the calling thread only: OpenBLAS is set to one thread and its idle worker threads
// are stopped. Our factors have thousands of small supernodes, where BLAS threading costs more than it
// gives, and the two cores go to our own OpenMP regions (two-domain factorization, assembly).
//
// Why the workers are stopped, not just left unused: OpenBLAS starts them when the library loads and
// each one spins in sched_yield for its timeout (~2^28 cycles, about 0.1 s) before it sleeps. On two
// cores that spin takes one core from the first parallel assembly of every process (the first
// evaluation of the 7k-vertex sleeve would take six times as long).
//
// Call before the first parallel region or BLAS call of a component (GarmentSystem and SparseCholesky
// do). Idempotent and thread-safe (the work is done once per process, and no BLAS call of ours can run
// before it). No effect when the BLAS behind libblas.so.3 is not OpenBLAS.
#pragma once

namespace kgd {

void UseSerialBlas();

}  // namespace kgd
