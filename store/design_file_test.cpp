// The design file round-trips a BESO history bit for bit, resumes by truncation, and refuses files that
// are not design files with a message naming the file.
#include "store/design_file.h"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <csignal>
#include <sys/wait.h>
#include <unistd.h>

#include "core/scene/scene.h"
#include "core/scene/builtin_scenes.h"

namespace kgd {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("kgd_design_file_test_" + name)).string();
}

struct Fixture {
  SceneSpec scene;
  BesoSettings settings;
  DesignFileHeader header;
  std::vector<BesoIteration> run;
};

Fixture MakeRun(int iterations) {
  Fixture f;
  f.scene = *PullTestScene("all_cloth");
  f.settings.budget = 0.6;
  f.settings.evolutionary_ratio = 0.05;
  f.settings.admission_ratio = 0.05;
  f.settings.max_iterations = iterations;
  f.header.scene = "pull_test";
  f.header.body = "";
  f.header.settings = f.settings;
  f.header.garment = f.scene.garment;
  f.header.initial = f.scene.initial;
  f.header.rest_area_m2 = FaceAreas(f.scene.garment.vertices, f.scene.garment.faces);
  f.header.attachment_faces = {1, 2, 3};
  f.run = *RunBeso(f.scene, f.settings);
  return f;
}

void ExpectSame(const BesoIteration& a, const BesoIteration& b) {
  EXPECT_EQ(a.iteration, b.iteration);
  EXPECT_EQ(a.energy_J, b.energy_J);
  EXPECT_EQ(a.density_ratio, b.density_ratio);
  EXPECT_EQ(a.area_fraction, b.area_fraction);
  EXPECT_EQ(a.target_area_m2, b.target_area_m2);
  EXPECT_EQ(a.solver_iterations, b.solver_iterations);
  EXPECT_EQ(a.status, b.status);
  EXPECT_EQ(a.total_s, b.total_s);
  EXPECT_EQ(a.assembly_s, b.assembly_s);
  EXPECT_EQ(a.membrane_s, b.membrane_s);
  EXPECT_EQ(a.contact_s, b.contact_s);
  EXPECT_EQ(a.design, b.design);
  EXPECT_TRUE(a.positions == b.positions);
  EXPECT_TRUE(a.energy_density_Pa == b.energy_density_Pa);
  EXPECT_TRUE(a.sensitivity == b.sensitivity) << "iteration " << a.iteration;
}

TEST(DesignFile, RoundTripsAHistoryBitForBit) {
  const Fixture f = MakeRun(4);
  ASSERT_EQ(f.run.size(), 5u);
  const std::string path = TempPath("roundtrip.h5");
  // A body (any mesh) and the thicknesses travel with the header.
  DesignFileHeader header = f.header;
  header.body_mesh = f.scene.garment;
  header.body_mesh.vertices.array() += 0.01;
  header.cloth_thickness_m = 0.27e-3;
  header.reinforced_thickness_m = 0.5e-3;
  header.kernels = "x86-64-v3";
  header.grad_tol = 2e-3;
  header.max_newton_iterations = 50;
  {
    auto w = DesignFileWriter::Create(path, header);
    ASSERT_TRUE(w.ok()) << w.message();
    for (const BesoIteration& it : f.run) ASSERT_TRUE((*w)->Append(it).ok());
    // Out of order is refused.
    EXPECT_FALSE((*w)->Append(f.run[1]).ok());
  }
  const Result<DesignFile> d = ReadDesignFile(path);
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_EQ(d->header.scene, "pull_test");
  EXPECT_EQ(d->header.settings.budget, 0.6);
  EXPECT_EQ(d->header.settings.max_iterations, 4);
  EXPECT_TRUE(d->header.garment.vertices == f.scene.garment.vertices);
  EXPECT_TRUE(d->header.garment.faces == f.scene.garment.faces);
  EXPECT_TRUE(d->header.initial == f.scene.initial);
  EXPECT_EQ(d->header.attachment_faces, (std::vector<int>{1, 2, 3}));
  EXPECT_TRUE(d->header.body_mesh.vertices == header.body_mesh.vertices);
  EXPECT_TRUE(d->header.body_mesh.faces == header.body_mesh.faces);
  EXPECT_EQ(d->header.cloth_thickness_m, 0.27e-3);
  EXPECT_EQ(d->header.reinforced_thickness_m, 0.5e-3);
  EXPECT_EQ(d->header.kernels, "x86-64-v3");
  EXPECT_EQ(d->header.grad_tol, 2e-3);
  EXPECT_EQ(d->header.max_newton_iterations, 50);
  ASSERT_EQ(d->iterations.size(), f.run.size());
  for (size_t k = 0; k < f.run.size(); ++k) ExpectSame(d->iterations[k], f.run[k]);

  // Metrics only, and one iteration's arrays.
  const Result<DesignFile> m = ReadDesignFile(path, {.arrays = false});
  ASSERT_TRUE(m.ok());
  EXPECT_TRUE(m->iterations[3].design.empty());
  EXPECT_EQ(m->iterations[3].density_ratio, f.run[3].density_ratio);
  const Result<DesignFile> one = ReadDesignFile(path, {.arrays = true, .only_iteration = 2});
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->iterations[2].design, f.run[2].design);
  EXPECT_TRUE(one->iterations[1].design.empty());
  const Result<DesignFile> missing = ReadDesignFile(path, {.arrays = true, .only_iteration = 9});
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("iteration 9 is not stored"), std::string::npos) << missing.message();
  std::filesystem::remove(path);
}

// Per-motion records (docs/MODEL.md, "Motions with roles") round-trip with the header's motions, and
// survive a reopen; a file without them (from before motions) reads as one motion, the scene's, with
// the iteration's figures.
TEST(DesignFile, PerMotionRecordsRoundTripAndOldFilesReadAsOneMotion) {
  Fixture f = MakeRun(3);
  DesignFileHeader header = f.header;
  header.motions.resize(2);
  header.motions[0].name = "straighten";
  header.motions[1].name = "bend";
  header.motions[1].role = MotionRole::kAllow;
  header.motions[1].weight = 0.25;
  for (BesoIteration& it : f.run) {
    it.motions = header.motions;
    for (int m = 0; m < 2; ++m) {
      MotionMetrics& mm = it.motions[m];
      mm.energy_J = it.energy_J + m;
      mm.reinforced_energy_J = 0.1 * it.iteration + m + 1e-17;
      mm.reinforced_density_J_per_m2 = 3.0 / (it.iteration + 7) + m;
      mm.density_ratio = 1.0 / 3.0 + it.iteration + m;
      mm.simulation_s = 0.001 * (it.iteration + 1) * (m + 1);
      mm.solver_iterations = it.iteration + 10 * m;
    }
    // The other motion's equilibrium, where a resumed job warm-starts it; iteration 2 without it.
    if (it.iteration < 2) it.motion_positions = {1.5 * it.positions};
  }
  const std::string path = TempPath("motions.h5");
  {
    auto w = DesignFileWriter::Create(path, header);
    ASSERT_TRUE(w.ok()) << w.message();
    for (const BesoIteration& it : f.run) ASSERT_TRUE((*w)->Append(it).ok());
    BesoIteration one_motion = f.run[0];
    one_motion.iteration = static_cast<int>(f.run.size());
    one_motion.motions.resize(1);
    const Status refused = (*w)->Append(one_motion);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.message().find("1 motions, the file 2"), std::string::npos) << refused.message();
  }
  auto check = [&](const DesignFile& d, size_t n) {
    ASSERT_EQ(d.header.motions.size(), 2u);
    EXPECT_EQ(d.header.motions[1].name, "bend");
    EXPECT_EQ(d.header.motions[1].role, MotionRole::kAllow);
    EXPECT_EQ(d.header.motions[1].weight, 0.25);
    ASSERT_EQ(d.iterations.size(), n);
    for (size_t k = 0; k < n; ++k) EXPECT_EQ(d.iterations[k].motions, f.run[k].motions) << "iteration " << k;
  };
  Result<DesignFile> d = ReadDesignFile(path, {.arrays = false});
  ASSERT_TRUE(d.ok()) << d.message();
  check(*d, f.run.size());
  {
    auto w = DesignFileWriter::Reopen(path, 2);
    ASSERT_TRUE(w.ok()) << w.message();
    ASSERT_TRUE((*w)->Append(f.run[2]).ok());
  }
  d = ReadDesignFile(path);
  ASSERT_TRUE(d.ok()) << d.message();
  check(*d, 3);
  for (size_t k = 0; k < 3; ++k) {
    ASSERT_EQ(d->iterations[k].motion_positions.size(), f.run[k].motion_positions.size()) << "iteration " << k;
    if (k < 2) EXPECT_TRUE(d->iterations[k].motion_positions[0] == f.run[k].motion_positions[0]) << "iteration " << k;
  }
  {
    auto w = DesignFileWriter::Reopen(path, 3);
    ASSERT_TRUE(w.ok()) << w.message();
    BesoIteration wrong = f.run[0];
    wrong.iteration = 3;
    wrong.motion_positions = {wrong.positions, wrong.positions};
    const Status refused = (*w)->Append(wrong);
    EXPECT_NE(refused.message().find("the other motions' positions do not match"), std::string::npos) << refused.message();
  }

  // The same history in a file without motions.
  {
    auto w = DesignFileWriter::Create(path, f.header);
    ASSERT_TRUE(w.ok()) << w.message();
    for (const BesoIteration& it : f.run) ASSERT_TRUE((*w)->Append(it).ok());
  }
  d = ReadDesignFile(path, {.arrays = false});
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_TRUE(d->header.motions.empty());
  for (const BesoIteration& it : d->iterations) {
    ASSERT_EQ(it.motions.size(), 1u);
    EXPECT_EQ(it.motions[0].name, "pull_test");
    EXPECT_EQ(it.motions[0].role, MotionRole::kResist);
    EXPECT_EQ(it.motions[0].weight, 1.0);
    EXPECT_EQ(it.motions[0].reinforced_energy_J, it.reinforced_energy_J);
    EXPECT_EQ(it.motions[0].density_ratio, it.density_ratio);
  }
  std::filesystem::remove(path);
}

TEST(DesignFile, ReopenKeepsThePrefixAndResumedRunsMatchUninterruptedOnes) {
  const Fixture f = MakeRun(6);
  const std::string path = TempPath("resume.h5");
  {
    auto w = DesignFileWriter::Create(path, f.header);
    ASSERT_TRUE(w.ok());
    for (size_t k = 0; k < 5; ++k) ASSERT_TRUE((*w)->Append(f.run[k]).ok());
  }
  // Resume after iteration 2 (drop 3 and 4) from what the file holds.
  {
    auto w = DesignFileWriter::Reopen(path, 3);
    ASSERT_TRUE(w.ok()) << w.message();
    EXPECT_EQ((*w)->num_iterations(), 3);
  }
  const Result<DesignFile> stored = ReadDesignFile(path);
  ASSERT_TRUE(stored.ok());
  ASSERT_EQ(stored->iterations.size(), 3u);
  {
    auto w = DesignFileWriter::Reopen(path, 3);
    ASSERT_TRUE(w.ok()) << w.message();
    const Result<std::vector<BesoIteration>> rest = RunBeso(f.scene, f.settings, {}, &stored->iterations);
    ASSERT_TRUE(rest.ok()) << rest.message();
    for (const BesoIteration& it : *rest) ASSERT_TRUE((*w)->Append(it).ok());
  }
  const Result<DesignFile> d = ReadDesignFile(path);
  ASSERT_TRUE(d.ok());
  ASSERT_EQ(d->iterations.size(), f.run.size());
  for (size_t k = 0; k < f.run.size(); ++k) {
    EXPECT_EQ(d->iterations[k].design, f.run[k].design) << "iteration " << k;
    EXPECT_TRUE(d->iterations[k].positions == f.run[k].positions) << "iteration " << k;
    EXPECT_EQ(d->iterations[k].energy_J, f.run[k].energy_J) << "iteration " << k;
  }
  EXPECT_FALSE(DesignFileWriter::Reopen(path, 99).ok());
  std::filesystem::remove(path);
}

// A file written before the solve profile existed (no datasets for it) reads the profile as 0, and a
// resumed run adds the datasets: the old rows read 0, the new ones their values.
// A resume's new iteration limit replaces the stored settings; a writer killed between removing the
// old settings and renaming the new ones leaves a file that reads the new.
TEST(DesignFile, SetSettingsReplacesTheStoredSettingsAndAKilledReplacementReadsTheNew) {
  const Fixture f = MakeRun(2);
  const std::string path = TempPath("settings.h5");
  {
    auto w = DesignFileWriter::Create(path, f.header);
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE((*w)->Append(f.run[0]).ok());
    BesoSettings later = f.header.settings;
    later.max_iterations = 30;
    ASSERT_TRUE((*w)->SetSettings(later).ok());
    ASSERT_TRUE((*w)->Append(f.run[1]).ok());
  }
  Result<DesignFile> d = ReadDesignFile(path);
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_EQ(d->header.settings.max_iterations, 30);
  EXPECT_EQ(d->header.settings.budget, f.header.settings.budget);
  ASSERT_EQ(d->iterations.size(), 2u);
  {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    ASSERT_GE(H5Arename_by_name(file, "job", "settings", "settings_next", H5P_DEFAULT), 0);
    H5Fclose(file);
  }
  d = ReadDesignFile(path);
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_EQ(d->header.settings.max_iterations, 30);
  std::filesystem::remove(path);
}

// A file from before the kernel level was recorded ran the x86-64 pin (core/util/pinned_kernels.h).
TEST(DesignFile, AFileWithoutItsKernelLevelReadsX8664) {
  const Fixture f = MakeRun(1);
  const std::string path = TempPath("no_kernels.h5");
  DesignFileHeader header = f.header;
  header.kernels = "x86-64-v3";
  ASSERT_TRUE(DesignFileWriter::Create(path, header).ok());
  {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    ASSERT_GE(H5Adelete_by_name(file, "job", "kernels", H5P_DEFAULT), 0);
    H5Fclose(file);
  }
  const Result<DesignFile> d = ReadDesignFile(path);
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_EQ(d->header.kernels, "x86-64");
  std::filesystem::remove(path);
}

TEST(DesignFile, AFileWithoutTheSolveProfileReadsItAsZeroAndGainsItWhenResumed) {
  const Fixture f = MakeRun(4);
  ASSERT_GT(f.run[1].membrane_s, 0.0);
  const std::string path = TempPath("no_profile.h5");
  {
    auto w = DesignFileWriter::Create(path, f.header);
    ASSERT_TRUE(w.ok());
    for (size_t k = 0; k < 3; ++k) ASSERT_TRUE((*w)->Append(f.run[k]).ok());
  }
  {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
#define KGD_DROP_PROFILE_METRIC(type, name, what) ASSERT_GE(H5Ldelete(file, "/iterations/" #name, H5P_DEFAULT), 0);
    KGD_BESO_PROFILE_METRICS(KGD_DROP_PROFILE_METRIC)
#undef KGD_DROP_PROFILE_METRIC
    H5Fclose(file);
  }
  Result<DesignFile> old = ReadDesignFile(path);
  ASSERT_TRUE(old.ok()) << old.message();
  ASSERT_EQ(old->iterations.size(), 3u);
  EXPECT_EQ(old->iterations[1].membrane_s, 0.0);
  EXPECT_EQ(old->iterations[1].assembly_s, 0.0);
  EXPECT_EQ(old->iterations[1].energy_J, f.run[1].energy_J);
  {
    auto w = DesignFileWriter::Reopen(path, 3);
    ASSERT_TRUE(w.ok()) << w.message();
    ASSERT_TRUE((*w)->Append(f.run[3]).ok());
  }
  const Result<DesignFile> d = ReadDesignFile(path);
  ASSERT_TRUE(d.ok()) << d.message();
  ASSERT_EQ(d->iterations.size(), 4u);
  EXPECT_EQ(d->iterations[2].membrane_s, 0.0);
  EXPECT_EQ(d->iterations[3].membrane_s, f.run[3].membrane_s);
  EXPECT_EQ(d->iterations[3].factorization_s, f.run[3].factorization_s);
  std::filesystem::remove(path);
}

// Appends f.run's iterations (renumbered 0, 1, ...) to `path` in a child process: forever, or `count`
// of them and then waits. Returns the child's pid once the file exists.
pid_t StartWriter(const Fixture& f, const std::string& path, int count) {
  std::filesystem::remove(path + ".ready");
  const pid_t child = fork();
  if (child == 0) {
    auto w = DesignFileWriter::Create(path, f.header);
    if (!w.ok()) _exit(1);
    for (int k = 0; k < count; ++k) {
      BesoIteration it = f.run[k % f.run.size()];
      it.iteration = k;
      if (!(*w)->Append(it).ok()) _exit(2);
    }
    std::ofstream(path + ".ready") << "1";
    for (int k = count;; ++k) {
      if (count > 0) {
        pause();
        continue;
      }
      BesoIteration it = f.run[k % f.run.size()];
      it.iteration = k;
      if (!(*w)->Append(it).ok()) _exit(2);
    }
  }
  for (int waited = 0; child > 0 && !std::filesystem::exists(path + ".ready") && waited < 60000; ++waited) usleep(1000);
  std::filesystem::remove(path + ".ready");
  return child;
}

// Iterations 0..n-1 of `d` are f.run's, renumbered.
void ExpectRunPrefix(const Fixture& f, const DesignFile& d, int n) {
  ASSERT_EQ(static_cast<int>(d.iterations.size()), n);
  for (int k = 0; k < n; ++k) {
    BesoIteration expected = f.run[k % f.run.size()];
    expected.iteration = k;
    ExpectSame(d.iterations[k], expected);
  }
}

// A writer killed between iterations leaves its file marked "open for write" (SWMR); Reopen rebuilds
// it with every iteration, says so, and appends.
TEST(DesignFile, AKilledWritersFileIsRebuiltWithEveryIteration) {
  const Fixture f = MakeRun(3);
  const std::string path = TempPath("killed_idle.h5");
  const pid_t child = StartWriter(f, path, 5);
  ASSERT_GT(child, 0);
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the writer stopped by itself";
  auto w = DesignFileWriter::Reopen(path);
  ASSERT_TRUE(w.ok()) << w.message();
  EXPECT_EQ((*w)->num_iterations(), 5);
  EXPECT_EQ((*w)->repair_note(), "rebuilt after its writer was killed: kept 5 of 5 iterations");
  BesoIteration next = f.run[5 % f.run.size()];
  next.iteration = 5;
  ASSERT_TRUE((*w)->Append(next).ok());
  w->reset();
  const Result<DesignFile> d = ReadDesignFile(path);
  ASSERT_TRUE(d.ok()) << d.message();
  ExpectRunPrefix(f, *d, 6);
  EXPECT_FALSE(std::filesystem::exists(path + ".salvage"));
  // A file closed by its writer reopens in place, without a note.
  auto again = DesignFileWriter::Reopen(path, 4);
  ASSERT_TRUE(again.ok()) << again.message();
  EXPECT_EQ((*again)->num_iterations(), 4);
  EXPECT_TRUE((*again)->repair_note().empty());
  std::filesystem::remove(path);
}

// A writer that stops while it has the file open outside SWMR mode (a failed write while reopening,
// truncating or closing it) leaves the superblock marked "open for write" without the SWMR flag, which
// every reader refuses; Reopen clears the mark, rebuilds the file with every iteration and appends.
TEST(DesignFile, AFileLeftOpenForWriteOutsideSwmrIsRebuiltWithEveryIteration) {
  const Fixture f = MakeRun(3);
  const std::string path = TempPath("open_outside_swmr.h5");
  {
    auto w = DesignFileWriter::Create(path, f.header);
    ASSERT_TRUE(w.ok()) << w.message();
    for (int k = 0; k < 3; ++k) ASSERT_TRUE((*w)->Append(f.run[k]).ok());
  }
  const pid_t child = fork();
  if (child == 0) {
    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    H5Pset_libver_bounds(fapl, H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
    H5Pset_file_locking(fapl, false, true);
    _exit(H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl) >= 0 ? 0 : 1);  // exits with the file open
  }
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the child could not open the file";
  const Result<DesignFile> marked = ReadDesignFile(path);
  ASSERT_FALSE(marked.ok()) << "the file is not marked open for write: the test tests nothing";
  EXPECT_NE(marked.message().find("already open for write"), std::string::npos) << marked.message();
  auto w = DesignFileWriter::Reopen(path, 2);
  ASSERT_TRUE(w.ok()) << w.message();
  EXPECT_EQ((*w)->num_iterations(), 2);
  ASSERT_TRUE((*w)->Append(f.run[2]).ok());
  w->reset();
  const Result<DesignFile> d = ReadDesignFile(path);
  ASSERT_TRUE(d.ok()) << d.message();
  ExpectRunPrefix(f, *d, 3);
  std::filesystem::remove(path);
}

// SIGKILL at any moment of the append cycle. HDF5 1.10 is not crash-safe even in SWMR mode (about one
// kill in 150 damages committed rows: design_file.cpp, Salvage), so what holds is: reading never hangs,
// Reopen yields a file whose iterations are a prefix of what was written, bit for bit, and appending
// to it works.
TEST(DesignFile, AWriterKilledAtAnyMomentLeavesAFileThatReopensWithAnIntactPrefix) {
  const Fixture f = MakeRun(3);
  const std::string path = TempPath("killed.h5");
  for (int trial = 0; trial < 6; ++trial) {
    const pid_t child = StartWriter(f, path, 0);
    ASSERT_GT(child, 0);
    usleep(20000 + 37000 * trial);  // different moments of the append cycle
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the writer stopped by itself";

    auto w = DesignFileWriter::Reopen(path);
    ASSERT_TRUE(w.ok()) << "trial " << trial << ": " << w.message();
    const int n = (*w)->num_iterations();
    EXPECT_FALSE((*w)->repair_note().empty());
    BesoIteration next = f.run[n % f.run.size()];
    next.iteration = n;
    ASSERT_TRUE((*w)->Append(next).ok()) << "trial " << trial;
    w->reset();
    const Result<DesignFile> read = ReadDesignFile(path);
    ASSERT_TRUE(read.ok()) << "trial " << trial << ": " << read.message();
    ExpectRunPrefix(f, *read, n + 1);
  }
  std::filesystem::remove(path);
}

// A damaged chunk index (one byte of one extensible-array index block, as a disk error or a bad copy
// leaves it) must not send a resumed writer into HDF5's SWMR retries, which sleep for ever. Reopen
// finds the iterations that no longer read back whole, rebuilds the file from the ones before them,
// keeps the original as FILE.damaged, and the file takes appends again. Every index block is tried in
// turn; at least one must damage an iteration's arrays.
TEST(DesignFile, ADamagedFileIsRebuiltAndKeptInsteadOfHangingTheWriter) {
  const Fixture f = MakeRun(3);
  const std::string path = TempPath("damaged.h5");
  {
    auto w = DesignFileWriter::Create(path, f.header);
    ASSERT_TRUE(w.ok()) << w.message();
    for (size_t k = 0; k < 4; ++k) ASSERT_TRUE((*w)->Append(f.run[k]).ok());
  }
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  int damaging = 0;
  for (size_t at = bytes.find("EAIB"); at != std::string::npos; at = bytes.find("EAIB", at + 1)) {
    std::string damaged = bytes;
    damaged[at + 8] = static_cast<char>(damaged[at + 8] ^ 0x5a);
    std::ofstream(path, std::ios::binary | std::ios::trunc).write(damaged.data(), static_cast<std::streamsize>(damaged.size()));
    std::filesystem::remove(path + ".damaged");
    const bool reads_whole = ReadDesignFile(path, {.arrays = true}).ok();
    auto w = DesignFileWriter::Reopen(path);
    if (reads_whole) {
      ASSERT_TRUE(w.ok()) << w.message();
      EXPECT_TRUE((*w)->repair_note().empty()) << (*w)->repair_note();
      continue;
    }
    ++damaging;
    ASSERT_TRUE(w.ok()) << "index block at byte " << at << ": " << w.message();
    EXPECT_NE((*w)->repair_note().find("cannot be read (damaged)"), std::string::npos) << (*w)->repair_note();
    if ((*w)->repair_note().empty()) continue;  // appending to the damaged file would hang the test
    EXPECT_LT((*w)->num_iterations(), 4);
    BesoIteration next = f.run[(*w)->num_iterations()];
    ASSERT_TRUE((*w)->Append(next).ok());
    w->reset();
    const Result<DesignFile> d = ReadDesignFile(path);
    ASSERT_TRUE(d.ok()) << d.message();
    EXPECT_EQ(d->iterations.size(), static_cast<size_t>(next.iteration + 1));
    std::ifstream kept(path + ".damaged", std::ios::binary);
    const std::string kept_bytes((std::istreambuf_iterator<char>(kept)), {});
    EXPECT_EQ(kept_bytes, damaged) << "the damaged original is kept as it was";
  }
  EXPECT_GT(damaging, 0) << "no index block damaged an iteration: the test damages nothing";
  std::filesystem::remove(path);
  std::filesystem::remove(path + ".damaged");
}

// Flips one bit in the middle of the chunk of `dataset` that holds element `coord`.
void FlipABitInChunk(const std::string& path, const char* dataset, const std::vector<hsize_t>& coord) {
  haddr_t address = HADDR_UNDEF;
  hsize_t size = 0;
  {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    const hid_t set = H5Dopen2(file, dataset, H5P_DEFAULT);
    ASSERT_GE(set, 0) << dataset;
    unsigned filter_mask = 0;
    ASSERT_GE(H5Dget_chunk_info_by_coord(set, coord.data(), &filter_mask, &address, &size), 0) << dataset << " is not chunked";
    H5Dclose(set);
    H5Fclose(file);
  }
  ASSERT_NE(address, HADDR_UNDEF);
  ASSERT_GT(size, 100u);
  std::fstream io(path, std::ios::binary | std::ios::in | std::ios::out);
  io.seekg(static_cast<std::streamoff>(address + size / 2));
  char byte = 0;
  io.read(&byte, 1);
  byte = static_cast<char>(byte ^ 0x01);  // one bit of a mantissa
  io.seekp(static_cast<std::streamoff>(address + size / 2));
  io.write(&byte, 1);
}

// A flipped bit in raw data (HDF5 checksums only its metadata) is caught by the chunks' checksums instead
// of reading back as another number: an iteration's is damage that Reopen rebuilds the file without, the
// garment's makes the file unreadable.
TEST(DesignFile, AFlippedBitInRawDataIsDamageNotAnotherNumber) {
  const Fixture f = MakeRun(3);
  const std::string path = TempPath("raw_damaged.h5");
  auto write = [&] {
    std::filesystem::remove(path + ".damaged");
    auto w = DesignFileWriter::Create(path, f.header);
    ASSERT_TRUE(w.ok()) << w.message();
    for (size_t k = 0; k < 3; ++k) ASSERT_TRUE((*w)->Append(f.run[k]).ok());
  };
  write();
  FlipABitInChunk(path, "/iterations/positions", {1, 0, 0});
  const Result<DesignFile> d = ReadDesignFile(path, {.arrays = true});
  ASSERT_FALSE(d.ok()) << "a flipped bit in iteration 1's positions read back as another number";
  EXPECT_NE(d.message().find("iteration 1"), std::string::npos) << d.message();
  EXPECT_NE(d.message().find(path), std::string::npos) << d.message();
  auto w = DesignFileWriter::Reopen(path);
  ASSERT_TRUE(w.ok()) << w.message();
  EXPECT_NE((*w)->repair_note().find("iteration 1 cannot be read (damaged)"), std::string::npos) << (*w)->repair_note();
  EXPECT_EQ((*w)->num_iterations(), 1);
  ASSERT_TRUE((*w)->Append(f.run[1]).ok());
  w->reset();
  const Result<DesignFile> rebuilt = ReadDesignFile(path, {.arrays = true});
  ASSERT_TRUE(rebuilt.ok()) << rebuilt.message();
  ASSERT_EQ(rebuilt->iterations.size(), 2u);
  ExpectSame(rebuilt->iterations[1], f.run[1]);
  EXPECT_TRUE(std::filesystem::exists(path + ".damaged"));

  write();
  FlipABitInChunk(path, "/garment/rest_vertices", {0, 0});
  const Result<DesignFile> g = ReadDesignFile(path, {.arrays = false});
  ASSERT_FALSE(g.ok()) << "a flipped bit in the garment's rest shape read back as another number";
  EXPECT_NE(g.message().find("cannot read /garment"), std::string::npos) << g.message();
  std::filesystem::remove(path);
  std::filesystem::remove(path + ".damaged");
}

TEST(DesignFile, RefusesFilesThatAreNotDesignFiles) {
  const std::string text = TempPath("text.h5");
  std::ofstream(text) << "hello\n";
  Result<DesignFile> d = ReadDesignFile(text);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.message().find(text), std::string::npos);
  EXPECT_NE(d.message().find("not an HDF5 file"), std::string::npos) << d.message();
  d = ReadDesignFile(TempPath("does_not_exist.h5"));
  ASSERT_FALSE(d.ok());
  EXPECT_FALSE(DesignFileWriter::Create("/nonexistent-folder/x.h5", MakeRun(1).header).ok());
  std::filesystem::remove(text);
}

// Every solver status survives the file; a number that is none (a damaged or foreign file) is refused
// with the row named instead of becoming an enum value nobody handles.
TEST(DesignFile, StatusesRoundTripAndUnknownOnesAreRefused) {
  const Fixture f = MakeRun(1);
  const std::string path = TempPath("status.h5");
  auto write = [&](SolveStatus second) {
    auto w = DesignFileWriter::Create(path, f.header);
    ASSERT_TRUE(w.ok()) << w.message();
    ASSERT_TRUE((*w)->Append(f.run[0]).ok());
    BesoIteration it = f.run[1];
    it.status = second;
    ASSERT_TRUE((*w)->Append(it).ok());
  };
  write(SolveStatus::kStalled);
  Result<DesignFile> d = ReadDesignFile(path, {.arrays = false});
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_EQ(d->iterations[1].status, SolveStatus::kStalled);
  write(static_cast<SolveStatus>(42));
  d = ReadDesignFile(path, {.arrays = false});
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.message().find("/iterations/status row 1 holds 42"), std::string::npos) << d.message();
  EXPECT_NE(d.message().find(path), std::string::npos) << d.message();
  std::filesystem::remove(path);
}

TEST(DesignFile, SettingsJsonRoundTripsAndRejectsBadValues) {
  BesoSettings s;
  s.budget = 0.2;
  s.keep_attachments = true;
  s.max_iterations = 17;
  const Result<BesoSettings> back = BesoSettingsFromJson(BesoSettingsToJson(s));
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->budget, 0.2);
  EXPECT_TRUE(back->keep_attachments);
  EXPECT_EQ(back->max_iterations, 17);
  EXPECT_EQ(back->resolve_tolerance_factor, BesoSettings{}.resolve_tolerance_factor);
  s.resolve_tolerance_factor = 3;
  EXPECT_EQ(BesoSettingsFromJson(BesoSettingsToJson(s))->resolve_tolerance_factor, 3.0);
  // A file written before the factor existed ran every re-solve at the tolerance: it resumes so.
  const Result<BesoSettings> old = BesoSettingsFromJson("{\"budget\": 0.2}");
  ASSERT_TRUE(old.ok()) << old.message();
  EXPECT_EQ(old->resolve_tolerance_factor, 1.0);
  EXPECT_NE(BesoSettings{}.resolve_tolerance_factor, 1.0);
  EXPECT_FALSE(BesoSettingsFromJson("{\"resolve_tolerance_factor\": 0.5}").ok());
  EXPECT_FALSE(BesoSettingsFromJson("{\"budget\": 2}").ok());
  EXPECT_FALSE(BesoSettingsFromJson("{\"bugdet\": 0.2}").ok());
  EXPECT_FALSE(BesoSettingsFromJson("[1,2]").ok());
}

}  // namespace
}  // namespace kgd
