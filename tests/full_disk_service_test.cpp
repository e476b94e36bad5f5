// A full disk under the design service, for real: `kgd serve` on a small tmpfs (mounting needs root;
// skipped otherwise), a job running, the disk filled to the last byte, then freed. The job must wait
// paused with the reason where users look (kgd job, the HTTP job, the watch stream), the readiness
// route must say not ready while liveness stays fine, new jobs must be refused with the reason, and
// once space returns the job must continue by itself and end with the design an uninterrupted local
// `kgd design` gives, bit for bit.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <thread>
#include <vector>

#include "kgd/v1/kgd.grpc.pb.h"
#include "store/design_file.h"
#include "tests/child_process.h"
// After Eigen (through store/): a macro of the HTTP library's system headers breaks Eigen's templates.
#include <httplib.h>
#include "tests/kgd_cli.h"

namespace kgd {
namespace {
namespace fs = std::filesystem;
using cli_test::Kgd;
using test_support::FreePort;
using test_support::Process;
using test_support::WaitFor;
using test_support::ReadText;

// Writes `path` until the file system holds no more: 1 MiB blocks, then 4 KiB ones.
void FillDisk(const std::string& path) {
  FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr) << path;
  std::setvbuf(f, nullptr, _IONBF, 0);
  const std::vector<char> block(1 << 20, 'x');
  while (std::fwrite(block.data(), 1, block.size(), f) == block.size()) {
  }
  while (std::fwrite(block.data(), 1, 4096, f) == 4096) {
  }
  std::fclose(f);
}

TEST(FullDiskService, AJobPausesWithItsReasonAndContinuesBitForBitWhenSpaceReturns) {
  if (geteuid() != 0) GTEST_SKIP() << "mounting a small tmpfs needs root";
  const std::string dir = (fs::temp_directory_path() / ("kgd_full_disk_test_" + std::to_string(getpid()))).string();
  const std::string disk = dir + "/disk", data = disk + "/data";
  fs::remove_all(dir);
  fs::create_directories(disk);
  if (std::system(("mount -t tmpfs -o size=24m kgd-full-disk-test " + disk).c_str()) != 0)
    GTEST_SKIP() << "cannot mount a tmpfs at " << disk << " (mount -t tmpfs failed)";
  struct Unmount {
    std::string dir, disk;
    ~Unmount() {
      std::system(("umount " + disk).c_str());
      fs::remove_all(dir);
    }
  } unmount{dir, disk};

  const int iterations = 40;
  const double budget = 0.15;
  const std::string address = "127.0.0.1:" + std::to_string(FreePort());
  const int http_port = FreePort();
  Process serve = Process::Spawn({KGD_BINARY, "serve", "--data", data, "--listen", address, "--http", "127.0.0.1:" + std::to_string(http_port),
                                  "--lease-s", "3"},
                                 dir + "/serve.log");
  const std::string log_path = dir + "/serve.log";
  ASSERT_TRUE(WaitFor([&] { return ReadText(log_path).find("listening on") != std::string::npos; }, 60)) << ReadText(log_path);
  auto channel = grpc::CreateChannel(address, grpc::InsecureChannelCredentials());
  auto stub = v1::DesignService::NewStub(channel);
  httplib::Client http("127.0.0.1", http_port);
  auto get_job = [&](int64_t id) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::GetJobRequest req;
    req.set_id(id);
    v1::Job job;
    const grpc::Status st = stub->GetJob(&ctx, req, &job);
    EXPECT_TRUE(st.ok()) << st.error_message();
    return job;
  };
  v1::JobSpec spec;
  spec.set_builtin_scene("sleeve_on_limb");
  spec.mutable_optimizer()->set_max_iterations(iterations);
  spec.mutable_optimizer()->set_budget(budget);

  auto ready = http.Get("/readyz");
  ASSERT_TRUE(ready);
  EXPECT_EQ(ready->status, 200) << ready->body;

  v1::Job job;
  {
    grpc::ClientContext ctx;
    v1::CreateJobRequest req;
    *req.mutable_spec() = spec;
    const grpc::Status st = stub->CreateJob(&ctx, req, &job);
    ASSERT_TRUE(st.ok()) << st.error_message();
  }
  const int64_t id = job.id();
  // A watcher from the start: it must hear of the pause and end with the job, every iteration once.
  std::vector<v1::Job> snapshots;
  std::vector<int> watched;
  grpc::Status watch_status;
  std::thread watcher([&] {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(180));
    v1::WatchJobRequest req;
    req.set_id(id);
    auto reader = stub->WatchJob(&ctx, req);
    v1::WatchJobEvent ev;
    while (reader->Read(&ev)) {
      if (ev.has_job()) snapshots.push_back(ev.job());
      if (ev.has_iteration()) watched.push_back(ev.iteration().metrics().iteration());
    }
    watch_status = reader->Finish();
  });
  struct Join {
    std::thread& t;
    ~Join() {
      if (t.joinable()) t.join();
    }
  } join{watcher};

  ASSERT_TRUE(WaitFor([&] { return get_job(id).iterations() >= 3; }, 60)) << ReadText(log_path);
  FillDisk(disk + "/filler");
  ASSERT_TRUE(WaitFor([&] { return !get_job(id).paused().empty(); }, 30)) << "the job never reads paused:\n" << ReadText(log_path);

  // Paused, with the reason, wherever users look.
  job = get_job(id);
  EXPECT_EQ(job.state(), v1::RUNNING);
  const std::string reason = "the server's disk is full (data folder " + data + ", ";
  EXPECT_NE(job.paused().find(reason), std::string::npos) << job.paused();
  const auto shown = Kgd("job " + std::to_string(id) + " --server " + address);
  EXPECT_EQ(shown.exit_code, 0) << shown.output;
  EXPECT_NE(shown.output.find("paused: " + reason), std::string::npos) << shown.output;
  auto http_job = http.Get("/v1/jobs/" + std::to_string(id));
  ASSERT_TRUE(http_job);
  EXPECT_NE(http_job->body.find("\"paused\":\"" + reason), std::string::npos) << http_job->body;
  // Not ready, still alive.
  ready = http.Get("/readyz");
  ASSERT_TRUE(ready);
  EXPECT_EQ(ready->status, 503) << ready->body;
  EXPECT_NE(ready->body.find("not ready: " + reason), std::string::npos) << ready->body;
  auto live = http.Get("/healthz");
  ASSERT_TRUE(live);
  EXPECT_EQ(live->status, 200) << live->body;
  // New jobs refused, over both doors, with the reason.
  {
    grpc::ClientContext ctx;
    v1::CreateJobRequest req;
    *req.mutable_spec() = spec;
    v1::Job refused;
    const grpc::Status st = stub->CreateJob(&ctx, req, &refused);
    EXPECT_EQ(st.error_code(), grpc::StatusCode::UNAVAILABLE) << st.error_message();
    EXPECT_NE(st.error_message().find("the server takes no new jobs now: " + reason), std::string::npos) << st.error_message();
  }
  auto posted = http.Post("/v1/jobs", R"({"builtinScene": "sleeve_on_limb", "optimizer": {"maxIterations": 2}})", "application/json");
  ASSERT_TRUE(posted);
  EXPECT_EQ(posted->status, 503) << posted->body;
  EXPECT_NE(posted->body.find(reason), std::string::npos) << posted->body;
  const auto submitted = Kgd("submit sleeve_on_limb --iterations 2 --server " + address);
  EXPECT_NE(submitted.exit_code, 0) << submitted.output;
  EXPECT_NE(submitted.output.find("the server takes no new jobs now: " + reason), std::string::npos) << submitted.output;
  // It waits: no iteration is lost or stored while the disk is full, and the lease is kept.
  const int stored = get_job(id).iterations();
  std::this_thread::sleep_for(std::chrono::seconds(4));  // longer than the lease
  job = get_job(id);
  EXPECT_EQ(job.state(), v1::RUNNING);
  EXPECT_EQ(job.iterations(), stored);
  EXPECT_EQ(job.attempts(), 1);
  EXPECT_FALSE(job.paused().empty());

  // Space returns: the job continues by itself and ends as an uninterrupted run.
  fs::remove(disk + "/filler");
  ASSERT_TRUE(WaitFor(
      [&] {
        const v1::JobState s = get_job(id).state();
        return s == v1::SUCCEEDED || s == v1::FAILED || s == v1::CANCELLED;
      },
      90))
      << ReadText(log_path);
  job = get_job(id);
  EXPECT_EQ(job.state(), v1::SUCCEEDED) << job.failure();
  EXPECT_TRUE(job.paused().empty());
  EXPECT_EQ(job.attempts(), 1);
  ready = http.Get("/readyz");
  ASSERT_TRUE(ready);
  EXPECT_EQ(ready->status, 200) << ready->body;
  watcher.join();
  EXPECT_TRUE(watch_status.ok()) << watch_status.error_message();
  bool heard_pause = false;
  for (const v1::Job& j : snapshots) heard_pause = heard_pause || j.paused().find(reason) != std::string::npos;
  EXPECT_TRUE(heard_pause) << "the watch stream never said the job was paused";
  ASSERT_FALSE(snapshots.empty());
  EXPECT_EQ(snapshots.back().state(), v1::SUCCEEDED);
  EXPECT_TRUE(snapshots.back().paused().empty());
  ASSERT_EQ(static_cast<int>(watched.size()), job.iterations());
  for (size_t k = 0; k < watched.size(); ++k) EXPECT_EQ(watched[k], static_cast<int>(k));

  const std::string local_path = dir + "/local.h5";
  const auto local_run = Kgd("design sleeve_on_limb --iterations " + std::to_string(iterations) + " --budget " + std::to_string(budget) +
                             " --out " + local_path);
  ASSERT_EQ(local_run.exit_code, 0) << local_run.output;
  Result<DesignFile> local = ReadDesignFile(local_path);
  Result<DesignFile> served = ReadDesignFile(data + "/jobs/job-" + std::to_string(id) + ".h5");
  ASSERT_TRUE(local.ok()) << local.message();
  ASSERT_TRUE(served.ok()) << served.message();
  ASSERT_EQ(served->iterations.size(), local->iterations.size());
  for (size_t k = 0; k < local->iterations.size(); ++k) {
    const BesoIteration &a = served->iterations[k], &b = local->iterations[k];
    EXPECT_EQ(a.iteration, static_cast<int>(k));
    EXPECT_EQ(a.design, b.design) << "iteration " << k;
    EXPECT_EQ(a.energy_J, b.energy_J) << "iteration " << k;
    EXPECT_EQ(a.density_ratio, b.density_ratio) << "iteration " << k;
    EXPECT_TRUE(a.positions == b.positions) << "iteration " << k;
    EXPECT_TRUE(a.energy_density_Pa == b.energy_density_Pa) << "iteration " << k;
    EXPECT_TRUE(a.sensitivity == b.sensitivity) << "iteration " << k;
  }
  serve.Signal(SIGINT);
  serve.Wait();
}

}  // namespace
}  // namespace kgd
