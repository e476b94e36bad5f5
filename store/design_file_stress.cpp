// design_file_stress TRIALS [SEED]: kills a design-file writer with SIGKILL at random moments of its
// append cycle, TRIALS times, and after each kill reopens the file (DesignFileWriter::Reopen rebuilds a
// killed writer's file from its intact iterations), appends one iteration and reads everything back.
// Prints how many kills damaged committed iterations and what Reopen kept of them, and fails (exit 1) if a
// reopen, an append or a read fails or an iteration reads back different from what was written.
// Not a test: a thousand trials take minutes (docs/PERFORMANCE.md, "Design files").
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "store/design_file.h"

namespace {

using namespace kgd;

// Iteration k of the synthetic run: every array holds k, so a row read back names itself.
BesoIteration MakeIteration(int k, int nv, int nf) {
  BesoIteration it;
  it.iteration = k;
  it.energy_J = k;
  it.design.assign(nf, static_cast<uint8_t>(k % 2));
  it.positions = Positions::Constant(nv, 3, k);
  it.energy_density_Pa = Eigen::VectorXd::Constant(nf, k);
  it.sensitivity = Eigen::VectorXd::Constant(nf, k);
  return it;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: design_file_stress TRIALS [SEED]\n");
    return 2;
  }
  const int trials = std::atoi(argv[1]);
  std::mt19937 rng(argc > 2 ? std::atoi(argv[2]) : 1);
  const int nv = 1500, nf = 2800;  // about the pull-test sample's size
  DesignFileHeader h;
  h.scene = "design_file_stress";
  h.garment.vertices = Eigen::MatrixXd::Random(nv, 3);
  h.garment.faces.resize(nf, 3);
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) h.garment.faces(f, k) = (f + k) % nv;
  h.initial = h.garment.vertices;
  h.rest_area_m2 = Eigen::VectorXd::Ones(nf);
  const std::string path = (std::filesystem::temp_directory_path() / ("kgd_design_file_stress_" + std::to_string(getpid()) + ".h5")).string();
  int damaged = 0, failures = 0;
  for (int t = 0; t < trials; ++t) {
    std::filesystem::remove(path + ".ready");
    const pid_t child = fork();
    if (child == 0) {
      auto w = DesignFileWriter::Create(path, h);
      if (!w.ok()) _exit(1);
      std::ofstream(path + ".ready") << "1";
      for (int k = 0;; ++k)
        if (!(*w)->Append(MakeIteration(k, nv, nf)).ok()) _exit(2);
    }
    for (int i = 0; i < 10000 && !std::filesystem::exists(path + ".ready"); ++i) usleep(1000);
    usleep(std::uniform_int_distribution<int>(0, 150000)(rng));
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    const Result<DesignFile> before = ReadDesignFile(path, {.arrays = false});
    auto w = DesignFileWriter::Reopen(path);
    if (!w.ok()) {
      ++failures;
      std::fprintf(stderr, "trial %d: %s\n", t, w.message().c_str());
      continue;
    }
    const int n = (*w)->num_iterations();
    if (!before.ok() || n < static_cast<int>(before->iterations.size())) {
      ++damaged;
      std::fprintf(stderr, "trial %d: %s\n", t, (*w)->repair_note().c_str());
    }
    Status appended = (*w)->Append(MakeIteration(n, nv, nf));
    w->reset();
    const Result<DesignFile> after = ReadDesignFile(path);
    bool same = appended.ok() && after.ok() && static_cast<int>(after->iterations.size()) == n + 1;
    for (int k = 0; same && k <= n; ++k) {
      const BesoIteration& it = after->iterations[k];
      same = it.iteration == k && it.positions.minCoeff() == k && it.positions.maxCoeff() == k &&
             it.energy_density_Pa.minCoeff() == k && it.energy_density_Pa.maxCoeff() == k;
    }
    if (!same) {
      ++failures;
      std::fprintf(stderr, "trial %d: after reopening with %d iterations: %s\n", t, n,
                   !appended.ok() ? appended.message().c_str() : !after.ok() ? after.message().c_str() : "rows differ");
    }
  }
  std::filesystem::remove(path);
  std::printf("%d kills: %d damaged committed iterations (what each kept is printed above; a resumed job recomputes the rest); "
              "%d failures\n", trials, damaged, failures);
  return failures == 0 ? 0 : 1;
}
