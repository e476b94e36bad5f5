#include "core/util/serial_blas.h"

#include <dirent.h>
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <cmath>

extern "C" void dpotrf_(const char* uplo, const int* n, double* a, const int* lda, int* info, size_t);

namespace kgd {
namespace {

int ThreadsInProcess() {
  int n = 0;
  if (DIR* d = opendir("/proc/self/task")) {
    while (const dirent* e = readdir(d))
      if (e->d_name[0] != '.') ++n;
    closedir(d);
  }
  return n;
}

// OpenBLAS starts its workers when it loads (one per further core); afterwards only this thread is left,
// and the BLAS still computes on it. This binary runs no OpenMP region before the check.
TEST(SerialBlas, StopsTheBlasWorkersAndKeepsTheBlasWorking) {
  const int before = ThreadsInProcess();
  UseSerialBlas();
  UseSerialBlas();  // idempotent
  EXPECT_EQ(ThreadsInProcess(), 1) << "threads before: " << before;
  using GetThreads = int (*)();
  if (auto get = reinterpret_cast<GetThreads>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"))) {
    EXPECT_EQ(get(), 1);
  }
  // Cholesky of [4 2; 2 3]: L = [2 0; 1 sqrt(2)] (column-major, lower).
  double a[4] = {4, 2, 2, 3};
  const int n = 2;
  int info = -1;
  dpotrf_("L", &n, a, &n, &info, 1);
  EXPECT_EQ(info, 0);
  EXPECT_DOUBLE_EQ(a[0], 2.0);
  EXPECT_DOUBLE_EQ(a[1], 1.0);
  EXPECT_NEAR(a[3], std::sqrt(2.0), 1e-15);
}

}  // namespace
}  // namespace kgd
