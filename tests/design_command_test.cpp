// `kgd design`, `kgd designs`, `kgd evaluate`, `kgd baselines` as a user runs them: the real binary,
// real HDF5 files. Determinism, stop-and-resume (by --iterations and by Ctrl-C) giving the designs of
// an uninterrupted run bit for bit, and bad parameters refused with a message naming them.
#include <gtest/gtest.h>

#include "tests/kgd_cli.h"
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/testing/bodies_test_scene.h"
#include "core/scene/scene_file.h"
#include "store/design_file.h"

namespace kgd {
namespace {

namespace fs = std::filesystem;

using ::kgd::cli_test::CommandRun;
using ::kgd::cli_test::Kgd;

class DesignCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / "kgd_design_command" / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

// A small, quick job: the pull test from all reinforced down to 60 %.
const std::string kJob = "design pull_test_all_cloth --budget 0.6 --er 0.05 --ar-max 0.05";

void ExpectSameDesigns(const DesignFile& a, const DesignFile& b) {
  ASSERT_EQ(a.iterations.size(), b.iterations.size());
  for (size_t k = 0; k < a.iterations.size(); ++k) {
    EXPECT_EQ(a.iterations[k].design, b.iterations[k].design) << "iteration " << k;
    EXPECT_TRUE(a.iterations[k].positions == b.iterations[k].positions) << "iteration " << k;
    EXPECT_EQ(a.iterations[k].energy_J, b.iterations[k].energy_J) << "iteration " << k;
    EXPECT_EQ(a.iterations[k].density_ratio, b.iterations[k].density_ratio) << "iteration " << k;
  }
}

TEST_F(DesignCommand, RunsDeterministicallyAndResumesBitForBit) {
  CommandRun r = Kgd(kJob + " --iterations 12 --out " + Path("a.h5"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // Not a terminal: JSON lines, one per iteration, then a summary.
  EXPECT_NE(r.output.find("{\"iteration\":12,"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"event\":\"done\""), std::string::npos) << r.output;
  ASSERT_EQ(Kgd(kJob + " --iterations 12 --out " + Path("b.h5")).exit_code, 0);
  // Stopped after iteration 4, then resumed to 12.
  ASSERT_EQ(Kgd(kJob + " --iterations 4 --out " + Path("c.h5")).exit_code, 0);
  Result<DesignFile> c4 = ReadDesignFile(Path("c.h5"), {.arrays = false});
  ASSERT_TRUE(c4.ok());
  EXPECT_EQ(c4->iterations.size(), 5u);
  r = Kgd("design --resume " + Path("c.h5") + " --iterations 12");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find("{\"iteration\":4,"), std::string::npos) << "resumed runs start after the last stored iteration";
  EXPECT_NE(r.output.find("{\"iteration\":5,"), std::string::npos) << r.output;
  // The file reads as the job now runs: ended at the resumed run's iteration limit.
  r = Kgd("designs " + Path("c.h5"));
  EXPECT_NE(r.output.find("iteration limit (12)"), std::string::npos) << r.output;

  const Result<DesignFile> a = ReadDesignFile(Path("a.h5")), b = ReadDesignFile(Path("b.h5")), c = ReadDesignFile(Path("c.h5"));
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  ASSERT_EQ(a->iterations.size(), 13u);
  ExpectSameDesigns(*a, *b);
  ExpectSameDesigns(*a, *c);
  // The designs lose area towards the budget and each is binary with the recorded area.
  const Eigen::VectorXd& area = a->header.rest_area_m2;
  for (const BesoIteration& it : a->iterations) {
    double reinforced = 0;
    for (size_t f = 0; f < it.design.size(); ++f) {
      ASSERT_TRUE(it.design[f] == 0 || it.design[f] == 1);
      reinforced += it.design[f] * area[f];
    }
    EXPECT_NEAR(reinforced / area.sum(), it.area_fraction, 1e-12);
  }
  EXPECT_LT(a->iterations.back().area_fraction, 0.65);

  // The history as a table and as JSON.
  r = Kgd("designs " + Path("a.h5"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("13 iterations"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("density_J/m2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("re-solves while shrinking at 20x the tolerance"), std::string::npos) << r.output;
  r = Kgd("designs --json " + Path("a.h5"));
  ASSERT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("\"scene\":\"pull_test_all_cloth\""), std::string::npos) << r.output;
}

// A job at another quality (its solves' tolerance) resumes at that quality, not at the scene's.
TEST_F(DesignCommand, AJobAtDraftQualityResumesAtDraft) {
  const std::string draft = kJob + " --quality draft";
  ASSERT_EQ(Kgd(draft + " --iterations 8 --out " + Path("d.h5")).exit_code, 0);
  ASSERT_EQ(Kgd(kJob + " --iterations 8 --out " + Path("s.h5")).exit_code, 0);
  ASSERT_EQ(Kgd(draft + " --iterations 3 --out " + Path("e.h5")).exit_code, 0);
  const CommandRun r = Kgd("design --resume " + Path("e.h5") + " --iterations 8");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Result<DesignFile> d = ReadDesignFile(Path("d.h5")), s = ReadDesignFile(Path("s.h5")), e = ReadDesignFile(Path("e.h5"));
  ASSERT_TRUE(d.ok() && s.ok() && e.ok());
  EXPECT_EQ(d->header.grad_tol, 1e-3);
  ExpectSameDesigns(*d, *e);
  // The quality matters to this job: at the scene's tolerance it runs otherwise.
  bool differ = false;
  for (size_t k = 0; !differ && k < d->iterations.size(); ++k) differ = d->iterations[k].energy_J != s->iterations[k].energy_J;
  EXPECT_TRUE(differ) << "draft and the scene's tolerance gave the same energies: the test cannot tell a resume at either apart";
  const CommandRun t = Kgd("designs " + Path("e.h5"));
  EXPECT_NE(t.output.find("solves to grad_tol 0.001"), std::string::npos) << t.output;
  // Another quality on a resume is refused, not ignored.
  const CommandRun q = Kgd("design --resume " + Path("e.h5") + " --iterations 9 --quality standard");
  EXPECT_EQ(q.exit_code, 2) << q.output;
  EXPECT_NE(q.output.find("its solves' quality too"), std::string::npos) << q.output;
}

// kgd under the environment of another machine: OpenBLAS told to use another CPU's kernels, glibc's
// libm without (or with) its FMA variants. `env` is prepended to the command.
CommandRun KgdOn(const std::string& env, const std::string& args) {
  FILE* p = popen(("env " + env + " " + KGD_BINARY + " " + args + " 2>&1").c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), out};
}

// A quick job whose solves go through OpenBLAS (CHOLMOD's supernodes) and libm on every iteration.
const std::string kCpuJob = "design sleeve_on_limb";

TEST_F(DesignCommand, AJobGivesTheSameDesignsBitForBitOnEveryCpuAndResumedOnAnother) {
  // Core types this CPU can run (forcing a core type the CPU lacks would fault).
  std::vector<std::string> cores = {"Prescott", "Nehalem"};
  if (__builtin_cpu_supports("avx")) cores.push_back("Sandybridge");
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) cores.push_back("Haswell");
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
      __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512cd"))
    cores.push_back("SkylakeX");
  const std::string native = cores.back();
  const std::string other = cores.size() > 2 ? cores[cores.size() - 2] : "Prescott";
  auto run = [&](const std::string& env, const std::string& args) {
    const CommandRun r = KgdOn(env, args);
    EXPECT_EQ(r.exit_code, 0) << env << " " << args << "\n" << r.output;
    return r;
  };
  // Each kernel level this machine runs (core/util/pinned_kernels.h), chosen with KGD_KERNELS.
  std::vector<std::string> levels = {"x86-64"};
  if (__builtin_cpu_supports("x86-64-v3")) levels.push_back("x86-64-v3");
  std::map<std::string, DesignFile> full;
  for (const std::string& level : levels) {
    SCOPED_TRACE(level);
    const std::string at = "KGD_KERNELS=" + level + " ";
    const std::string file = level + "_";
    run(at + "OPENBLAS_CORETYPE=" + native, kCpuJob + " --iterations 30 --out " + Path(file + "native.h5"));
    run(at + "OPENBLAS_CORETYPE=" + other + " GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2", kCpuJob + " --iterations 30 --out " + Path(file + "other.h5"));
    run(at + "OPENBLAS_CORETYPE=Prescott", kCpuJob + " --iterations 30 --out " + Path(file + "prescott.h5"));
    // Stopped after iteration 12 on one machine, resumed on another.
    run(at + "OPENBLAS_CORETYPE=" + native, kCpuJob + " --iterations 12 --out " + Path(file + "resumed.h5"));
    run(at + "OPENBLAS_CORETYPE=" + other + " GLIBC_TUNABLES=glibc.cpu.hwcaps=-FMA", "design --resume " + Path(file + "resumed.h5") + " --iterations 30");
    const Result<DesignFile> a = ReadDesignFile(Path(file + "native.h5")), b = ReadDesignFile(Path(file + "other.h5")),
                             c = ReadDesignFile(Path(file + "prescott.h5")), d = ReadDesignFile(Path(file + "resumed.h5"));
    ASSERT_TRUE(a.ok() && b.ok() && c.ok() && d.ok());
    ASSERT_EQ(a->iterations.size(), 31u);
    EXPECT_EQ(a->header.kernels, level);
    EXPECT_EQ(d->header.kernels, level);
    ExpectSameDesigns(*a, *b);
    ExpectSameDesigns(*a, *c);
    ExpectSameDesigns(*a, *d);
    full.emplace(level, *a);
  }
  // A level that is not one stops the program (a lab's typo must not give another level's designs);
  // KGD_NATIVE_KERNELS=0 keeps the pin.
  CommandRun bad = KgdOn("KGD_KERNELS=X86-64", "machine");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("KGD_KERNELS=X86-64 is not a kernel level"), std::string::npos) << bad.output;
  bad = run("KGD_NATIVE_KERNELS=0", "machine");
  EXPECT_NE(bad.output.find("kernels " + levels.back()), std::string::npos) << bad.output;
  if (levels.size() < 2) GTEST_SKIP() << "this CPU runs only the x86-64 level";

  // The levels are different kernels: the same job rounds differently.
  const DesignFile &base = full.at("x86-64"), &v3 = full.at("x86-64-v3");
  bool differ = false;
  for (size_t k = 0; !differ && k < base.iterations.size(); ++k) differ = base.iterations[k].energy_J != v3.iterations[k].energy_J;
  EXPECT_TRUE(differ) << "the x86-64 and x86-64-v3 pins gave identical results: the level pin does not change the kernels";

  // A job resumes at its own level: an x86-64 job continued on this x86-64-v3 machine runs the x86-64
  // kernels again and gives the x86-64 designs ...
  run("KGD_KERNELS=x86-64", kCpuJob + " --iterations 12 --out " + Path("down.h5"));
  CommandRun r = run("", "design --resume " + Path("down.h5") + " --iterations 30");
  EXPECT_NE(r.output.find("computed with the x86-64 kernels; resuming it with them"), std::string::npos) << r.output;
  const Result<DesignFile> down = ReadDesignFile(Path("down.h5"));
  ASSERT_TRUE(down.ok());
  ExpectSameDesigns(base, *down);
  // ... and an x86-64-v3 job is refused where only x86-64 may run, the file untouched.
  run("", kCpuJob + " --iterations 12 --out " + Path("up.h5"));
  r = KgdOn("KGD_KERNELS=x86-64", "design --resume " + Path("up.h5") + " --iterations 30");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("computed with the x86-64-v3 kernels, and KGD_KERNELS=x86-64 keeps this machine below the x86-64-v3 kernels: "
                          "resuming it here would not repeat them"),
            std::string::npos)
      << r.output;
  const Result<DesignFile> up = ReadDesignFile(Path("up.h5"), {.arrays = false});
  ASSERT_TRUE(up.ok());
  EXPECT_EQ(up->iterations.size(), 13u);
  // A stored design is simulated again (evaluate, baselines, export) at its level too: its scene
  // rebuilds as stored only there.
  r = run("", "evaluate " + Path("down.h5") + " --json");
  EXPECT_NE(r.output.find("simulating its designs with them"), std::string::npos) << r.output;
  r = KgdOn("KGD_KERNELS=x86-64", "evaluate " + Path("up.h5"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("computed with the x86-64-v3 kernels, and KGD_KERNELS=x86-64 keeps this machine below the x86-64-v3 kernels: "
                          "simulating its designs here would not repeat them"),
            std::string::npos)
      << r.output;

  // The variation is real: with the machine's own kernels (KGD_NATIVE_KERNELS), the same job rounds
  // differently under another CPU's kernels.
  run("KGD_NATIVE_KERNELS=1 OPENBLAS_CORETYPE=Haswell", kCpuJob + " --iterations 30 --out " + Path("free_haswell.h5"));
  run("KGD_NATIVE_KERNELS=1 OPENBLAS_CORETYPE=Prescott", kCpuJob + " --iterations 30 --out " + Path("free_prescott.h5"));
  const Result<DesignFile> e = ReadDesignFile(Path("free_haswell.h5")), f = ReadDesignFile(Path("free_prescott.h5"));
  ASSERT_TRUE(e.ok() && f.ok());
  EXPECT_EQ(e->header.kernels, "native");
  differ = e->iterations.size() != f->iterations.size();
  for (size_t k = 0; !differ && k < e->iterations.size(); ++k) differ = e->iterations[k].energy_J != f->iterations[k].energy_J;
  EXPECT_TRUE(differ) << "unpinned kernels gave identical results: the test's machines are not different enough";
}

TEST_F(DesignCommand, CtrlCStopsCleanlyAndTheRunResumes) {
  // Start a longer job, interrupt it once a few iterations are in, resume it to the end.
  const std::string cmd = std::string(KGD_BINARY) + " " + kJob + " --iterations 14 --out " + Path("i.h5");
  int out_pipe[2];
  ASSERT_EQ(pipe(out_pipe), 0);
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(out_pipe[1], 1);
    close(out_pipe[0]);
    execl("/bin/sh", "sh", "-c", ("exec " + cmd).c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  close(out_pipe[1]);
  FILE* out = fdopen(out_pipe[0], "r");
  char line[8192];
  int seen = 0;
  while (fgets(line, sizeof line, out))
    if (std::string(line).rfind("{\"iteration\":", 0) == 0 && ++seen == 3) {
      kill(pid, SIGINT);
      break;
    }
  while (fgets(line, sizeof line, out)) {
  }
  fclose(out);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);
  Result<DesignFile> stopped = ReadDesignFile(Path("i.h5"), {.arrays = false});
  ASSERT_TRUE(stopped.ok()) << stopped.message();
  EXPECT_GE(stopped->iterations.size(), 3u);
  EXPECT_LT(stopped->iterations.size(), 15u);
  ASSERT_EQ(Kgd("design --resume " + Path("i.h5")).exit_code, 0);
  ASSERT_EQ(Kgd(kJob + " --iterations 14 --out " + Path("u.h5")).exit_code, 0);
  const Result<DesignFile> resumed = ReadDesignFile(Path("i.h5")), straight = ReadDesignFile(Path("u.h5"));
  ASSERT_TRUE(resumed.ok() && straight.ok());
  ExpectSameDesigns(*resumed, *straight);
}

TEST_F(DesignCommand, BadParametersAreRefused) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--budget 0", "budget = 0"},          {"--budget 1.5", "budget = 1.5"}, {"--er 0", "evolutionary_ratio (ER) = 0"},
      {"--ar-max -0.1", "admission_ratio (AR_max) = -0.1"}, {"--penalty 0.5", "penalty (p) = 0.5"},
  };
  for (const auto& [args, needle] : cases) {
    const CommandRun r = Kgd("design pull_test_all_cloth " + args + " --out " + Path("bad.h5"));
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(needle), std::string::npos) << args << "\n" << r.output;
  }
  // NaN is how the flags mark "not given": a NaN given must be refused, not read as the scene's budget.
  for (const std::string args : {"--budget nan", "--tau inf"}) {
    const CommandRun r = Kgd("design pull_test_all_cloth " + args + " --out " + Path("bad.h5"));
    EXPECT_NE(r.exit_code, 0) << args << "\n" << r.output;
    EXPECT_NE(r.output.find("is not a finite number"), std::string::npos) << args << "\n" << r.output;
  }
  EXPECT_FALSE(fs::exists(Path("bad.h5"))) << "nothing is written for a refused job";
  CommandRun r = Kgd("design no_such_scene --out " + Path("x.h5"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // Refused before its first iteration: bad input (2), the reason named, no design file left behind.
  r = Kgd("design knee_flexion --symmetric --iterations 1 --out " + Path("sym.h5"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("the garment is not symmetric about the plane"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("iterations so far"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(Path("sym.h5"))) << "nothing is written for a job refused before its first iteration";
  // A design worn by the bodies of a scene of another garment (other faces): refused, both scenes named.
  r = Kgd("design pull_test_all_cloth --iterations 1 --out " + Path("pull.h5"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = Kgd("evaluate " + Path("pull.h5") + " --on knee_flexion");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("is not the garment of scene 'knee_flexion'"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("scene 'pull_test_all_cloth'"), std::string::npos) << r.output;
  std::ofstream(Path("text.h5")) << "not hdf5\n";
  r = Kgd("designs " + Path("text.h5"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("text.h5: not an HDF5 file"), std::string::npos) << r.output;
  r = Kgd("design --resume " + Path("text.h5"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("not an HDF5 file"), std::string::npos) << r.output;
}

// `kgd evaluate` of a design of several bodies gives each body's density ratio and the skin pressure
// the garment puts on it.
TEST_F(DesignCommand, EvaluateOnTheBodiesGivesEachBodysRatioAndSkinPressure) {
  Result<SceneSpec> scene = SleeveForBodies({{"M", 0.05, 1}, {"L", 0.055, 1}}, BodyObjective::kWorst);
  ASSERT_TRUE(scene.ok()) << scene.message();
  ASSERT_TRUE(ExportScene(*scene, Path("bodies")).ok());
  CommandRun r = Kgd("design " + Path("bodies/scene.json") + " --iterations 1 --budget 0.6 --er 0.05 --ar-max 0.05 --out " + Path("b.h5"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = Kgd("evaluate " + Path("b.h5") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output.substr(r.output.find('{')));
  ASSERT_EQ(j["bodies"].size(), 2u) << r.output;
  EXPECT_EQ(j["bodies"][0]["body"], "M");
  EXPECT_EQ(j["bodies"][1]["body"], "L");
  for (const auto& b : j["bodies"]) {
    EXPECT_GT(b["p95_pressure_Pa"].get<double>(), 0) << b;
    EXPECT_GE(b["peak_pressure_Pa"].get<double>(), b["p95_pressure_Pa"].get<double>()) << b;
  }
  r = Kgd("evaluate " + Path("b.h5"));
  EXPECT_NE(r.output.find("peak_kPa"), std::string::npos) << r.output;
}

// Resuming after the scene's mesh was edited is refused with the first difference named.
TEST_F(DesignCommand, ResumeNamesWhatChangedInTheScene) {
  CommandRun r = Kgd("scene export pull_test_all_cloth " + Path("scene"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = Kgd("design " + Path("scene/scene.json") + " --iterations 1 --budget 0.6 --er 0.05 --ar-max 0.05 --out " + Path("d.h5"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // Move rest vertex 7 (the eighth "v" line) by 1 mm.
  std::ifstream in(Path("scene/garment_rest.obj"));
  std::string text, line;
  for (int v = 0; std::getline(in, line);) {
    if (line.rfind("v ", 0) == 0 && v++ == 7) {
      double x, y, z;
      std::sscanf(line.c_str(), "v %lf %lf %lf", &x, &y, &z);
      line = "v " + std::to_string(x + 1e-3) + " " + std::to_string(y) + " " + std::to_string(z);
    }
    text += line + "\n";
  }
  in.close();
  std::ofstream(Path("scene/garment_rest.obj")) << text;
  r = Kgd("design --resume " + Path("d.h5") + " --iterations 3");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no longer gives the garment stored in the file (rest vertex 7 moved)"), std::string::npos)
      << r.output;
}

// A body that does not move gives the garment nothing to resist: the job stops after iteration 0,
// says why, exits 0, and the design file says so too.
TEST_F(DesignCommand, AMotionlessSceneStopsAtOnceAndSaysWhy) {
  CommandRun r = Kgd("scene export knee_flexion " + Path("scene"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json scene;
  std::ifstream(Path("scene/scene.json")) >> scene;
  scene["body"]["deformed"] = scene["body"]["rest"];
  scene["body"]["frames"] = {scene["body"]["rest"]};
  std::ofstream(Path("scene/scene.json")) << scene.dump(2);
  r = Kgd("design " + Path("scene/scene.json") + " --out " + Path("d.h5"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"end\":\"nothing to resist: the motion puts"), std::string::npos) << r.output;
  Result<DesignFile> f = ReadDesignFile(Path("d.h5"), {.arrays = false});
  ASSERT_TRUE(f.ok()) << f.message();
  EXPECT_EQ(f->iterations.size(), 1u);
  r = Kgd("designs " + Path("d.h5"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("finished: nothing to resist"), std::string::npos) << r.output;
}

// The done line's prediction and what the job took; `kgd design` learns the machine's factor from it.
nlohmann::json DoneLine(const std::string& output) {
  const size_t at = output.rfind("{\"event\":\"done\"");
  if (at == std::string::npos) return {};
  return nlohmann::json::parse(output.substr(at, output.find('\n', at) - at));
}

TEST_F(DesignCommand, AFinishedJobTunesThePredictionToThisMachine) {
  const fs::path cache = dir_ / "cache";
  setenv("KGD_CACHE_DIR", cache.c_str(), 1);
  CommandRun r = Kgd(kJob + " --iterations 12 --out " + Path("a.h5"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json first = DoneLine(r.output);
  ASSERT_TRUE(first.contains("predicted_s")) << r.output;
  EXPECT_EQ(first["machine_factor"], 1.0) << "nothing learned yet: the reference machine's prediction";
  EXPECT_EQ(first["machine_factor_jobs"], 0);
  nlohmann::json learned;
  std::ifstream(cache / "cost_calibration.json") >> learned;
  EXPECT_EQ(learned["jobs"], 1);
  const double factor = learned["factor"];
  EXPECT_GT(factor, 1.0 / 20);
  EXPECT_LT(factor, 20);
  // The next job's prediction is this machine's.
  r = Kgd(kJob + " --iterations 12 --out " + Path("b.h5"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json second = DoneLine(r.output);
  EXPECT_EQ(second["machine_factor"], factor);
  EXPECT_EQ(second["machine_factor_jobs"], 1);
  EXPECT_NEAR(second["predicted_s"].get<double>(), factor * first["predicted_s"].get<double>(), 1e-9 * first["predicted_s"].get<double>());
  r = Kgd("scenes");
  EXPECT_NE(r.output.find("learned from the design jobs run here: 2"), std::string::npos) << r.output;
  // A damaged file reads as nothing learned, and the next job writes a sound one.
  std::ofstream(cache / "cost_calibration.json") << "{\"factor\": \"fast\"";
  r = Kgd(kJob + " --iterations 12 --out " + Path("c.h5"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(DoneLine(r.output)["machine_factor"], 1.0);
  std::ifstream(cache / "cost_calibration.json") >> learned;
  EXPECT_EQ(learned["jobs"], 1);
  unsetenv("KGD_CACHE_DIR");
}

// `kgd scenes` lists each scene's motions with their roles and weights, the scene's own first, and
// whether its garment is mirror symmetric (the shirt's is, the one-arm sleeve's is not).
TEST_F(DesignCommand, ScenesListEachScenesMotionsAndSymmetry) {
  const CommandRun r = Kgd("scenes");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::map<std::string, std::string> line_of;
  std::istringstream lines(r.output);
  for (std::string line; std::getline(lines, line);) line_of[line.substr(0, line.find(' '))] = line;
  const size_t symmetric = line_of["name"].find("symmetric"), motions = line_of["name"].find("motions (role weight)");
  ASSERT_NE(symmetric, std::string::npos) << r.output;
  ASSERT_NE(motions, std::string::npos) << r.output;
  auto column = [&](const std::string& scene, size_t at, size_t size) {
    return line_of[scene].size() > at ? line_of[scene].substr(at, size) : "(no line for " + scene + ")";
  };
  EXPECT_EQ(column("arm_brace", symmetric, 3), "no ") << r.output;
  EXPECT_EQ(column("posture_shirt", symmetric, 3), "yes") << r.output;
  EXPECT_EQ(column("slouch", symmetric, 3), "yes") << r.output;
  EXPECT_EQ(column("knee_flexion", symmetric, 3), "no ") << r.output;
  EXPECT_EQ(column("arm_brace", motions, 39), "straighten (resist 1), bend (allow 15) ") << r.output;
  EXPECT_EQ(column("posture_shirt", motions, 43), "slouch (resist 1), reach_forward (allow 1) ") << r.output;
  EXPECT_EQ(column("knee_flexion", motions, 25), "knee_flexion (resist 1)  ") << r.output;
}

TEST_F(DesignCommand, EvaluateAndBaselinesReadTheFile) {
  ASSERT_EQ(Kgd(kJob + " --iterations 3 --out " + Path("e.h5")).exit_code, 0);
  // The pull test has no motion frames: evaluate simulates its one pose, beside the fully reinforced design.
  CommandRun r = Kgd("evaluate --json " + Path("e.h5"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"frames\":[{\"frame\":1"), std::string::npos) << r.output;
  r = Kgd("evaluate " + Path("e.h5") + " --iteration 7");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("iteration 7 is not stored"), std::string::npos) << r.output;
  // Its clamps are not attachment bands: baselines say why they cannot be drawn.
  r = Kgd("baselines " + Path("e.h5"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("this garment has 0"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace kgd
