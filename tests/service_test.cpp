// The design service end to end, as it runs for real: a kgd-server process and kgd-worker processes on
// loopback, clients over gRPC and through the kgd CLI, results compared bit for bit with `kgd design`
// run locally. Covers the service issue's acceptance list: many jobs on two workers, a worker killed
// mid-job, the server killed mid-job, cancel, watch replay/live/resume, bad requests.
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <thread>

#include "kgd/v1/kgd.grpc.pb.h"
#include "store/design_file.h"
#include "proto/connection.h"
#include "tests/child_process.h"
#include "tests/job_client.h"
#include "tests/kgd_cli.h"

namespace kgd {
namespace {
namespace fs = std::filesystem;
using cli_test::Kgd;

using test_support::FreePort;
using test_support::JobClient;
using test_support::Process;
using test_support::WaitFor;

// One server (restartable on the same port and data folder) and its workers.
class Service {
 public:
  explicit Service(const std::string& name, std::vector<std::string> server_flags = {})
      : dir_((fs::temp_directory_path() / ("kgd_service_test_" + name)).string()), flags_(std::move(server_flags)) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    address_ = "127.0.0.1:" + std::to_string(FreePort());
    StartServer();
    client_ = std::make_unique<JobClient>(address_);
  }

  void StartServer() {
    std::vector<std::string> args = {KGD_SERVER_BINARY, "--data", dir_ + "/data", "--listen", address_, "--lease-s", "3"};
    args.insert(args.end(), flags_.begin(), flags_.end());
    server_ = Process::Spawn(args, dir_ + "/server.log");
    ASSERT_TRUE(WaitFor([&] { return Log().find("listening on") != std::string::npos; }, 30)) << Log();
  }
  void KillServer(int sig = SIGKILL) {
    server_.Signal(sig);
    server_.Wait();
  }
  int StopServer() {
    server_.Signal(SIGTERM);
    return server_.Wait();
  }
  // Starts a worker process; returns its index.
  int StartWorker() {
    const int k = static_cast<int>(workers_.size());
    workers_.push_back(Process::Spawn({KGD_WORKER_BINARY, "--server", address_, "--name", "w" + std::to_string(k)},
                                      dir_ + "/worker" + std::to_string(k) + ".log"));
    return k;
  }
  void SignalWorker(int k, int sig) { workers_[k].Signal(sig); }
  void KillWorker(int k) {
    workers_[k].Signal(SIGKILL);
    workers_[k].Wait();
  }

  std::string Log() const {
    std::ifstream in(dir_ + "/server.log");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  const std::string& address() const { return address_; }
  const std::string& dir() const { return dir_; }
  std::string DataFile(int64_t id) const { return dir_ + "/data/jobs/job-" + std::to_string(id) + ".h5"; }
  v1::DesignService::Stub& stub() { return client_->stub(); }
  grpc::Status Create(const v1::JobSpec& spec, v1::Job* job) { return client_->Create(spec, job); }
  v1::Job Get(int64_t id) { return client_->Get(id); }
  bool Finished(int64_t id) { return client_->Finished(id); }

 private:
  std::string dir_, address_;
  std::vector<std::string> flags_;
  Process server_;
  std::vector<Process> workers_;
  std::unique_ptr<JobClient> client_;
};

v1::JobSpec Sleeve(int iterations, double budget = 0.15) {
  v1::JobSpec spec;
  spec.set_builtin_scene("sleeve_on_limb");
  spec.mutable_optimizer()->set_max_iterations(iterations);
  spec.mutable_optimizer()->set_budget(budget);
  return spec;
}

// The same job run locally with `kgd design` (cached per settings).
const DesignFile& LocalRun(int iterations, double budget = 0.15) {
  static std::map<std::pair<int, double>, DesignFile> cache;
  auto key = std::make_pair(iterations, budget);
  if (!cache.count(key)) {
    const std::string path =
        (fs::temp_directory_path() / ("kgd_service_test_local_" + std::to_string(getpid()) + "_" + std::to_string(iterations) + "_" +
                                   std::to_string(budget) + ".h5")).string();  // per process: ctest runs tests side by side
    const auto run = Kgd("design sleeve_on_limb --json --iterations " + std::to_string(iterations) + " --budget " + std::to_string(budget) +
                         " --out " + path);
    EXPECT_EQ(run.exit_code, 0) << run.output;
    Result<DesignFile> f = ReadDesignFile(path);
    EXPECT_TRUE(f.ok()) << f.message();
    fs::remove(path);
    cache[key] = std::move(f).value();
  }
  return cache[key];
}

// The job's design file equals the local run, iteration by iteration, bit for bit.
void ExpectSameAsLocal(const std::string& server_file, const DesignFile& local) {
  Result<DesignFile> f = ReadDesignFile(server_file);
  ASSERT_TRUE(f.ok()) << f.message();
  // The header records what the iterations ran with, as the local file's does: kernel level and solves.
  EXPECT_EQ(f->header.kernels, local.header.kernels);
  EXPECT_GT(f->header.grad_tol, 0.0);
  EXPECT_EQ(f->header.grad_tol, local.header.grad_tol);
  EXPECT_EQ(f->header.max_newton_iterations, local.header.max_newton_iterations);
  ASSERT_EQ(f->iterations.size(), local.iterations.size()) << server_file;
  for (size_t k = 0; k < local.iterations.size(); ++k) {
    const BesoIteration &a = f->iterations[k], &b = local.iterations[k];
    ASSERT_EQ(a.iteration, static_cast<int>(k)) << "iterations are contiguous";
    EXPECT_EQ(a.design, b.design) << server_file << " iteration " << k;
    EXPECT_EQ(a.energy_J, b.energy_J) << server_file << " iteration " << k;
    EXPECT_EQ(a.density_ratio, b.density_ratio) << server_file << " iteration " << k;
    EXPECT_TRUE(a.positions == b.positions) << server_file << " iteration " << k;
    EXPECT_TRUE(a.sensitivity == b.sensitivity) << server_file << " iteration " << k;
  }
}

// Every iteration a watcher receives, in order.
struct Watched {
  std::vector<v1::IterationRecord> iterations;
  std::vector<v1::JobState> states;
  grpc::Status status;
};
Watched Watch(v1::DesignService::Stub& stub, int64_t id, int from, int stop_after = -1, bool with_positions = false) {
  Watched w;
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  v1::WatchJobRequest req;
  req.set_id(id);
  req.set_from_iteration(from);
  req.set_with_positions(with_positions);
  auto reader = stub.WatchJob(&ctx, req);
  v1::WatchJobEvent ev;
  while (reader->Read(&ev)) {
    if (ev.has_job()) w.states.push_back(ev.job().state());
    if (ev.has_iteration()) w.iterations.push_back(ev.iteration());
    if (stop_after >= 0 && static_cast<int>(w.iterations.size()) >= stop_after) {
      ctx.TryCancel();
      break;
    }
  }
  w.status = reader->Finish();
  return w;
}

bool SameRecord(const v1::IterationRecord& a, const v1::IterationRecord& b) { return a.SerializeAsString() == b.SerializeAsString(); }

// 1. Five jobs at once, two worker processes: all finish, contiguous, identical to local runs.
TEST(Service, FiveJobsOnTwoWorkersAllFinishIdenticalToLocalRuns) {
  Service service("five");
  service.StartWorker();
  service.StartWorker();
  std::vector<int64_t> ids;
  for (int k = 0; k < 5; ++k) {
    v1::Job job;
    ASSERT_TRUE(service.Create(Sleeve(10 + k), &job).ok());
    EXPECT_EQ(job.state(), v1::QUEUED);
    ids.push_back(job.id());
  }
  ASSERT_TRUE(WaitFor([&] {
    for (int64_t id : ids)
      if (!service.Finished(id)) return false;
    return true;
  }, 300)) << service.Log();
  std::set<std::string> workers_used;
  for (int k = 0; k < 5; ++k) {
    const v1::Job job = service.Get(ids[k]);
    EXPECT_EQ(job.state(), v1::SUCCEEDED) << job.failure();
    EXPECT_EQ(job.iterations(), 11 + k);
    EXPECT_EQ(job.attempts(), 1);
    ExpectSameAsLocal(service.DataFile(ids[k]), LocalRun(10 + k));
    // The stored stream (SQLite) agrees with the HDF5 file: iterations 0..n-1, each once.
    const Watched w = Watch(service.stub(), ids[k], 0);
    ASSERT_TRUE(w.status.ok()) << w.status.error_message();
    ASSERT_EQ(static_cast<int>(w.iterations.size()), job.iterations());
    for (int i = 0; i < job.iterations(); ++i) EXPECT_EQ(w.iterations[i].metrics().iteration(), i);
  }
  const std::string log = service.Log();
  EXPECT_NE(log.find("leased to w0"), std::string::npos);
  EXPECT_NE(log.find("leased to w1"), std::string::npos) << "both workers took jobs";
}

// 2. A worker killed with SIGKILL mid-job: the job resumes on the other worker from its last reported
// iteration; the result equals an uninterrupted run.
TEST(Service, AKilledWorkersJobResumesOnTheOtherWorkerIdenticalToAnUninterruptedRun) {
  Service service("worker_killed");
  service.StartWorker();
  service.StartWorker();
  v1::Job job;
  ASSERT_TRUE(service.Create(Sleeve(30), &job).ok());
  ASSERT_TRUE(WaitFor([&] { return service.Get(job.id()).iterations() >= 6; }, 120)) << service.Log();
  const v1::Job before = service.Get(job.id());
  ASSERT_EQ(before.state(), v1::RUNNING);
  const int victim = before.worker() == "w0" ? 0 : 1;
  service.KillWorker(victim);
  ASSERT_TRUE(WaitFor([&] { return service.Finished(job.id()); }, 180)) << service.Log();
  const v1::Job after = service.Get(job.id());
  EXPECT_EQ(after.state(), v1::SUCCEEDED) << after.failure();
  EXPECT_EQ(after.attempts(), 2);
  EXPECT_GE(after.iterations(), before.iterations());
  EXPECT_NE(service.Log().find("leased to w" + std::to_string(1 - victim) + " (attempt 2, from iteration"), std::string::npos)
      << service.Log();
  ExpectSameAsLocal(service.DataFile(job.id()), LocalRun(30));
}

// A worker frozen (SIGSTOP) mid-job keeps its stream open but stops heartbeating: its lease expires, the
// job resumes on the other worker, and when the frozen one wakes up its reports are refused; the result
// is still the uninterrupted run's.
TEST(Service, AFrozenWorkersLeaseExpiresAndItsLateReportsAreRefused) {
  Service service("worker_frozen");
  service.StartWorker();
  service.StartWorker();
  v1::Job job;
  ASSERT_TRUE(service.Create(Sleeve(30), &job).ok());
  ASSERT_TRUE(WaitFor([&] { return service.Get(job.id()).iterations() >= 4; }, 120)) << service.Log();
  const v1::Job before = service.Get(job.id());
  const int frozen = before.worker() == "w0" ? 0 : 1;
  service.SignalWorker(frozen, SIGSTOP);
  ASSERT_TRUE(WaitFor([&] { return service.Log().find("lease expired") != std::string::npos; }, 60)) << service.Log();
  service.SignalWorker(frozen, SIGCONT);
  ASSERT_TRUE(WaitFor([&] { return service.Finished(job.id()); }, 120)) << service.Log();
  const v1::Job after = service.Get(job.id());
  EXPECT_EQ(after.state(), v1::SUCCEEDED) << after.failure();
  EXPECT_EQ(after.attempts(), 2);
  ExpectSameAsLocal(service.DataFile(job.id()), LocalRun(30));
}

// 3. The server killed with SIGKILL mid-job and restarted on the same folder: no job or acknowledged
// iteration lost, workers reconnect, all jobs finish; SQLite and HDF5 intact. A `kgd watch` running
// across the restart sees every iteration once.
TEST(Service, AServerKilledMidJobRestartsWithEveryAcknowledgedIteration) {
  Service service("server_killed");
  service.StartWorker();
  service.StartWorker();
  std::vector<int64_t> ids;
  for (int k = 0; k < 3; ++k) {
    v1::Job job;
    ASSERT_TRUE(service.Create(Sleeve(24 + 3 * k), &job).ok());
    ids.push_back(job.id());
  }
  const std::string watch_out = service.dir() + "/watch.jsonl";
  Process watcher = Process::Spawn({KGD_BINARY, "watch", std::to_string(ids[0]), "--json", "--server", service.address()}, watch_out);
  ASSERT_TRUE(WaitFor([&] { return service.Get(ids[0]).iterations() >= 8; }, 120)) << service.Log();
  std::map<int64_t, int> acknowledged;
  for (int64_t id : ids) acknowledged[id] = service.Get(id).iterations();
  service.KillServer(SIGKILL);
  // Between the kill and the restart: the files are readable as they are.
  for (int64_t id : ids) {
    if (!fs::exists(service.DataFile(id))) continue;
    Result<DesignFile> f = ReadDesignFile(service.DataFile(id), {.arrays = false});
    ASSERT_TRUE(f.ok()) << f.message();
    EXPECT_GE(static_cast<int>(f->iterations.size()), acknowledged[id]);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  service.StartServer();
  for (int64_t id : ids) {
    ASSERT_TRUE(WaitFor([&] { return service.Get(id).state() != v1::JOB_STATE_UNSPECIFIED; }, 30)) << "the restarted server answers";
    EXPECT_GE(service.Get(id).iterations(), acknowledged[id]) << "job " << id << " lost acknowledged iterations";
  }
  ASSERT_TRUE(WaitFor([&] {
    for (int64_t id : ids)
      if (!service.Finished(id)) return false;
    return true;
  }, 240)) << service.Log();
  for (int k = 0; k < 3; ++k) {
    const v1::Job job = service.Get(ids[k]);
    EXPECT_EQ(job.state(), v1::SUCCEEDED) << job.failure();
    ExpectSameAsLocal(service.DataFile(ids[k]), LocalRun(24 + 3 * k));
  }
  const int final_iterations = service.Get(ids[0]).iterations();
  service.StopServer();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((service.dir() + "/data/kgd.sqlite").c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "PRAGMA integrity_check", -1, &st, nullptr);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)), "ok");
  sqlite3_finalize(st);
  sqlite3_close(db);

  // The watcher followed job 1 across the restart: iterations 0..n-1, each once, then SUCCEEDED.
  EXPECT_EQ(watcher.Wait(), 0);
  std::ifstream in(watch_out);
  int next = 0;
  bool succeeded = false;
  for (std::string line; std::getline(in, line);) {
    if (line.find("\"event\":\"iteration\"") != std::string::npos) {
      EXPECT_NE(line.find("\"iteration\":" + std::to_string(next) + ","), std::string::npos) << "expected iteration " << next << ": " << line;
      ++next;
    }
    succeeded |= line.find("SUCCEEDED") != std::string::npos;
  }
  EXPECT_EQ(next, final_iterations);
  EXPECT_TRUE(succeeded);
}

// 4. Cancel stops a running job within one simulation; stored iterations stay readable.
TEST(Service, CancelStopsARunningJobWithinOneIteration) {
  Service service("cancel");
  service.StartWorker();
  v1::Job job;
  ASSERT_TRUE(service.Create(Sleeve(200), &job).ok());
  ASSERT_TRUE(WaitFor([&] { return service.Get(job.id()).iterations() >= 4; }, 120)) << service.Log();
  const auto cancel = Kgd("cancel " + std::to_string(job.id()) + " --server " + service.address());
  EXPECT_EQ(cancel.exit_code, 0) << cancel.output;
  const int at_cancel = service.Get(job.id()).iterations();
  ASSERT_TRUE(WaitFor([&] { return service.Finished(job.id()); }, 30)) << service.Log();
  const v1::Job after = service.Get(job.id());
  EXPECT_EQ(after.state(), v1::CANCELLED);
  // The iteration under way when the cancel arrived may finish (and one report may be in flight).
  EXPECT_LE(after.iterations(), at_cancel + 2);
  const auto get = Kgd("get " + std::to_string(job.id()) + " --iteration 2 --json --out " + service.dir() + "/it2.ply --server " + service.address());
  EXPECT_EQ(get.exit_code, 0) << get.output;
  EXPECT_NE(get.output.find("\"iteration\":2"), std::string::npos) << get.output;
  EXPECT_TRUE(fs::exists(service.dir() + "/it2.ply"));
  // A queued job is cancelled at once.
  v1::Job second, third;
  ASSERT_TRUE(service.Create(Sleeve(200), &second).ok());
  ASSERT_TRUE(service.Create(Sleeve(200), &third).ok());
  const auto cancel3 = Kgd("cancel " + std::to_string(third.id()) + " --server " + service.address());
  EXPECT_NE(cancel3.output.find("CANCELLED"), std::string::npos) << cancel3.output;
  Kgd("cancel " + std::to_string(second.id()) + " --server " + service.address());
  EXPECT_TRUE(WaitFor([&] { return service.Finished(second.id()); }, 30));
}

// 5. WatchJob replays then continues live; two watchers receive identical streams; a watcher that
// disconnects and resumes sees no gap.
TEST(Service, WatchersReplayThenFollowLiveIdenticallyAndResumeWithoutGaps) {
  Service service("watch");
  service.StartWorker();
  v1::Job job;
  ASSERT_TRUE(service.Create(Sleeve(40), &job).ok());
  ASSERT_TRUE(WaitFor([&] { return service.Get(job.id()).iterations() >= 3; }, 120)) << service.Log();
  // Arrays of a running job come from its design file while the server writes it.
  const auto get = Kgd("get " + std::to_string(job.id()) + " --iteration 1 --out " + service.dir() + "/it1.ply --server " + service.address());
  EXPECT_EQ(get.exit_code, 0) << get.output;
  Watched a, b, partial, rest, late;
  std::thread ta([&] { a = Watch(service.stub(), job.id(), 0); });
  std::thread tb([&] { b = Watch(service.stub(), job.id(), 0); });
  std::thread tc([&] {
    partial = Watch(service.stub(), job.id(), 0, 7);  // disconnects after 7 iterations ...
    rest = Watch(service.stub(), job.id(), 7);        // ... and resumes where it stopped
  });
  std::thread td([&] { late = Watch(service.stub(), job.id(), 5); });
  ta.join(), tb.join(), tc.join(), td.join();
  ASSERT_TRUE(a.status.ok()) << a.status.error_message();
  ASSERT_TRUE(b.status.ok());
  const v1::Job done = service.Get(job.id());
  EXPECT_EQ(done.state(), v1::SUCCEEDED);
  ASSERT_EQ(static_cast<int>(a.iterations.size()), done.iterations());
  ASSERT_EQ(a.iterations.size(), b.iterations.size());
  for (size_t i = 0; i < a.iterations.size(); ++i) {
    EXPECT_EQ(a.iterations[i].metrics().iteration(), static_cast<int>(i));
    EXPECT_TRUE(SameRecord(a.iterations[i], b.iterations[i])) << "iteration " << i;
    EXPECT_EQ(a.iterations[i].design().size(), static_cast<size_t>(done.garment_faces()));
  }
  EXPECT_EQ(a.states.back(), v1::SUCCEEDED);
  ASSERT_EQ(partial.iterations.size(), 7u);
  std::vector<v1::IterationRecord> resumed = partial.iterations;
  resumed.insert(resumed.end(), rest.iterations.begin(), rest.iterations.end());
  ASSERT_EQ(resumed.size(), a.iterations.size());
  for (size_t i = 0; i < resumed.size(); ++i) EXPECT_TRUE(SameRecord(resumed[i], a.iterations[i])) << "iteration " << i;
  ASSERT_EQ(late.iterations.size(), a.iterations.size() - 5);
  for (size_t i = 0; i < late.iterations.size(); ++i) EXPECT_TRUE(SameRecord(late.iterations[i], a.iterations[i + 5]));
  // The design bits streamed are those stored in the HDF5 file.
  Result<DesignFile> f = ReadDesignFile(service.DataFile(job.id()));
  ASSERT_TRUE(f.ok());
  for (size_t i = 0; i < a.iterations.size(); ++i)
    EXPECT_EQ(a.iterations[i].design(), std::string(f->iterations[i].design.begin(), f->iterations[i].design.end()));
  // Positions on request: the stored equilibrium, bit for bit.
  const Watched with_positions = Watch(service.stub(), job.id(), done.iterations() - 2, -1, true);
  ASSERT_EQ(with_positions.iterations.size(), 2u);
  for (const v1::IterationRecord& r : with_positions.iterations) {
    const Positions& x = f->iterations[r.metrics().iteration()].positions;
    ASSERT_EQ(r.positions_size(), x.size());
    for (int i = 0; i < r.positions_size(); ++i) ASSERT_EQ(r.positions(i), x.data()[i]);
  }
  EXPECT_EQ(a.iterations.back().positions_size(), 0) << "positions only on request";
}

// 6. Bad requests get clear errors and disturb nothing; the server answers health checks.
TEST(Service, BadRequestsGetClearErrorsAndLeaveRunningJobsAlone) {
  Service service("bad", {"--max-message-mb", "1"});
  service.StartWorker();
  v1::Job running;
  ASSERT_TRUE(service.Create(Sleeve(25), &running).ok());

  v1::Job ignored;
  v1::JobSpec spec = Sleeve(10);
  spec.mutable_optimizer()->set_budget(1.5);
  grpc::Status st = service.Create(spec, &ignored);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(st.error_message().find("budget"), std::string::npos) << st.error_message();
  spec = Sleeve(10);
  spec.set_builtin_scene("elbow_of_a_giraffe");
  st = service.Create(spec, &ignored);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(st.error_message().find("spec.builtin_scene"), std::string::npos) << st.error_message();
  st = service.Create(v1::JobSpec(), &ignored);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);

  EXPECT_EQ(service.Get(987654).state(), v1::JOB_STATE_UNSPECIFIED);
  {
    grpc::ClientContext ctx;
    v1::GetJobRequest req;
    req.set_id(987654);
    v1::Job job;
    st = service.stub().GetJob(&ctx, req, &job);
    EXPECT_EQ(st.error_code(), grpc::StatusCode::NOT_FOUND);
    EXPECT_NE(st.error_message().find("987654"), std::string::npos);
  }
  const Watched w = Watch(service.stub(), 987654, 0);
  EXPECT_EQ(w.status.error_code(), grpc::StatusCode::NOT_FOUND);
  const auto cli = Kgd("job 987654 --server " + service.address());
  EXPECT_EQ(cli.exit_code, 2);
  EXPECT_NE(cli.output.find("job 987654 does not exist"), std::string::npos) << cli.output;

  spec = Sleeve(10);
  spec.mutable_scene_files()->mutable_scene()->set_description(std::string(2 << 20, 'x'));
  st = service.Create(spec, &ignored);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << st.error_message();

  // Standard health checking (grpc.health.v1.Health/Check with an empty request: the whole server).
  Connection to_service;
  to_service.server = service.address();
  const Status health = CheckHealth(to_service, 10);
  EXPECT_TRUE(health.ok()) << health.message();

  // A scene naming a file the bundle lacks is refused at once, naming the key and the file.
  spec = Sleeve(10);
  spec.mutable_scene_files()->mutable_scene()->set_name("broken");
  spec.mutable_scene_files()->mutable_scene()->mutable_garment()->set_rest("broken.obj");
  st = service.Create(spec, &ignored);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(st.error_message().find("spec.scene_files.scene.garment.rest: 'broken.obj'"), std::string::npos)
      << st.error_message();

  // A spec that validates but whose scene cannot be built fails with the worker's reason, once.
  (*spec.mutable_scene_files()->mutable_files())["broken.obj"] = "v 0 0 0\nv 1 0 0\nf 1 2 3\n";
  v1::Job broken;
  ASSERT_TRUE(service.Create(spec, &broken).ok());

  ASSERT_TRUE(WaitFor([&] { return service.Finished(running.id()) && service.Finished(broken.id()); }, 120));
  EXPECT_EQ(service.Get(running.id()).state(), v1::SUCCEEDED);
  ExpectSameAsLocal(service.DataFile(running.id()), LocalRun(25));
  const v1::Job failed = service.Get(broken.id());
  EXPECT_EQ(failed.state(), v1::FAILED);
  EXPECT_EQ(failed.attempts(), 1);
  EXPECT_NE(failed.failure().find("broken.obj"), std::string::npos) << failed.failure();
}

// SIGTERM drains: the running job stops after its iteration, goes back to the queue, and a restarted
// server finishes it with the same result.
TEST(Service, SigtermDrainsAndTheJobResumesAfterARestart) {
  Service service("drain");
  service.StartWorker();
  v1::Job job;
  ASSERT_TRUE(service.Create(Sleeve(24), &job).ok());
  ASSERT_TRUE(WaitFor([&] { return service.Get(job.id()).iterations() >= 4; }, 120)) << service.Log();
  const int status = service.StopServer();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << service.Log();
  EXPECT_NE(service.Log().find("draining"), std::string::npos);
  EXPECT_NE(service.Log().find("job " + std::to_string(job.id()) + " QUEUED"), std::string::npos) << service.Log();
  service.StartServer();
  ASSERT_TRUE(WaitFor([&] { return service.Finished(job.id()); }, 120)) << service.Log();
  EXPECT_EQ(service.Get(job.id()).state(), v1::SUCCEEDED);
  ExpectSameAsLocal(service.DataFile(job.id()), LocalRun(24));
}

}  // namespace
}  // namespace kgd
