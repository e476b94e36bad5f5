// A design job on `kgd serve` (server and in-process worker, real SQLite and HDF5) killed with SIGKILL at
// each place where an iteration is stored or reported (the fault points, core/util/fault_point.h), for
// every iteration in turn, then restarted on the same data folder: the finished job's design file must
// equal the uninterrupted run's, every iteration's figures and arrays bit for bit, and the job store
// must hold the same iterations.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <map>
#include <sstream>
#include <string_view>
#include <thread>

#include "core/util/fault_point.h"
#include "kgd/v1/kgd.grpc.pb.h"
#include "store/design_file.h"
#include "tests/child_process.h"
#include "tests/job_client.h"

namespace kgd {
namespace {
namespace fs = std::filesystem;
using test_support::FreePort;
using test_support::JobClient;
using test_support::Process;
using test_support::WaitFor;
using test_support::ReadText;

// The kgd under test: the build's, or $KGD_TEST_BINARY (a copy kept apart from a build dir others rebuild).
std::string KgdBinary() {
  const char* b = std::getenv("KGD_TEST_BINARY");
  return b && *b ? b : KGD_BINARY;
}

// Figures (double, int) and Eigen arrays, compared by their bits.
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool SameBits(int a, int b) { return a == b; }
template <typename Derived>
bool SameBits(const Eigen::PlainObjectBase<Derived>& a, const Eigen::PlainObjectBase<Derived>& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && std::memcmp(a.data(), b.data(), sizeof(*a.data()) * a.size()) == 0;
}

std::string Exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// The first way `got` differs from `want` (every figure but the times, every array, bit for bit), or "".
std::string FirstDifference(const DesignFile& want, const DesignFile& got) {
  if (got.iterations.size() != want.iterations.size())
    return std::to_string(got.iterations.size()) + " iterations, the uninterrupted run " + std::to_string(want.iterations.size());
  for (size_t k = 0; k < want.iterations.size(); ++k) {
    const BesoIteration &a = want.iterations[k], &b = got.iterations[k];
    const std::string at = "iteration " + std::to_string(k) + ": ";
    if (b.iteration != a.iteration) return at + "numbered " + std::to_string(b.iteration);
    if (b.status != a.status) return at + "solve status differs";
#define KGD_COMPARE_METRIC(type, name, what)                                                                         \
  if (!std::string_view(#name).ends_with("_s") && !SameBits(a.name, b.name))                                        \
    return at + #name + " " + Exact(static_cast<double>(b.name)) + ", the uninterrupted run " + Exact(static_cast<double>(a.name));
    KGD_BESO_METRICS(KGD_COMPARE_METRIC)
#undef KGD_COMPARE_METRIC
    if (b.design != a.design) return at + "design differs";
    if (!SameBits(a.positions, b.positions)) return at + "positions differ";
    if (!SameBits(a.energy_density_Pa, b.energy_density_Pa)) return at + "energy densities differ";
    if (!SameBits(a.sensitivity, b.sensitivity)) return at + "sensitivities differ";
    if (b.motions.size() != a.motions.size()) return at + "motion count differs";
    for (size_t m = 0; m < a.motions.size(); ++m) {
      const MotionMetrics &x = a.motions[m], &y = b.motions[m];
      if (!SameBits(x.energy_J, y.energy_J) || !SameBits(x.reinforced_energy_J, y.reinforced_energy_J) ||
          !SameBits(x.density_ratio, y.density_ratio) || x.solver_iterations != y.solver_iterations)
        return at + "motion " + x.name + "'s figures differ";
    }
    if (b.motion_positions.size() != a.motion_positions.size()) return at + "other motions' positions differ in count";
    for (size_t m = 0; m < a.motion_positions.size(); ++m)
      if (!SameBits(a.motion_positions[m], b.motion_positions[m])) return at + "motion " + std::to_string(m + 1) + "'s positions differ";
  }
  return "";
}

// `kgd serve` on one data folder, started again after each death; a fault point armed per start.
class Serve {
 public:
  explicit Serve(const std::string& dir, const std::string& cache_dir) : dir_(dir), cache_dir_(cache_dir) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    address_ = "127.0.0.1:" + std::to_string(FreePort());
    client_ = std::make_unique<JobClient>(address_, /*reconnect_backoff_ms=*/200);
  }
  ~Serve() {
    if (process_.pid > 0) Stop();
  }

  // Starts `kgd serve`, with KGD_FAULT_POINT=`fault` unless empty; the log of this start is
  // log(starts() - 1). False (with the log) when it does not listen within a minute, or dies before
  // it listens unarmed (armed, a point passed while it starts may kill it: WaitForDeath tells).
  ::testing::AssertionResult Start(const std::string& fault = "") {
    const std::string log = Log(starts_++);
    std::vector<std::string> args = {"/usr/bin/env", "KGD_CACHE_DIR=" + cache_dir_};
    if (!fault.empty()) args.push_back("KGD_FAULT_POINT=" + fault);
    args.push_back(KgdBinary());
    for (const char* a : {"serve", "--no-http", "--workers", "1", "--lease-s", "5"}) args.push_back(a);
    for (const std::string& a : {std::string("--data"), dir_ + "/data", std::string("--listen"), address_}) args.push_back(a);
    process_ = Process::Spawn(args, log);
    bool died = false;
    if (WaitFor([&] {
          if (ReadText(log).find("listening on") != std::string::npos) return true;
          int status = 0;
          died = waitpid(process_.pid, &status, WNOHANG) == process_.pid;
          if (died) process_.pid = -1, status_ = status;
          return died;
        }, 60) && (!died || !fault.empty()))
      return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << (died ? "kgd serve died before listening" : "kgd serve is not listening") << ":\n" << ReadText(log);
  }
  // Waits (up to `timeout_s`) for the process to die; its wait status, or -1 when it lives on.
  int WaitForDeath(double timeout_s) {
    int status = -1;
    const bool dead = WaitFor([&] {
      if (process_.pid <= 0) return true;
      int s = 0;
      if (waitpid(process_.pid, &s, WNOHANG) != process_.pid) return false;
      process_.pid = -1;
      status_ = s;
      return true;
    }, timeout_s);
    if (dead) status = status_;
    return status;
  }
  int Stop() {
    process_.Signal(SIGTERM);
    return process_.Wait();
  }

  int64_t Create(const v1::JobSpec& spec, std::string* error) {
    v1::Job job;
    const grpc::Status st = client_->Create(spec, &job);
    if (!st.ok()) *error = st.error_message();
    return st.ok() ? job.id() : 0;
  }
  v1::Job Get(int64_t id) { return client_->Get(id); }
  bool Finished(int64_t id) { return client_->Finished(id); }
  // The job store's iterations (metrics and design), replayed by a watch of the ended job.
  std::vector<v1::IterationRecord> Stored(int64_t id, grpc::Status* status) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    v1::WatchJobRequest req;
    req.set_id(id);
    auto reader = client_->stub().WatchJob(&ctx, req);
    std::vector<v1::IterationRecord> out;
    for (v1::WatchJobEvent ev; reader->Read(&ev);)
      if (ev.has_iteration()) out.push_back(ev.iteration());
    *status = reader->Finish();
    return out;
  }

  std::string DataFile(int64_t id) const { return dir_ + "/data/jobs/job-" + std::to_string(id) + ".h5"; }
  std::string Log(int start) const { return dir_ + "/serve" + std::to_string(start) + ".log"; }
  int starts() const { return starts_; }
  std::string Logs() const {
    std::string all;
    for (int i = 0; i < starts_; ++i) all += "--- start " + std::to_string(i) + "\n" + ReadText(Log(i));
    return all;
  }

 private:
  std::string dir_, cache_dir_, address_;
  Process process_;
  int status_ = 0, starts_ = 0;
  std::unique_ptr<JobClient> client_;
};

struct Job {
  std::string scene;
  int iterations = 0;  // 0: the default limit
  double budget = 0;   // 0: the scene's
  v1::JobSpec Spec() const {
    v1::JobSpec spec;
    spec.set_builtin_scene(scene);
    if (iterations > 0) spec.mutable_optimizer()->set_max_iterations(iterations);
    if (budget > 0) spec.mutable_optimizer()->set_budget(budget);
    return spec;
  }
};

// A kill: KGD_FAULT_POINT for one start of `kgd serve`.
struct Kill {
  std::string point;
  int iteration = -1;  // -1: the point's first hit
  std::string Env() const { return iteration >= 0 ? point + "@iteration=" + std::to_string(iteration) : point; }
};

// Every fault point an iteration passes while it is computed, reported and stored.
std::vector<std::string> IterationPoints() {
  std::vector<std::string> out;
  for (const std::string& p : FaultPointNames())
    if (p.rfind("open_job_file.", 0) != 0 && p.rfind("repair.", 0) != 0) out.push_back(p);
  return out;
}

std::string TestDir(const std::string& name) { return (fs::temp_directory_path() / ("kgd_resume_fault_" + std::to_string(getpid()) + "_" + name)).string(); }

// A cache folder of the test's own with this machine's speed already known: each start of `kgd serve`
// then skips its worker's speed measurement (a design job of its own).
std::string CacheDir() {
  static const std::string dir = [] {
    const std::string d = TestDir("cache");
    fs::create_directories(d);
    std::ofstream(d + "/cost_calibration.json") << R"({"factor": 1.0, "jobs": 1, "weight_s": 1.0})" << "\n";
    return d;
  }();
  return dir;
}

// Removes the cache folder when the tests end.
class RemoveCacheDir : public ::testing::Environment {
 public:
  void TearDown() override { fs::remove_all(TestDir("cache")); }
};
const auto* const kRemoveCacheDir = ::testing::AddGlobalTestEnvironment(new RemoveCacheDir);

// Runs `job` on a fresh data folder, `kills` one after another (each start armed with the next; each
// must kill the process at its point), then once more unarmed to the end. Returns the finished design
// file, or a failure naming the kill schedule and the logs.
::testing::AssertionResult RunKilled(const Job& job, const std::vector<Kill>& kills, const std::string& name, DesignFile* out) {
  std::string schedule;
  for (const Kill& k : kills) schedule += (schedule.empty() ? "" : ", ") + k.Env();
  if (schedule.empty()) schedule = "none";
  Serve serve(TestDir(name), CacheDir());
  int64_t id = 0;
  for (size_t i = 0; i <= kills.size(); ++i) {
    const bool armed = i < kills.size();
    if (::testing::AssertionResult started = serve.Start(armed ? kills[i].Env() : ""); !started)
      return ::testing::AssertionFailure() << "kills " << schedule << ": start " << i << ": " << started.message();
    if (id == 0) {  // the first start is never killed before it listens: no startup point has a job to pass
      std::string error;
      id = serve.Create(job.Spec(), &error);
      if (id == 0) return ::testing::AssertionFailure() << "the job was not created: " << error;
    }
    if (armed) {
      const int status = serve.WaitForDeath(600);
      const std::string log = ReadText(serve.Log(i));
      if (status == -1 || !WIFSIGNALED(status) || WTERMSIG(status) != SIGKILL ||
          log.find("kgd: fault point " + kills[i].point + " ") == std::string::npos)
        return ::testing::AssertionFailure() << "kills " << schedule << ": start " << i << " was not killed at " << kills[i].Env()
                                             << (status == -1 ? " (still running)" : "") << ":\n" << serve.Logs();
      continue;
    }
    if (!WaitFor([&] { return serve.Finished(id); }, 3600))
      return ::testing::AssertionFailure() << "kills " << schedule << ": the job did not finish:\n" << serve.Logs();
  }
  const v1::Job ended = serve.Get(id);
  if (ended.state() != v1::SUCCEEDED)
    return ::testing::AssertionFailure() << "kills " << schedule << ": the job ended " << v1::JobState_Name(ended.state()) << " ("
                                         << ended.failure() << "):\n" << serve.Logs();
  grpc::Status watched;
  const std::vector<v1::IterationRecord> stored = serve.Stored(id, &watched);
  const int stopped = serve.Stop();
  if (!watched.ok()) return ::testing::AssertionFailure() << "kills " << schedule << ": the watch failed: " << watched.error_message();
  if (!WIFEXITED(stopped) || WEXITSTATUS(stopped) != 0)
    return ::testing::AssertionFailure() << "kills " << schedule << ": kgd serve did not stop cleanly:\n" << serve.Logs();
  Result<DesignFile> f = ReadDesignFile(serve.DataFile(id));
  if (!f.ok()) return ::testing::AssertionFailure() << "kills " << schedule << ": " << f.message();
  // The job store holds what the design file holds.
  if (stored.size() != f->iterations.size() || ended.iterations() != static_cast<int>(f->iterations.size()))
    return ::testing::AssertionFailure() << "kills " << schedule << ": the job store holds " << stored.size() << " iterations (job: "
                                         << ended.iterations() << "), the design file " << f->iterations.size();
  for (size_t k = 0; k < stored.size(); ++k) {
    const BesoIteration& it = f->iterations[k];
    if (stored[k].metrics().iteration() != static_cast<int>(k) || !SameBits(stored[k].metrics().energy_j(), it.energy_J) ||
        stored[k].design() != std::string(it.design.begin(), it.design.end()))
      return ::testing::AssertionFailure() << "kills " << schedule << ": the job store's iteration " << k << " is not the design file's";
  }
  *out = std::move(f).value();
  fs::remove_all(TestDir(name));
  return ::testing::AssertionSuccess();
}

const Job kSleeve{"sleeve_on_limb", 4, 0.5};

const DesignFile& Uninterrupted(const Job& job) {
  static std::map<std::string, DesignFile> runs;
  const std::string key = job.scene + "/" + std::to_string(job.iterations);
  if (!runs.count(key)) {
    DesignFile f;
    EXPECT_TRUE(RunKilled(job, {}, "uninterrupted", &f));
    runs[key] = std::move(f);
  }
  return runs[key];
}

// Every fault point, after every iteration in turn: for each point one job, killed there in iteration 0,
// restarted and killed there again in iteration 1, and so on to the last, then run to its end. Each
// restart resumes from what the kill before it left stored.
TEST(ResumeFault, AJobKilledAtEachFaultPointAfterEveryIterationFinishesAsTheUninterruptedRun) {
  const DesignFile& want = Uninterrupted(kSleeve);
  ASSERT_EQ(static_cast<int>(want.iterations.size()), kSleeve.iterations + 1) << "the job runs to its iteration limit";
  // Two jobs at a time, each on its own `kgd serve` (one core each).
  const std::vector<std::string> points = IterationPoints();
  for (size_t p = 0; p < points.size(); p += 2) {
    std::vector<std::future<std::pair<::testing::AssertionResult, std::string>>> runs;
    for (size_t q = p; q < std::min(p + 2, points.size()); ++q)
      runs.push_back(std::async(std::launch::async, [&, q] {
        std::vector<Kill> kills;
        for (int k = 0; k <= kSleeve.iterations; ++k) kills.push_back({points[q], k});
        DesignFile got;
        ::testing::AssertionResult ran = RunKilled(kSleeve, kills, "every_iteration_" + points[q], &got);
        return std::make_pair(ran, ran ? FirstDifference(want, got) : std::string());
      }));
    for (size_t i = 0; i < runs.size(); ++i) {
      const auto [ran, difference] = runs[i].get();
      EXPECT_TRUE(ran);
      EXPECT_EQ(difference, "") << "killed at " << points[p + i] << " in every iteration";
    }
  }
}

// Kills while the service starts: opening the job's design file, and repairing a file whose iteration
// the job store had not acknowledged (then killed again after the repair's rebuild, before the trim).
TEST(ResumeFault, KillsWhileTheServiceOpensAndRepairsTheFileLoseNothing) {
  const DesignFile& want = Uninterrupted(kSleeve);
  const std::vector<std::vector<Kill>> schedules = {
      {{"open_job_file.after_open", 0}},
      {{"commit.after_hdf5", 2}, {"open_job_file.after_open", 2}},
      {{"commit.after_hdf5", 3}, {"repair.after_reopen", -1}},
      {{"design_file.append.after_marker", 3}, {"repair.after_reopen", -1}, {"commit.after_hdf5", 4}},
  };
  for (const std::vector<Kill>& kills : schedules) {
    DesignFile got;
    ASSERT_TRUE(RunKilled(kSleeve, kills, "startup", &got));
    EXPECT_EQ(FirstDifference(want, got), "") << "killed at " << kills.front().Env() << " then " << kills.back().Env();
  }
}

// The long version: arm_flexion killed after every iteration in turn, in one job that is killed again
// after each restart, the fault point going round the list.
TEST(ResumeFaultLong, ArmFlexionKilledAfterEveryIterationFinishesAsTheUninterruptedRun) {
  const Job arm{"arm_flexion", 0, 0};
  const DesignFile& want = Uninterrupted(arm);
  ASSERT_GT(want.iterations.size(), 2u);
  const std::vector<std::string> points = IterationPoints();
  std::vector<Kill> kills;
  for (int k = 0; k + 1 < static_cast<int>(want.iterations.size()); ++k) kills.push_back({points[k % points.size()], k});
  DesignFile got;
  ASSERT_TRUE(RunKilled(arm, kills, "arm_every_iteration", &got));
  EXPECT_EQ(FirstDifference(want, got), "");
}

}  // namespace
}  // namespace kgd
