// The job service in-process, with fake workers that speak RunJob through callbacks: a lost worker's
// lease expires and its job resumes on the next from the last acknowledged iteration; a reopened data
// folder queues its leased jobs again with every acknowledged iteration; watchers get the stored
// iterations, each new one and the end; each limit is hit and named; the doors' results (garment,
// design file, energy per area, PLY) come from the service; a job's per-motion records are the design
// file's wherever they are read.
#include "server/job_service.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <hdf5.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "core/mesh/mesh_io.h"
#include "core/scene/scene_file.h"
#include "core/scene/shapes.h"
#include "core/scene/builtin_scenes.h"
#include "proto/job_spec.h"
#include "proto/records.h"
#include "job/fabrication_export.h"
#include "server/job_results.h"
#include "store/design_file.h"

namespace kgd::server {
namespace {
namespace fs = std::filesystem;

const Caller kAlice{"alice", Role::kUser};
const Caller kBob{"bob", Role::kUser};
const Caller kWorker{"w", Role::kWorker};

std::string FreshDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("kgd_job_service_test_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(p);
  return p.string();
}

JobServiceOptions Options(const std::string& dir) {
  JobServiceOptions o;
  o.data_dir = dir;
  o.lease_duration_s = 30;
  o.quiet = true;
  return o;
}

std::unique_ptr<JobService> Open(const JobServiceOptions& o) {
  Result<std::unique_ptr<JobService>> s = JobService::Open(o);
  EXPECT_TRUE(s.ok()) << s.message();
  return s.ok() ? std::move(s).value() : nullptr;
}

v1::CreateJobRequest SleeveJob(int max_iterations = 10) {
  v1::CreateJobRequest r;
  r.mutable_spec()->set_builtin_scene("sleeve_on_limb");
  r.mutable_spec()->mutable_optimizer()->set_max_iterations(max_iterations);
  return r;
}

// A small garment as a worker describes it: a 2 x 2 cm sheet, cloth 1 mm and reinforcement 2 mm thick.
DesignFileHeader Garment() {
  DesignFileHeader h;
  h.scene = "sleeve_on_limb";
  h.garment = RectangleSheet(0.02, 0.02, 0.01);
  h.initial = h.garment.vertices;
  h.rest_area_m2 = Eigen::VectorXd::Constant(h.garment.faces.rows(), 5e-5);
  h.cloth_thickness_m = 1e-3;
  h.reinforced_thickness_m = 2e-3;
  return h;
}

// Iteration k of a made-up run on Garment(): every array differs per iteration and per entry.
BesoIteration Iteration(int k) {
  const DesignFileHeader h = Garment();
  const int nf = static_cast<int>(h.garment.faces.rows());
  BesoIteration it;
  it.iteration = k;
  it.energy_J = 1.0 / (k + 2);
  it.area_fraction = 1.0 - 0.1 * k;
  it.design.assign(nf, 1);
  for (int f = 0; f < std::min(k, nf); ++f) it.design[f] = 0;
  it.positions = h.garment.vertices;
  it.positions.col(2).array() += 1e-3 * (k + 1);
  it.energy_density_Pa = Eigen::VectorXd::LinSpaced(nf, 10.0 + k, 20.0 + k);
  if (k > 0) it.sensitivity = Eigen::VectorXd::LinSpaced(nf, -1.0, 1.0 * k);
  return it;
}

// The kernel levels workers report (core/util/pinned_kernels.h); the fake workers run the first unless
// a test says otherwise.
const std::string kV3 = "x86-64-v3", kV1 = "x86-64";

v1::WorkerMessage Start(const std::string& lease, const std::string& kernels = kV3) {
  v1::WorkerMessage m;
  m.set_lease_id(lease);
  v1::JobStart* s = m.mutable_start();
  const DesignFileHeader h = Garment();
  *s->mutable_garment() = GarmentToProto(h);
  s->set_scene(h.scene);
  s->set_settings_json(BesoSettingsToJson(h.settings));
  s->set_kernels(kernels);
  return m;
}
v1::WorkerMessage Report(const std::string& lease, int k) {
  v1::WorkerMessage m;
  m.set_lease_id(lease);
  *m.mutable_iteration() = RecordToProto(Iteration(k));
  return m;
}
v1::WorkerMessage Complete(const std::string& lease) {
  v1::WorkerMessage m;
  m.set_lease_id(lease);
  m.set_complete(true);
  return m;
}
v1::WorkerMessage Release(const std::string& lease) {
  v1::WorkerMessage m;
  m.set_lease_id(lease);
  m.set_release(true);
  return m;
}

// One worker's RunJob stream: what the test sends, and each reply, in order.
class FakeStream {
 public:
  explicit FakeStream(JobService& service) {
    thread_ = std::thread([this, &service] {
      service.RunJob(
          kWorker,
          [this](v1::WorkerMessage* m) {
            std::unique_lock lock(mu_);
            cv_.wait(lock, [&] { return !in_.empty() || closed_; });
            if (in_.empty()) return false;
            *m = std::move(in_.front());
            in_.pop_front();
            return true;
          },
          [this](const v1::ServerMessage& m) {
            std::lock_guard lock(mu_);
            out_.push_back(m);
            cv_.notify_all();
            return true;
          },
          [] { return false; });
      std::lock_guard lock(mu_);
      ended_ = true;
      cv_.notify_all();
    });
  }
  ~FakeStream() {
    Close();
    thread_.join();
  }
  // Sends `m` and waits for its reply (none after complete, fail or release: then the stream's end).
  v1::ServerMessage Send(v1::WorkerMessage m) {
    std::unique_lock lock(mu_);
    const size_t replies = out_.size();
    in_.push_back(std::move(m));
    cv_.notify_all();
    cv_.wait(lock, [&] { return out_.size() > replies || ended_; });
    return out_.size() > replies ? out_.back() : v1::ServerMessage();
  }
  void Close() {
    std::lock_guard lock(mu_);
    closed_ = true;
    cv_.notify_all();
  }
  void WaitEnded() {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return ended_; });
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<v1::WorkerMessage> in_;
  std::vector<v1::ServerMessage> out_;
  bool closed_ = false, ended_ = false;
  std::thread thread_;
};

// A lease for `worker` running `kernels`, waiting up to wait_s for a job it may run.
v1::LeaseJobResponse Lease(JobService& s, const std::string& worker = "w", const std::string& kernels = kV3, double wait_s = 5) {
  v1::LeaseJobRequest r;
  r.set_worker(worker);
  r.set_kernels(kernels);
  r.set_wait_s(wait_s);
  v1::LeaseJobResponse out;
  EXPECT_TRUE(s.LeaseJob(kWorker, r, &out, [] { return false; }).ok());
  return out;
}

v1::Job Job(JobService& s, int64_t id) {
  v1::Job j;
  EXPECT_TRUE(s.GetJob(kAlice, id, &j).ok());
  return j;
}

bool WaitFor(const std::function<bool()>& done, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return done();
}

// Iteration `k` as the lease or a GetIteration carries it equals the one reported, bit for bit.
void ExpectRecordIs(const v1::IterationRecord& record, int k) {
  Result<BesoIteration> got = RecordFromProto(record);
  ASSERT_TRUE(got.ok()) << got.message();
  const BesoIteration want = Iteration(k);
  EXPECT_EQ(got->iteration, k);
  EXPECT_EQ(got->design, want.design);
  EXPECT_EQ(got->positions, want.positions);
  EXPECT_EQ(got->energy_density_Pa, want.energy_density_Pa);
  EXPECT_EQ(got->sensitivity, want.sensitivity);
}

TEST(JobService, ASilentWorkersLeaseExpiresAndTheNextResumesFromTheLastAcknowledgedIteration) {
  JobServiceOptions o = Options(FreshDir("lease"));
  o.lease_duration_s = 0.3;
  auto s = Open(o);
  ASSERT_TRUE(s);
  v1::Job job;
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &job).ok());
  const v1::LeaseJobResponse first = Lease(*s, "a");
  ASSERT_TRUE(first.leased());
  EXPECT_EQ(first.job_id(), job.id());
  EXPECT_EQ(first.attempt(), 1);
  EXPECT_EQ(first.history_size(), 0);
  FakeStream a(*s);
  EXPECT_EQ(a.Send(Start(first.lease_id())).error(), "");
  for (int k = 0; k < 2; ++k) EXPECT_EQ(a.Send(Report(first.lease_id(), k)).acknowledged_iterations(), k + 1);
  EXPECT_EQ(Job(*s, job.id()).state(), v1::RUNNING);
  // The worker goes silent, its stream open: after the lease's 0.3 s the job is queued again.
  ASSERT_TRUE(WaitFor([&] { return Job(*s, job.id()).state() == v1::QUEUED; }, 10));
  EXPECT_EQ(Job(*s, job.id()).iterations(), 2);
  const v1::LeaseJobResponse second = Lease(*s, "b");
  ASSERT_TRUE(second.leased());
  EXPECT_NE(second.lease_id(), first.lease_id());
  EXPECT_EQ(second.attempt(), 2);
  ASSERT_EQ(second.history_size(), 2);
  EXPECT_EQ(second.history(1).iteration(), 1);
  ExpectRecordIs(second.last(), 1);
  // The first worker's late report is refused and changes nothing.
  const v1::ServerMessage late = a.Send(Report(first.lease_id(), 2));
  EXPECT_NE(late.error().find("no longer held"), std::string::npos) << late.error();
  a.WaitEnded();
  EXPECT_EQ(Job(*s, job.id()).iterations(), 2);
  EXPECT_EQ(Job(*s, job.id()).state(), v1::RUNNING);
}

// A job whose iterations ran at one kernel level resumes only on a worker of that level (another would
// change its designs): released, it waits while an x86-64 worker asks (which takes a new job meanwhile),
// and goes to the next x86-64-v3 worker; a worker that starts it reporting another level is refused and
// the job queued again. Each job's level is its first worker's, in the job and its design file.
TEST(JobService, AJobResumesOnlyOnAWorkerOfTheKernelLevelItsIterationsRanAt) {
  auto s = Open(Options(FreshDir("kernels")));
  ASSERT_TRUE(s);
  v1::Job started, fresh;
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &started).ok());
  EXPECT_EQ(Job(*s, started.id()).kernels(), "") << "no worker has started it";
  const v1::LeaseJobResponse first = Lease(*s, "v3", kV3);
  ASSERT_TRUE(first.leased());
  {
    FakeStream a(*s);
    EXPECT_EQ(a.Send(Start(first.lease_id(), kV3)).error(), "");
    for (int k = 0; k < 2; ++k) EXPECT_EQ(a.Send(Report(first.lease_id(), k)).acknowledged_iterations(), k + 1);
    a.Send(Release(first.lease_id()));
    a.WaitEnded();
  }
  ASSERT_EQ(Job(*s, started.id()).state(), v1::QUEUED);
  EXPECT_EQ(Job(*s, started.id()).kernels(), kV3);
  Result<DesignFile> file = ReadDesignFile(Job(*s, started.id()).data_file(), {.arrays = false});
  ASSERT_TRUE(file.ok()) << file.message();
  EXPECT_EQ(file->header.kernels, kV3);

  EXPECT_FALSE(Lease(*s, "v1", kV1, 0).leased()) << "its iterations ran at x86-64-v3";
  EXPECT_FALSE(Lease(*s, "old", "", 0).leased()) << "a worker that does not say its level";
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &fresh).ok());
  const v1::LeaseJobResponse other = Lease(*s, "v1", kV1, 0);
  ASSERT_TRUE(other.leased());
  EXPECT_EQ(other.job_id(), fresh.id()) << "a new job goes to any level, past the older one waiting";
  {
    FakeStream b(*s);
    EXPECT_EQ(b.Send(Start(other.lease_id(), kV1)).error(), "");
    EXPECT_EQ(Job(*s, fresh.id()).kernels(), kV1);
  }  // the stream breaks before an iteration: the new job is queued again
  Result<DesignFile> fresh_file = ReadDesignFile(Job(*s, fresh.id()).data_file(), {.arrays = false});
  ASSERT_TRUE(fresh_file.ok()) << fresh_file.message();
  EXPECT_EQ(fresh_file->header.kernels, kV1);
  EXPECT_EQ(Job(*s, started.id()).state(), v1::QUEUED) << "still waiting";

  // A worker that leases as x86-64-v3 but starts as x86-64 is refused; the job waits again.
  const v1::LeaseJobResponse liar = Lease(*s, "v3", kV3, 0);
  ASSERT_TRUE(liar.leased());
  ASSERT_EQ(liar.job_id(), started.id());
  {
    FakeStream c(*s);
    const v1::ServerMessage refused = c.Send(Start(liar.lease_id(), kV1));
    EXPECT_NE(refused.error().find("x86-64-v3 kernels and this worker runs x86-64"), std::string::npos) << refused.error();
  }  // (a stream the service did not end, the fake worker closes)
  EXPECT_EQ(Job(*s, started.id()).state(), v1::QUEUED);
  EXPECT_EQ(Job(*s, started.id()).kernels(), kV3);

  const v1::LeaseJobResponse second = Lease(*s, "v3", kV3, 0);
  ASSERT_TRUE(second.leased());
  EXPECT_EQ(second.job_id(), started.id());
  ASSERT_EQ(second.history_size(), 2);
  FakeStream d(*s);
  EXPECT_EQ(d.Send(Start(second.lease_id(), kV3)).acknowledged_iterations(), 2);
  EXPECT_EQ(d.Send(Report(second.lease_id(), 2)).acknowledged_iterations(), 3);
}

// A job made from an uploaded scene is listed, fetched and watched without its files' contents (megabytes
// of meshes per job); the worker that leases it gets them whole.
TEST(JobService, CallersSeeAnUploadedScenesJobWithoutItsFilesAndTheWorkerGetsThem) {
  auto s = Open(Options(FreshDir("upload")));
  ASSERT_TRUE(s);
  const fs::path dir = fs::path(FreshDir("upload-scene"));
  Result<SceneSpec> pull = PullTestScene("all_cloth");
  ASSERT_TRUE(pull.ok());
  ASSERT_TRUE(ExportScene(*pull, dir.string()).ok());
  v1::CreateJobRequest req;
  Result<v1::SceneFiles> files = ReadSceneFiles((dir / "scene.json").string());
  ASSERT_TRUE(files.ok()) << files.message();
  ASSERT_GT(files->files_size(), 0);
  *req.mutable_spec()->mutable_scene_files() = *files;
  v1::Job created;
  const ServiceStatus st = s->CreateJob(kAlice, req, &created);
  ASSERT_TRUE(st.ok()) << st.message;
  EXPECT_TRUE(created.spec().has_scene_files());
  EXPECT_EQ(created.spec().scene_files().files_size(), 0);
  EXPECT_EQ(Job(*s, created.id()).spec().scene_files().files_size(), 0);
  EXPECT_EQ(Job(*s, created.id()).spec().scene_files().scene().SerializeAsString(), files->scene().SerializeAsString());
  v1::ListJobsResponse list;
  ASSERT_TRUE(s->ListJobs(kAlice, {}, &list).ok());
  ASSERT_EQ(list.jobs_size(), 1);
  EXPECT_EQ(list.jobs(0).spec().scene_files().files_size(), 0);
  const v1::LeaseJobResponse lease = Lease(*s, "a");
  ASSERT_TRUE(lease.leased());
  EXPECT_EQ(lease.spec().scene_files().files_size(), files->files_size());
}

TEST(JobService, AReopenedDataFolderQueuesItsLeasedJobsAgainWithEveryAcknowledgedIteration) {
  const JobServiceOptions o = Options(FreshDir("reopen"));
  int64_t id = 0;
  {
    auto s = Open(o);
    ASSERT_TRUE(s);
    v1::Job job;
    ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &job).ok());
    id = job.id();
    const v1::LeaseJobResponse lease = Lease(*s);
    {
      FakeStream w(*s);
      w.Send(Start(lease.lease_id()));
      for (int k = 0; k < 3; ++k) EXPECT_EQ(w.Send(Report(lease.lease_id(), k)).acknowledged_iterations(), k + 1);
    }  // the stream breaks: the job is queued again
    EXPECT_EQ(Job(*s, id).state(), v1::QUEUED);
    // Leased again, and the service closes with the lease held (as a killed server would leave it).
    ASSERT_TRUE(Lease(*s).leased());
    EXPECT_EQ(Job(*s, id).state(), v1::RUNNING);
  }
  auto s = Open(o);
  ASSERT_TRUE(s);
  const v1::Job job = Job(*s, id);
  EXPECT_EQ(job.state(), v1::QUEUED);
  EXPECT_EQ(job.iterations(), 3);
  const v1::LeaseJobResponse lease = Lease(*s);
  ASSERT_TRUE(lease.leased());
  EXPECT_EQ(lease.attempt(), 3);
  ASSERT_EQ(lease.history_size(), 3);
  ExpectRecordIs(lease.last(), 2);
  v1::GetIterationRequest r;
  r.set_id(id);
  r.set_iteration(1);
  v1::GetIterationResponse it;
  ASSERT_TRUE(s->GetIteration(kAlice, r, &it).ok());
  ExpectRecordIs(it.record(), 1);
  // The resumed lease continues the same file: iteration 3 follows, and the job ends.
  FakeStream w(*s);
  EXPECT_EQ(w.Send(Start(lease.lease_id())).acknowledged_iterations(), 3);
  EXPECT_EQ(w.Send(Report(lease.lease_id(), 3)).acknowledged_iterations(), 4);
  w.Send(Complete(lease.lease_id()));
  w.WaitEnded();
  EXPECT_EQ(Job(*s, id).state(), v1::SUCCEEDED);
  EXPECT_EQ(Job(*s, id).iterations(), 4);
}

// Every event of one watch, from its own thread, until the job ends or `stop`; the status it ended with.
struct Watch {
  std::vector<v1::WatchJobEvent> events;
  ServiceStatus status;
  std::atomic<bool> stop{false};
  std::thread thread;
  std::atomic<int> job_events{0};  // job snapshots received so far (readable while the watch runs)

  Watch(JobService& s, int64_t id, int from, const Caller& caller = kAlice) {
    thread = std::thread([this, &s, id, from, caller] {
      v1::WatchJobRequest r;
      r.set_id(id);
      r.set_from_iteration(from);
      status = s.WatchJob(
          caller, r, [this](const v1::WatchJobEvent& e) { return events.push_back(e), job_events += e.has_job(), true; }, [this] { return stop.load(); });
    });
  }
  ~Watch() {
    stop = true;
    if (thread.joinable()) thread.join();
  }
  std::vector<int> Iterations() const {
    std::vector<int> out;
    for (const auto& e : events)
      if (e.has_iteration()) out.push_back(e.iteration().metrics().iteration());
    return out;
  }
};

// The open watches the service counts (kgd_watchers).
bool OpenWatchesAre(JobService& s, int n) { return s.MetricsText().find("kgd_watchers " + std::to_string(n) + "\n") != std::string::npos; }

// One server per data folder: a second service on a folder another one has open is refused, naming the
// folder and the holder, before it touches the first's leases; the folder opens again once the first
// is closed.
TEST(JobService, ASecondServiceOnADataFolderInUseIsRefusedNamingTheFirst) {
  const JobServiceOptions o = Options(FreshDir("second"));
  auto first = Open(o);
  ASSERT_TRUE(first);
  v1::Job job;
  ASSERT_TRUE(first->CreateJob(kAlice, SleeveJob(), &job).ok());
  ASSERT_TRUE(Lease(*first).leased());
  Result<std::unique_ptr<JobService>> second = JobService::Open(o);
  ASSERT_FALSE(second.ok());
  EXPECT_NE(second.message().find("--data " + o.data_dir + ": another server uses this data folder"), std::string::npos) << second.message();
  EXPECT_NE(second.message().find("process " + std::to_string(getpid())), std::string::npos) << second.message();
  EXPECT_EQ(Job(*first, job.id()).state(), v1::RUNNING) << "the first server's lease is kept";
  first.reset();
  EXPECT_TRUE(Open(o)) << "the folder opens once the first server is closed";
}

TEST(JobService, WatchersGetTheStoredIterationsThenEachNewOneAndTheEnd) {
  auto s = Open(Options(FreshDir("watch")));
  ASSERT_TRUE(s);
  v1::Job job;
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &job).ok());
  const v1::LeaseJobResponse lease = Lease(*s);
  FakeStream w(*s);
  w.Send(Start(lease.lease_id()));
  for (int k = 0; k < 2; ++k) w.Send(Report(lease.lease_id(), k));
  Watch all(*s, job.id(), 0), late(*s, job.id(), 1);
  ASSERT_TRUE(WaitFor([&] { return OpenWatchesAre(*s, 2); }, 10)) << s->MetricsText();
  for (int k = 2; k < 4; ++k) w.Send(Report(lease.lease_id(), k));
  w.Send(Complete(lease.lease_id()));
  all.thread.join();
  late.thread.join();
  EXPECT_TRUE(all.status.ok()) << all.status.message;
  EXPECT_TRUE(late.status.ok()) << late.status.message;
  EXPECT_EQ(all.Iterations(), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(late.Iterations(), (std::vector<int>{1, 2, 3}));
  for (const Watch* watch : {&all, &late}) {
    ASSERT_FALSE(watch->events.empty());
    EXPECT_TRUE(watch->events.front().has_job());
    ASSERT_TRUE(watch->events.back().has_job());
    EXPECT_EQ(watch->events.back().job().state(), v1::SUCCEEDED);
  }
  // The design of each iteration as reported.
  for (const auto& e : all.events)
    if (e.has_iteration()) {
      const std::vector<uint8_t> design = Iteration(e.iteration().metrics().iteration()).design;
      EXPECT_EQ(e.iteration().design(), std::string(design.begin(), design.end()));
    }
  // Another user's watch is NOT_FOUND, the same as a job that does not exist.
  v1::WatchJobRequest r;
  r.set_id(job.id());
  const ServiceStatus bob = s->WatchJob(kBob, r, [](const v1::WatchJobEvent&) { return true; }, [] { return false; });
  EXPECT_EQ(bob.code, ServiceCode::kNotFound);
  EXPECT_EQ(bob.message, "job " + std::to_string(job.id()) + " does not exist");
}

TEST(JobService, EachLimitIsHitAndNamed) {
  JobServiceOptions o = Options(FreshDir("limits"));
  o.limits.max_queued_per_user = 2;
  o.limits.max_jobs_per_minute = 3;
  o.limits.max_iterations = 20;
  o.limits.max_watchers_per_job = 1;
  o.limits.max_held_watches = 1;
  auto s = Open(o);
  ASSERT_TRUE(s);
  auto refusal = [](const ServiceStatus& st, const std::string& flag) {
    EXPECT_EQ(st.code, ServiceCode::kResourceExhausted) << st.message;
    EXPECT_NE(st.message.find(flag), std::string::npos) << st.message;
  };
  v1::Job job;
  // An iteration limit above the server's is a bad argument, not a lack of resources: the same spec is
  // refused whenever it is sent.
  const ServiceStatus too_many = s->CreateJob(kAlice, SleeveJob(21), &job);
  EXPECT_EQ(too_many.code, ServiceCode::kInvalidArgument) << too_many.message;
  EXPECT_EQ(too_many.message, "spec.optimizer.max_iterations: 21 is above this server's limit of 20 iterations (--max-iterations)");
  v1::ListScenesResponse scenes;
  ASSERT_TRUE(s->ListScenes(&scenes).ok());
  EXPECT_EQ(scenes.max_iterations(), 20) << "the page checks the limit before it submits";
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(20), &job).ok());
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &job).ok());
  refusal(s->CreateJob(kAlice, SleeveJob(), &job), "--max-queued-per-user");
  // A job that starts frees a place in the queue; the refusals took no creation from the bucket of three.
  ASSERT_TRUE(Lease(*s).leased());
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &job).ok());
  ASSERT_TRUE(Lease(*s).leased());
  refusal(s->CreateJob(kAlice, SleeveJob(), &job), "--max-jobs-per-minute");
  // Another user has a queue and a bucket of its own.
  ASSERT_TRUE(s->CreateJob(kBob, SleeveJob(), &job).ok());
  // One watch of a job at a time.
  const int64_t id = job.id();
  {
    Watch open(*s, id, 0, kBob);
    ASSERT_TRUE(WaitFor([&] { return OpenWatchesAre(*s, 1); }, 10)) << s->MetricsText();
    refusal(s->CanWatch(kBob, id), "--max-watchers-per-job");
    v1::WatchJobRequest r;
    r.set_id(id);
    refusal(s->WatchJob(kBob, r, [](const v1::WatchJobEvent&) { return true; }, [] { return false; }), "--max-watchers-per-job");
    open.stop = true;
    open.thread.join();
    EXPECT_EQ(open.status.code, ServiceCode::kCancelled);
  }
  EXPECT_TRUE(s->CanWatch(kBob, id).ok());
  // Places for watches that hold a door's thread: one here; the second is refused until it is given back.
  WatchPlace place;
  ASSERT_TRUE(s->TakeWatchPlace(&place).ok());
  WatchPlace second;
  refusal(s->TakeWatchPlace(&second), "--max-watchers");
  place.reset();
  EXPECT_TRUE(s->TakeWatchPlace(&second).ok());
}

// Bad specs are refused when they are submitted, naming the field and the value, before any job exists:
// a body measurement outside the parametric body's range, a scene file without a garment, a mesh that
// is a photo.
TEST(JobService, BadSpecsAreRefusedAtSubmissionNamingTheFieldAndTheValue) {
  auto s = Open(Options(FreshDir("refusals")));
  ASSERT_TRUE(s);
  auto refused = [&](const v1::CreateJobRequest& r) {
    v1::Job job;
    const ServiceStatus st = s->CreateJob(kAlice, r, &job);
    EXPECT_EQ(st.code, ServiceCode::kInvalidArgument) << st.message;
    return st.message;
  };
  v1::CreateJobRequest tall;
  tall.mutable_spec()->set_builtin_scene("knee_flexion");
  tall.mutable_spec()->add_body("height_m=5");
  EXPECT_EQ(refused(tall), "spec.body: body measurement height_m = 5 is outside [1.2, 2.2]");
  v1::CreateJobRequest no_garment;
  v1::SceneFiles* files = no_garment.mutable_spec()->mutable_scene_files();
  files->mutable_scene()->mutable_body()->set_mesh("body.obj");
  (*files->mutable_files())["body.obj"] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  EXPECT_EQ(refused(no_garment), "spec.scene_files.scene: garment: missing (give garment.rest, or garment.region with body.rest and body.deformed)");
  files->mutable_scene()->mutable_garment()->set_rest("photo.obj");
  (*files->mutable_files())["photo.obj"] = std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16);
  EXPECT_EQ(refused(no_garment), "spec.scene_files.scene.garment.rest: photo.obj is not an OBJ or PLY mesh (line 1: \"\\x89PNG\" is not text)");
  v1::ListJobsResponse listed;
  ASSERT_TRUE(s->ListJobs(kAlice, v1::ListJobsRequest(), &listed).ok());
  EXPECT_EQ(listed.jobs_size(), 0) << "no job was made";
}

// The worker's end report: the job says how its design loop ended and, while the final design is
// evaluated, that it is evaluating (watchers get the job again when the phase turns); the worker's
// simulation of the cleaned last design fills the cut files' report of that iteration, and only when the
// export's cleaned design is the one the worker simulated.
TEST(JobService, TheEndReportTurnsTheJobToEvaluatingAndTheCleanedDesignFillsTheExportReport) {
  auto s = Open(Options(FreshDir("ended")));
  ASSERT_TRUE(s);
  v1::Job job;
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(2), &job).ok());
  const v1::LeaseJobResponse lease = Lease(*s);
  FakeStream w(*s);
  w.Send(Start(lease.lease_id()));
  Watch watch(*s, job.id(), 0);
  ASSERT_TRUE(WaitFor([&] { return OpenWatchesAre(*s, 1); }, 10)) << s->MetricsText();
  for (int k = 0; k < 3; ++k) w.Send(Report(lease.lease_id(), k));
  EXPECT_EQ(Job(*s, job.id()).phase(), v1::DESIGNING);
  EXPECT_EQ(Job(*s, job.id()).ended(), "");
  const std::string sentence = "stopped at the iteration limit (2) at 80.0 % of the garment, above the budget of 15 %";
  v1::WorkerMessage ended;
  ended.set_lease_id(lease.lease_id());
  ended.set_ended(sentence);
  EXPECT_EQ(w.Send(ended).error(), "");
  EXPECT_EQ(Job(*s, job.id()).state(), v1::RUNNING);
  EXPECT_EQ(Job(*s, job.id()).phase(), v1::EVALUATING);
  EXPECT_EQ(Job(*s, job.id()).ended(), sentence);

  // The cut files' report of iteration 2: "not simulated" until the worker's figures come.
  auto report = [&](int k) {
    v1::ExportDesignRequest r;
    r.set_id(job.id());
    r.set_iteration(k);
    v1::ExportDesignResponse out;
    const ServiceStatus st = s->ExportDesign(kAlice, r, &out);
    EXPECT_TRUE(st.ok()) << st.message;
    return st.ok() ? out.files().at("report.json") : std::string();
  };
  EXPECT_NE(report(2).find("\"solve_status\": \"not simulated\""), std::string::npos) << report(2);
  Result<ExportFiles> geometry = ExportGeometry(Garment(), Iteration(2), ExportOptions());
  ASSERT_TRUE(geometry.ok()) << geometry.message();
  const std::vector<uint8_t>& bits = geometry->report.cleaned.design;
  v1::WorkerMessage cleaned;
  cleaned.set_lease_id(lease.lease_id());
  v1::CleanedDesign* c = cleaned.mutable_cleaned();
  c->set_iteration(2);
  c->set_min_feature_m(CleaningOptions().min_feature_m);
  c->set_design(std::string(bits.size(), '\1'));  // another design than the export's cleaning gives
  ASSERT_NE(c->design(), std::string(bits.begin(), bits.end()));
  c->set_area_fraction(0.75);
  c->set_density_ratio(2.5);
  c->set_solve_status("converged");
  EXPECT_EQ(w.Send(cleaned).error(), "");
  EXPECT_NE(report(2).find("\"solve_status\": \"not simulated\""), std::string::npos) << "figures of another design are not this one's";
  c->set_design(std::string(bits.begin(), bits.end()));
  EXPECT_EQ(w.Send(cleaned).error(), "");
  const std::string simulated = report(2);
  EXPECT_NE(simulated.find("\"density_ratio\": 2.5,"), std::string::npos) << simulated;
  EXPECT_NE(simulated.find("\"solve_status\": \"converged\""), std::string::npos) << simulated;
  EXPECT_NE(report(1).find("\"solve_status\": \"not simulated\""), std::string::npos) << "the worker simulated the last design only";

  ASSERT_TRUE(WaitFor([&] { return watch.job_events == 2; }, 10)) << "the watcher hears the phase turn";
  w.Send(Complete(lease.lease_id()));
  w.WaitEnded();
  watch.thread.join();
  EXPECT_EQ(Job(*s, job.id()).state(), v1::SUCCEEDED);
  EXPECT_EQ(Job(*s, job.id()).ended(), sentence);
  EXPECT_EQ(Job(*s, job.id()).phase(), v1::JOB_PHASE_UNSPECIFIED);
  // The watcher saw the job DESIGNING, then EVALUATING with its end (after the last iteration), then SUCCEEDED.
  std::vector<std::string> seen;
  for (const v1::WatchJobEvent& e : watch.events)
    seen.push_back(e.has_iteration() ? "iteration " + std::to_string(e.iteration().metrics().iteration())
                                     : v1::JobState_Name(e.job().state()) + " " + v1::JobPhase_Name(e.job().phase()));
  EXPECT_EQ(seen, (std::vector<std::string>{"RUNNING DESIGNING", "iteration 0", "iteration 1", "iteration 2", "RUNNING EVALUATING",
                                            "SUCCEEDED JOB_PHASE_UNSPECIFIED"}));
  for (const v1::WatchJobEvent& e : watch.events)
    if (e.has_job() && e.job().phase() == v1::EVALUATING) EXPECT_EQ(e.job().ended(), sentence);
}

// A worker's speed, measured before its first job, is the server's first machine factor: the scenes'
// predictions are this machine's before any job has finished; a second worker's does not replace it.
TEST(JobService, AWorkersMeasuredSpeedIsTheFactorOfTheFirstPredictions) {
  auto s = Open(Options(FreshDir("speed")));
  ASSERT_TRUE(s);
  v1::ListScenesResponse before;
  ASSERT_TRUE(s->ListScenes(&before).ok());
  EXPECT_EQ(before.machine_factor(), 1.0);
  EXPECT_EQ(before.machine_factor_jobs(), 0);
  auto lease_with_speed = [&](double predicted_s, double measured_s) {
    v1::LeaseJobRequest r;
    r.set_worker("w");
    r.set_wait_s(0);
    r.mutable_speed()->set_predicted_s(predicted_s);
    r.mutable_speed()->set_measured_s(measured_s);
    r.mutable_speed()->set_what("knee_flexion, iterations 0-1");
    v1::LeaseJobResponse out;
    EXPECT_TRUE(s->LeaseJob(kWorker, r, &out, [] { return false; }).ok());
  };
  lease_with_speed(1.25, 2.5);
  v1::ListScenesResponse after;
  ASSERT_TRUE(s->ListScenes(&after).ok());
  EXPECT_DOUBLE_EQ(after.machine_factor(), 2.0);
  EXPECT_EQ(after.machine_factor_jobs(), 1);
  for (int i = 0; i < after.scenes_size(); ++i)
    for (const auto& [preset, seconds] : after.scenes(i).predicted_job_s())
      EXPECT_GT(seconds, before.scenes(i).predicted_job_s().at(preset)) << after.scenes(i).name() << " " << preset;
  lease_with_speed(1.0, 5.0);
  ASSERT_TRUE(s->ListScenes(&after).ok());
  EXPECT_DOUBLE_EQ(after.machine_factor(), 2.0) << "the first measurement stands until jobs teach more";
}

// A finished job's design file moved away (a clean-up script) or damaged: every read of it names the
// job and what is wrong, never the server's own path, and a damaged file is not served.
TEST(JobService, AMissingOrDamagedDesignFileIsNamedOnEveryRead) {
  auto s = Open(Options(FreshDir("missing")));
  ASSERT_TRUE(s);
  v1::Job job;
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &job).ok());
  const v1::LeaseJobResponse lease = Lease(*s);
  FakeStream w(*s);
  w.Send(Start(lease.lease_id()));
  for (int k = 0; k < 3; ++k) w.Send(Report(lease.lease_id(), k));
  w.Send(Complete(lease.lease_id()));
  w.WaitEnded();
  const std::string path = Job(*s, job.id()).data_file();
  fs::rename(path, path + ".away");
  v1::GetIterationRequest r;
  r.set_id(job.id());
  r.set_iteration(1);
  v1::GetIterationResponse it;
  v1::Garment garment;
  std::string bytes;
  const std::string missing = "job " + std::to_string(job.id()) + "'s design file is missing from the server's data folder";
  for (const ServiceStatus& st : {s->GetIteration(kAlice, r, &it), s->GetGarment(kAlice, job.id(), &garment), s->GetDesignFile(kAlice, job.id(), &bytes)}) {
    EXPECT_EQ(st.code, ServiceCode::kNotFound) << st.message;
    EXPECT_NE(st.message.find(missing), std::string::npos) << st.message;
    EXPECT_EQ(st.message.find(path), std::string::npos) << "the server's own path: " << st.message;
  }
  // Back, with 64 bytes of iteration 1's positions inverted: named, not served.
  fs::rename(path + ".away", path);
  {
    Result<DesignFile> f = ReadDesignFile(path);
    ASSERT_TRUE(f.ok());
    hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    hid_t set = H5Dopen2(file, "/iterations/positions", H5P_DEFAULT);
    hsize_t offset[3] = {1, 0, 0};
    unsigned mask = 0;
    haddr_t addr = 0;
    hsize_t size = 0;
    H5Dget_chunk_info_by_coord(set, offset, &mask, &addr, &size);
    H5Dclose(set);
    H5Fclose(file);
    ASSERT_GT(size, 64u);
    std::fstream bytes_on_disk(path, std::ios::in | std::ios::out | std::ios::binary);
    std::string b(64, '\0');
    bytes_on_disk.seekg(addr + size / 2);
    bytes_on_disk.read(b.data(), 64);
    for (char& c : b) c = static_cast<char>(~c);
    bytes_on_disk.seekp(addr + size / 2);
    bytes_on_disk.write(b.data(), 64);
  }
  ServiceStatus st = s->GetIteration(kAlice, r, &it);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message.find("iteration 1 is damaged: /iterations/positions"), std::string::npos) << st.message;
  EXPECT_EQ(st.message.find(path), std::string::npos) << st.message;
  st = s->GetDesignFile(kAlice, job.id(), &bytes);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message.find("iteration 1 is damaged"), std::string::npos) << st.message;
  r.set_iteration(2);
  EXPECT_TRUE(s->GetIteration(kAlice, r, &it).ok()) << "an intact iteration of a damaged file is still served";
}

TEST(JobService, GarmentDesignFileEnergyPerAreaAndPlyComeFromTheStoredJob) {
  auto s = Open(Options(FreshDir("results")));
  ASSERT_TRUE(s);
  v1::Job job;
  ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &job).ok());
  const std::string id = std::to_string(job.id());
  v1::Garment garment;
  ServiceStatus st = s->GetGarment(kAlice, job.id(), &garment);
  EXPECT_EQ(st.code, ServiceCode::kNotFound);
  EXPECT_EQ(st.message, "job " + id + " has no garment yet (it has no iteration; watch it until the first arrives)");
  EXPECT_EQ(s->GetGarment(kBob, job.id(), &garment).message, "job " + id + " does not exist");
  const v1::LeaseJobResponse lease = Lease(*s);
  FakeStream w(*s);
  w.Send(Start(lease.lease_id()));
  for (int k = 0; k < 3; ++k) w.Send(Report(lease.lease_id(), k));
  ASSERT_TRUE(s->GetGarment(kAlice, job.id(), &garment).ok());
  EXPECT_EQ(garment.faces_size(), 3 * Garment().garment.faces.rows());
  std::string bytes;
  st = s->GetDesignFile(kAlice, job.id(), &bytes);
  EXPECT_EQ(st.code, ServiceCode::kFailedPrecondition);
  EXPECT_NE(st.message.find("job " + id + " is RUNNING: its design file is still being written"), std::string::npos) << st.message;
  w.Send(Complete(lease.lease_id()));
  w.WaitEnded();
  ASSERT_TRUE(s->GetDesignFile(kAlice, job.id(), &bytes).ok());
  EXPECT_EQ(bytes.substr(0, 4), "\x89HDF");
  EXPECT_EQ(bytes.size(), fs::file_size(Job(*s, job.id()).data_file()));

  // Energy per area: each face's density times its material's thickness.
  v1::GetIterationRequest r;
  r.set_id(job.id());
  r.set_iteration(2);
  r.set_with_garment(true);
  v1::GetIterationResponse it;
  ASSERT_TRUE(s->GetIteration(kAlice, r, &it).ok());
  std::vector<float> e;
  ASSERT_TRUE(EnergyPerArea(it.garment(), it.record().design(), it.record().energy_density_pa(), &e).ok());
  const BesoIteration want = Iteration(2);
  ASSERT_EQ(e.size(), want.design.size());
  for (size_t f = 0; f < e.size(); ++f)
    EXPECT_EQ(e[f], static_cast<float>(want.energy_density_Pa[f] * (want.design[f] ? 2e-3 : 1e-3))) << "face " << f;
  v1::Garment old = it.garment();
  old.set_cloth_thickness_m(0);
  EXPECT_EQ(EnergyPerArea(old, it.record().design(), it.record().energy_density_pa(), &e).code, ServiceCode::kFailedPrecondition);
  EXPECT_EQ(EnergyPerArea(it.garment(), "\1", it.record().energy_density_pa(), &e).code, ServiceCode::kInternal);

  // The PLY: the iteration's positions and faces.
  std::string ply;
  ASSERT_TRUE(IterationPly(it, "job.ply", &ply).ok());
  Result<TriMesh> mesh = ParseMesh(ply, "job.ply");
  ASSERT_TRUE(mesh.ok()) << mesh.message();
  EXPECT_EQ(mesh->vertices, want.positions);
  EXPECT_EQ(mesh->faces, Garment().garment.faces);
}

// A job of two motions (knee_brace's roles), its iterations reported with both: after the service is
// reopened (nothing held in memory), the per-motion records the store gives to a resuming worker, a
// watcher, the job's last metrics and GetIteration are those of the job's design file.
TEST(JobService, ATwoMotionJobsRecordsAreTheDesignFilesAfterAReopen) {
  const JobServiceOptions o = Options(FreshDir("motions"));
  DesignFileHeader header = Garment();
  header.motions = {{.name = "hyperextend", .role = MotionRole::kResist, .weight = 1.0},
                    {.name = "flex", .role = MotionRole::kAllow, .weight = 0.5}};
  auto with_motions = [&](int k) {
    BesoIteration it = Iteration(k);
    for (size_t j = 0; j < header.motions.size(); ++j) {
      MotionMetrics m = header.motions[j];
      m.energy_J = 1e-3 * (k + 1) + static_cast<double>(j);
      m.reinforced_energy_J = 3e-4 / (k + 1) + static_cast<double>(j);
      m.reinforced_density_J_per_m2 = 0.02 * (k + 2) + 0.5 * static_cast<double>(j);
      m.density_ratio = 1 + 0.125 * k - 0.25 * static_cast<double>(j);
      m.simulation_s = 0.5 + k + static_cast<double>(j);
      m.solver_iterations = 4 + k + 5 * static_cast<int>(j);
      it.motions.push_back(m);
    }
    return it;
  };
  int64_t id = 0;
  {
    auto s = Open(o);
    ASSERT_TRUE(s);
    v1::Job job;
    ASSERT_TRUE(s->CreateJob(kAlice, SleeveJob(), &job).ok());
    id = job.id();
    const v1::LeaseJobResponse lease = Lease(*s);
    FakeStream w(*s);
    v1::WorkerMessage start = Start(lease.lease_id());
    *start.mutable_start()->mutable_garment() = GarmentToProto(header);
    EXPECT_EQ(w.Send(start).error(), "");
    for (int k = 0; k < 3; ++k) {
      v1::WorkerMessage report;
      report.set_lease_id(lease.lease_id());
      *report.mutable_iteration() = RecordToProto(with_motions(k));
      EXPECT_EQ(w.Send(report).acknowledged_iterations(), k + 1);
    }
  }
  auto s = Open(o);
  ASSERT_TRUE(s);
  Result<DesignFile> file = ReadDesignFile(Job(*s, id).data_file());
  ASSERT_TRUE(file.ok()) << file.message();
  ASSERT_EQ(file->iterations.size(), 3u);
  for (int k = 0; k < 3; ++k) ASSERT_EQ(file->iterations[k].motions, with_motions(k).motions) << "the design file's iteration " << k;
  auto motions_of = [](const v1::IterationMetrics& m) { return MetricsFromProto(m).motions; };
  EXPECT_EQ(motions_of(Job(*s, id).last()), file->iterations[2].motions);
  v1::GetIterationRequest r;
  r.set_id(id);
  r.set_iteration(1);
  v1::GetIterationResponse it;
  ASSERT_TRUE(s->GetIteration(kAlice, r, &it).ok());
  EXPECT_EQ(motions_of(it.record().metrics()), file->iterations[1].motions);
  {
    Watch watch(*s, id, 0);
    ASSERT_TRUE(WaitFor([&] { return watch.Iterations().size() == 3; }, 10));
    watch.stop = true;
    watch.thread.join();
    for (const v1::WatchJobEvent& e : watch.events)
      if (e.has_iteration())
        EXPECT_EQ(motions_of(e.iteration().metrics()), file->iterations[e.iteration().metrics().iteration()].motions) << "watched iteration";
  }
  const v1::LeaseJobResponse resumed = Lease(*s);
  ASSERT_TRUE(resumed.leased());
  ASSERT_EQ(resumed.history_size(), 3);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(motions_of(resumed.history(k)), file->iterations[k].motions) << "the resumed worker's history, iteration " << k;
}

}  // namespace
}  // namespace kgd::server
