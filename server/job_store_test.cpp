// The job store: schema versions, the lease life cycle (lease, renew, expire, retry limit), cancel,
// iterations that are stored in order, once, by the lease holder only, with their motions, and jobs
// that resume only on workers of the kernel level their iterations ran at.
#include "server/job_store.h"

#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace kgd::server {
namespace {

std::string FreshPath(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("kgd_job_store_test_" + name + ".sqlite");
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(p.string() + suffix);
  return p.string();
}

const std::string kV3 = "x86-64-v3", kV1 = "x86-64";

// A moment at which the wall clock and the lease clock read the same.
StoreTime At(double t) { return {t, t}; }

v1::JobSpec Spec() {
  v1::JobSpec s;
  s.set_builtin_scene("sleeve_on_limb");
  return s;
}

v1::IterationMetrics Metrics(int k) {
  v1::IterationMetrics m;
  m.set_iteration(k);
  m.set_energy_j(1.0 / (k + 3));
  m.set_density_ratio(1 + 0.1 * k);
  m.set_solve_status("converged");
  m.set_solver_iterations(k + 2);
  return m;
}

TEST(JobStore, MigratesAFreshDatabaseAndRefusesANewerOne) {
  const std::string path = FreshPath("version");
  ASSERT_TRUE(JobStore::Open(path).ok());
  ASSERT_TRUE(JobStore::Open(path).ok());  // reopening an up-to-date database changes nothing
  {
    sqlite3* db = nullptr;
    sqlite3_open(path.c_str(), &db);
    sqlite3_exec(db, ("PRAGMA user_version=" + std::to_string(kSchemaVersion + 1)).c_str(), nullptr, nullptr, nullptr);
    sqlite3_close(db);
  }
  Result<std::unique_ptr<JobStore>> newer = JobStore::Open(path);
  ASSERT_FALSE(newer.ok());
  EXPECT_NE(newer.message().find("newer kgd"), std::string::npos) << newer.message();
  std::ofstream(FreshPath("garbage")) << "not a database at all, just text that is long enough to be read";
  Result<std::unique_ptr<JobStore>> garbage = JobStore::Open((std::filesystem::temp_directory_path() / "kgd_job_store_test_garbage.sqlite").string());
  EXPECT_FALSE(garbage.ok());
}

// A database damaged on disk (bytes of a page overwritten) is refused at open, named, and not written to.
TEST(JobStore, ADamagedDatabaseIsRefusedNamingIt) {
  const std::string path = FreshPath("damaged");
  {
    Result<std::unique_ptr<JobStore>> store = JobStore::Open(path);
    ASSERT_TRUE(store.ok());
    for (int i = 0; i < 400; ++i) ASSERT_TRUE((*store)->CreateJob(Spec(), 3, 100.0 + i).ok());
  }
  {
    sqlite3* db = nullptr;  // the log folded into the database file, so that the damage lands in the jobs' pages
    sqlite3_open(path.c_str(), &db);
    sqlite3_exec(db, "PRAGMA wal_checkpoint(TRUNCATE); PRAGMA journal_mode=DELETE;", nullptr, nullptr, nullptr);
    sqlite3_close(db);
  }
  const auto size = std::filesystem::file_size(path);
  ASSERT_GT(size, 8u * 4096);
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    const std::string junk(2048, '\x5a');
    for (uintmax_t page = 2; page * 4096 + 2048 < size; page += 3) {
      f.seekp(static_cast<std::streamoff>(page * 4096 + 8));
      f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
    }
  }
  const auto before = std::filesystem::last_write_time(path);
  Result<std::unique_ptr<JobStore>> damaged = JobStore::Open(path);
  ASSERT_FALSE(damaged.ok());
  EXPECT_NE(damaged.message().find(path), std::string::npos) << damaged.message();
  EXPECT_TRUE(damaged.message().find("damaged") != std::string::npos || damaged.message().find("malformed") != std::string::npos)
      << damaged.message();
  EXPECT_EQ(std::filesystem::last_write_time(path), before);
}

// A version-2 database (iterations without the solve profile) migrates: its rows read the profile as 0,
// and new rows keep theirs.
TEST(JobStore, AVersion2DatabaseGainsTheSolveProfileColumns) {
  const std::string path = FreshPath("v2");
  int64_t job = 0;
  std::string lease;
  {
    auto store = std::move(JobStore::Open(path)).value();
    job = *store->CreateJob(Spec(), 3, 100.0);
    lease = (**store->LeaseNext("w1", kV3, At(101.0), 1000.0)).lease_id;
    ASSERT_TRUE(store->AppendIteration(job, lease, Metrics(0), std::string(3, '\1')).ok());
  }
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    for (const char* c : {"assembly_s", "factorization_s", "linear_solve_s", "line_search_s", "body_field_query_s", "membrane_s",
                          "fold_barrier_s", "attachment_s", "contact_s", "friction_s", "bending_s"})
      ASSERT_EQ(sqlite3_exec(db, (std::string("ALTER TABLE iterations DROP COLUMN ") + c).c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << c;
    ASSERT_EQ(sqlite3_exec(db, "DROP TABLE iteration_motions; ALTER TABLE jobs DROP COLUMN ended; ALTER TABLE jobs DROP COLUMN cleaned; ALTER TABLE jobs DROP COLUMN kernels; PRAGMA user_version=2",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  auto store = std::move(JobStore::Open(path)).value();
  Result<std::optional<v1::IterationRecord>> old = store->Iteration(job, 0);
  ASSERT_TRUE(old.ok() && *old) << old.message();
  EXPECT_EQ((*old)->metrics().membrane_s(), 0.0);
  EXPECT_EQ((*old)->metrics().energy_j(), Metrics(0).energy_j());
  v1::IterationMetrics m = Metrics(1);
  m.set_membrane_s(0.25);
  m.set_factorization_s(0.5);
  ASSERT_TRUE(store->AppendIteration(job, lease, m, std::string(3, '\1')).ok());
  Result<std::optional<v1::IterationRecord>> now = store->Iteration(job, 1);
  ASSERT_TRUE(now.ok() && *now);
  EXPECT_EQ((*now)->metrics().membrane_s(), 0.25);
  EXPECT_EQ((*now)->metrics().factorization_s(), 0.5);
}

// Iteration k with two motions, every figure of each its own value.
v1::IterationMetrics WithMotions(int k) {
  v1::IterationMetrics m = Metrics(k);
  for (int j = 0; j < 2; ++j) {
    v1::MotionMetrics* mm = m.add_motions();
    mm->set_name(j == 0 ? "hyperextend" : "flex");
    mm->set_role(j == 0 ? "resist" : "allow");
    mm->set_weight(j == 0 ? 1.0 : 0.25 + k);
    mm->set_energy_j(1e-3 * (k + 1) + j);
    mm->set_reinforced_energy_j(2e-4 * (k + 1) + j);
    mm->set_reinforced_density_j_per_m2(0.125 / (k + 1) + j);
    mm->set_density_ratio(1 + 0.01 * k + 0.5 * j);
    mm->set_simulation_s(0.75 + k + j);
    mm->set_solver_iterations(7 + k + 3 * j);
  }
  return m;
}

bool Same(const google::protobuf::Message& a, const google::protobuf::Message& b) {
  return google::protobuf::util::MessageDifferencer::Equals(a, b);
}

// Each iteration's motions come back from every query (metrics, the iteration, the job's last), after
// a truncation too; a version-3 database (no motion table) opens, its iterations without motions.
TEST(JobStore, EveryIterationsMotionsRoundTripAndAVersion3DatabaseGainsTheirTable) {
  const std::string path = FreshPath("v3");
  int64_t job = 0;
  std::string lease;
  {
    auto store = std::move(JobStore::Open(path)).value();
    job = *store->CreateJob(Spec(), 3, 100.0);
    lease = (**store->LeaseNext("w1", kV3, At(101.0), 1000.0)).lease_id;
    ASSERT_TRUE(store->AppendIteration(job, lease, Metrics(0), std::string(3, '\1')).ok());
  }
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "DROP TABLE iteration_motions; ALTER TABLE jobs DROP COLUMN ended; ALTER TABLE jobs DROP COLUMN cleaned; ALTER TABLE jobs DROP COLUMN kernels; PRAGMA user_version=3",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  Result<std::unique_ptr<JobStore>> opened = JobStore::Open(path);
  ASSERT_TRUE(opened.ok()) << opened.message();
  auto store = std::move(opened).value();
  Result<std::optional<v1::IterationRecord>> old = store->Iteration(job, 0);
  ASSERT_TRUE(old.ok() && *old) << old.message();
  EXPECT_TRUE(Same((*old)->metrics(), Metrics(0)));  // no motions
  for (int k = 1; k <= 2; ++k) ASSERT_TRUE(store->AppendIteration(job, lease, WithMotions(k), std::string(3, '\1')).ok()) << k;
  Result<std::vector<v1::IterationMetrics>> all = store->Metrics(job, 0, 3);
  ASSERT_TRUE(all.ok()) << all.message();
  ASSERT_EQ(all->size(), 3u);
  EXPECT_EQ((*all)[0].motions_size(), 0);
  for (int k = 1; k <= 2; ++k) EXPECT_TRUE(Same((*all)[k], WithMotions(k))) << (*all)[k].DebugString();
  Result<std::vector<v1::IterationMetrics>> one = store->Metrics(job, 2, 3);  // a range that starts past 0
  ASSERT_TRUE(one.ok() && one->size() == 1u);
  EXPECT_TRUE(Same(one->front(), WithMotions(2)));
  EXPECT_TRUE(Same((*store->Iteration(job, 1))->metrics(), WithMotions(1)));
  EXPECT_TRUE(Same((**store->GetJob(job)).last(), WithMotions(2)));
  // Truncated and stored again: iteration 2's new motions, none of the old.
  ASSERT_TRUE(store->TruncateIterations(job, 2).ok());
  v1::IterationMetrics again = WithMotions(2);
  again.mutable_motions()->RemoveLast();
  again.mutable_motions(0)->set_density_ratio(0.5);
  ASSERT_TRUE(store->AppendIteration(job, lease, again, std::string(3, '\1')).ok());
  EXPECT_TRUE(Same((**store->GetJob(job)).last(), again)) << (**store->GetJob(job)).last().DebugString();
  EXPECT_EQ(store->IntegrityCheck(), "ok");
}

// How the design loop ended and the cleaned final design: stored by the lease holder only, read back
// as they were; the running job's phase is DESIGNING until the end is known, then EVALUATING; a
// version-4 database (without the columns) opens with neither.
TEST(JobStore, TheEndAndTheCleanedDesignRoundTripForTheHolderAndAVersion4DatabaseGainsThem) {
  const std::string path = FreshPath("v4");
  int64_t job = 0;
  {
    auto store = std::move(JobStore::Open(path)).value();
    job = *store->CreateJob(Spec(), 3, 100.0);
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "ALTER TABLE jobs DROP COLUMN ended; ALTER TABLE jobs DROP COLUMN cleaned; ALTER TABLE jobs DROP COLUMN kernels; PRAGMA user_version=4", nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  Result<std::unique_ptr<JobStore>> opened = JobStore::Open(path);
  ASSERT_TRUE(opened.ok()) << opened.message();
  auto store = std::move(opened).value();
  EXPECT_EQ((**store->GetJob(job)).ended(), "");
  EXPECT_EQ((**store->GetJob(job)).phase(), v1::JOB_PHASE_UNSPECIFIED) << "a queued job has no phase";
  EXPECT_FALSE(*store->Cleaned(job));
  const std::string lease = (**store->LeaseNext("w1", kV3, At(101.0), 1000.0)).lease_id;
  EXPECT_EQ((**store->GetJob(job)).phase(), v1::DESIGNING);
  EXPECT_FALSE(store->Progress(job)->ended);
  const std::string ended = "stopped at the iteration limit (5) at 92.7 % of the garment, above the budget of 10 %";
  EXPECT_FALSE(store->SetEnded(job, "another lease", ended).ok());
  EXPECT_EQ((**store->GetJob(job)).ended(), "");
  ASSERT_TRUE(store->SetEnded(job, lease, ended).ok());
  EXPECT_EQ((**store->GetJob(job)).ended(), ended);
  EXPECT_EQ((**store->GetJob(job)).phase(), v1::EVALUATING);
  EXPECT_TRUE(store->Progress(job)->ended);
  v1::CleanedDesign cleaned;
  cleaned.set_iteration(5);
  cleaned.set_min_feature_m(0.003);
  cleaned.set_design(std::string("\1\0\1", 3));
  cleaned.set_area_fraction(0.125);
  cleaned.set_density_ratio(2.5);
  cleaned.set_solve_status("converged");
  EXPECT_FALSE(store->SetCleaned(job, "another lease", cleaned).ok());
  ASSERT_TRUE(store->SetCleaned(job, lease, cleaned).ok());
  ASSERT_TRUE(store->EndLease(job, lease, v1::SUCCEEDED, "", 102.0).ok());
  const v1::Job done = **store->GetJob(job);
  EXPECT_EQ(done.ended(), ended) << "the end stays with the finished job";
  EXPECT_EQ(done.phase(), v1::JOB_PHASE_UNSPECIFIED);
  Result<std::optional<v1::CleanedDesign>> back = store->Cleaned(job);
  ASSERT_TRUE(back.ok() && *back) << back.message();
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(**back, cleaned)) << (*back)->DebugString();
}

TEST(JobStore, LeasesRenewsAndStoresIterationsInOrderForTheHolderOnly) {
  auto store = std::move(JobStore::Open(FreshPath("lease"))).value();
  const int64_t a = *store->CreateJob(Spec(), 3, 100.0), b = *store->CreateJob(Spec(), 3, 101.0);
  Result<std::optional<Lease>> la = store->LeaseNext("w1", kV3, At(102.0), 10.0);
  ASSERT_TRUE(la.ok() && *la);
  EXPECT_EQ((*la)->job_id, a);  // oldest first
  EXPECT_EQ((*la)->attempt, 1);
  EXPECT_EQ((**store->GetJob(a)).state(), v1::RUNNING);
  EXPECT_EQ((**store->GetJob(a)).worker(), "w1");
  const std::string lease = (*la)->lease_id;
  ASSERT_TRUE(store->SetKernels(a, lease, kV3).ok());

  EXPECT_TRUE(store->AppendIteration(a, lease, Metrics(0), std::string(5, '\1')).ok());
  EXPECT_FALSE(store->AppendIteration(a, lease, Metrics(0), std::string(5, '\1')).ok());  // no duplicate
  EXPECT_FALSE(store->AppendIteration(a, lease, Metrics(2), std::string(5, '\1')).ok());  // no gap
  EXPECT_FALSE(store->AppendIteration(a, "someone-else", Metrics(1), std::string(5, '\1')).ok());
  EXPECT_TRUE(store->AppendIteration(a, lease, Metrics(1), std::string(5, '\0')).ok());
  const v1::Job job = **store->GetJob(a);
  EXPECT_EQ(job.iterations(), 2);
  EXPECT_EQ(job.last().iteration(), 1);
  EXPECT_EQ(job.last().energy_j(), Metrics(1).energy_j());  // every metric column round-trips
  EXPECT_EQ(job.last().solver_iterations(), 3);
  EXPECT_EQ(job.last().solve_status(), "converged");
  EXPECT_EQ((*store->Iteration(a, 1))->design(), std::string(5, '\0'));
  EXPECT_FALSE(*store->Iteration(a, 2));

  // Renewed leases live on; expired ones queue the job again, and it resumes where it was.
  EXPECT_TRUE(*store->Renew(a, lease, 110.0, 10.0));
  EXPECT_TRUE(store->ExpireLeases(At(115.0)).empty());
  EXPECT_EQ(store->ExpireLeases(At(121.0)), std::vector<int64_t>{a});
  EXPECT_EQ((**store->GetJob(a)).state(), v1::QUEUED);
  EXPECT_FALSE(store->AppendIteration(a, lease, Metrics(2), "x").ok());  // the old holder is out
  Result<std::optional<Lease>> again = store->LeaseNext("w2", kV3, At(122.0), 10.0);
  EXPECT_EQ((*again)->job_id, a);
  EXPECT_EQ((*again)->attempt, 2);
  EXPECT_EQ((*again)->iterations, 2);
  EXPECT_EQ(*store->EndLease(a, (*again)->lease_id, v1::SUCCEEDED, "", 130.0), v1::SUCCEEDED);
  EXPECT_EQ((*store->LeaseNext("w2", kV3, At(131.0), 10.0))->job_id, b);
  EXPECT_EQ(store->IntegrityCheck(), "ok");
}

// A full disk (a small tmpfs; mounting needs root, skipped otherwise): a write that fails there fails
// as a value naming it, leaves the store as it was (the failed commit rolled back, no transaction left
// open), and the same write succeeds once space is freed.
// A lease's deadline is kept on the lease clock: a wall clock stepped an hour forward expires nothing,
// one stepped an hour back keeps nothing longer, and the job's update time is the wall clock's.
TEST(JobStore, ALeaseExpiresOnTheLeaseClockWhateverTheWallClockDoes) {
  auto store = std::move(JobStore::Open(FreshPath("lease_clock"))).value();
  const double wall = 1.8e9;
  const int64_t a = *store->CreateJob(Spec(), 5, wall);
  const Lease la = **store->LeaseNext("w1", kV3, StoreTime{wall, 100.0}, 10.0);
  EXPECT_EQ((**store->GetJob(a)).update_time_s(), wall);
  EXPECT_TRUE(store->ExpireLeases(StoreTime{wall + 3600, 101.0}).empty()) << "an hour forward on the wall";
  EXPECT_TRUE(*store->Renew(a, la.lease_id, 105.0, 10.0));
  EXPECT_TRUE(store->ExpireLeases(StoreTime{wall - 3600, 114.0}).empty());
  EXPECT_EQ(store->ExpireLeases(StoreTime{wall - 3600, 116.0}), std::vector<int64_t>{a}) << "an hour back on the wall";
  const v1::Job expired = **store->GetJob(a);
  EXPECT_EQ(expired.state(), v1::QUEUED);
  EXPECT_EQ(expired.update_time_s(), wall - 3600);
}

TEST(JobStore, AFullDiskFailsAWriteWhichRollsBackAndSucceedsOnceFreed) {
  if (geteuid() != 0) GTEST_SKIP() << "mounting a small tmpfs needs root";
  const std::filesystem::path disk = std::filesystem::temp_directory_path() / ("kgd_job_store_test_disk_" + std::to_string(getpid()));
  std::filesystem::create_directories(disk);
  if (std::system(("mount -t tmpfs -o size=2m kgd-job-store-test " + disk.string()).c_str()) != 0)
    GTEST_SKIP() << "cannot mount a tmpfs at " << disk;
  struct Unmount {
    std::filesystem::path disk;
    ~Unmount() {
      std::system(("umount " + disk.string()).c_str());
      std::filesystem::remove_all(disk);
    }
  } unmount{disk};
  auto store = std::move(JobStore::Open((disk / "kgd.sqlite").string())).value();
  const int64_t a = *store->CreateJob(Spec(), 3, 100.0);
  Result<std::optional<Lease>> la = store->LeaseNext("w1", kV3, At(101.0), 1e6);
  ASSERT_TRUE(la.ok() && *la);
  const std::string lease = (*la)->lease_id;
  ASSERT_TRUE(store->AppendIteration(a, lease, Metrics(0), std::string(5, '\1')).ok());
  {
    std::ofstream filler(disk / "filler", std::ios::binary);
    const std::string block(4096, 'x');
    while (filler.write(block.data(), block.size()) && filler.flush()) {
    }
  }
  // Designs large enough to need new pages: the disk is full before the write can succeed.
  int k = 1;
  Status failed = Status::Ok();
  for (; k < 200 && failed.ok(); ++k) failed = store->AppendIteration(a, lease, Metrics(k), std::string(64 << 10, '\1'));
  ASSERT_FALSE(failed.ok()) << "the disk never filled";
  const int stored = k - 1;  // iterations 0..stored-1 were stored; `stored` failed
  EXPECT_NE(failed.message().find("full"), std::string::npos) << failed.message();
  EXPECT_EQ((**store->GetJob(a)).iterations(), stored);
  EXPECT_FALSE(*store->Iteration(a, stored));
  // Reads and other transactions go on: none is left open by the failed commit.
  EXPECT_EQ((**store->GetJob(a)).state(), v1::RUNNING);

  std::filesystem::remove(disk / "filler");
  Status again = store->AppendIteration(a, lease, Metrics(stored), std::string(64 << 10, '\1'));
  EXPECT_TRUE(again.ok()) << again.message();
  EXPECT_EQ((**store->GetJob(a)).iterations(), stored + 1);
  EXPECT_TRUE(*store->Renew(a, lease, 102.0, 1e6));
  EXPECT_EQ(*store->EndLease(a, lease, v1::SUCCEEDED, "", 103.0), v1::SUCCEEDED);
  EXPECT_EQ(store->IntegrityCheck(), "ok");
}

// A job's stored iterations resume only at the kernel level they ran at (designs differ between
// levels): released or expired, it is not leased to a worker of another level nor to one that does not
// say its level, which take newer jobs instead; a started job without iterations goes to any. The level
// is set by the lease holder only.
TEST(JobStore, AJobWithIterationsIsLeasedOnlyToAWorkerOfItsKernels) {
  auto store = std::move(JobStore::Open(FreshPath("kernels"))).value();
  const int64_t a = *store->CreateJob(Spec(), 5, 100.0), b = *store->CreateJob(Spec(), 5, 101.0);
  const Lease la = **store->LeaseNext("v3", kV3, At(102.0), 10.0);
  ASSERT_EQ(la.job_id, a);
  EXPECT_FALSE(store->SetKernels(a, "another lease", kV1).ok());
  ASSERT_TRUE(store->SetKernels(a, la.lease_id, kV3).ok());
  ASSERT_TRUE(store->AppendIteration(a, la.lease_id, Metrics(0), std::string(3, '\1')).ok());
  EXPECT_EQ((**store->GetJob(a)).kernels(), kV3);
  ASSERT_EQ(*store->EndLease(a, la.lease_id, v1::QUEUED, "", 103.0), v1::QUEUED);  // released (a drain)

  const Lease lb = **store->LeaseNext("v1", kV1, At(104.0), 10.0);
  EXPECT_EQ(lb.job_id, b) << "a new job goes to any level, past the older one waiting";
  ASSERT_TRUE(store->SetKernels(b, lb.lease_id, kV1).ok());
  EXPECT_FALSE(*store->LeaseNext("v1", kV1, At(105.0), 10.0)) << "job a's iteration ran at x86-64-v3";
  EXPECT_FALSE(*store->LeaseNext("old", "", At(105.0), 10.0)) << "a worker that does not say its level resumes nothing";
  EXPECT_EQ((**store->GetJob(a)).state(), v1::QUEUED);
  const Lease again = **store->LeaseNext("v3", kV3, At(106.0), 10.0);
  EXPECT_EQ(again.job_id, a);
  EXPECT_EQ(again.iterations, 1);

  // Both leases expire: a waits again for x86-64-v3; b, started without an iteration, goes to any.
  auto expired = [&](double now) {
    std::vector<int64_t> ids = store->ExpireLeases(At(now));
    std::sort(ids.begin(), ids.end());
    return ids;
  };
  EXPECT_EQ(expired(200.0), (std::vector<int64_t>{a, b}));
  const Lease lb2 = **store->LeaseNext("v3", kV3, At(201.0), 10.0);
  EXPECT_EQ(lb2.job_id, a) << "the oldest it may run";
  const Lease lb3 = **store->LeaseNext("v3", kV3, At(201.0), 10.0);
  EXPECT_EQ(lb3.job_id, b) << "job b stored no iteration at x86-64";
  EXPECT_EQ(expired(300.0), (std::vector<int64_t>{a, b}));
  EXPECT_EQ((**store->LeaseNext("v1", kV1, At(301.0), 10.0)).job_id, b);
  EXPECT_FALSE(*store->LeaseNext("v1", kV1, At(301.0), 10.0));
  const int64_t c = *store->CreateJob(Spec(), 5, 302.0);
  EXPECT_EQ((**store->LeaseNext("old", "", At(303.0), 10.0)).job_id, c) << "a new job goes to a worker that does not say its level";
  EXPECT_EQ((**store->LeaseNext("v3", kV3, At(304.0), 10.0)).job_id, a);
  // Iterations of no recorded level resume nowhere, not even on a worker that does not say its own.
  const int64_t d = *store->CreateJob(Spec(), 5, 305.0);
  const Lease ld = **store->LeaseNext("old", "", At(306.0), 10.0);
  ASSERT_EQ(ld.job_id, d);
  ASSERT_TRUE(store->AppendIteration(d, ld.lease_id, Metrics(0), std::string(3, '\1')).ok());
  ASSERT_EQ(*store->EndLease(d, ld.lease_id, v1::QUEUED, "", 307.0), v1::QUEUED);
  EXPECT_FALSE(*store->LeaseNext("old", "", At(308.0), 10.0));
}

// A version-5 database (no kernels column) migrates: a job that stored iterations then ran them at the
// one level kgd pinned then, x86-64, and resumes only there; one without iterations has no level.
TEST(JobStore, AVersion5DatabasesStartedJobsReadX8664) {
  const std::string path = FreshPath("v5");
  int64_t started = 0, queued = 0;
  {
    auto store = std::move(JobStore::Open(path)).value();
    started = *store->CreateJob(Spec(), 3, 100.0);
    queued = *store->CreateJob(Spec(), 3, 100.5);
    const Lease l = **store->LeaseNext("w1", kV3, At(101.0), 1000.0);
    ASSERT_TRUE(store->AppendIteration(started, l.lease_id, Metrics(0), std::string(3, '\1')).ok());
    ASSERT_TRUE(store->EndLease(started, l.lease_id, v1::QUEUED, "", 102.0).ok());
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "ALTER TABLE jobs DROP COLUMN kernels; PRAGMA user_version=5", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  Result<std::unique_ptr<JobStore>> opened = JobStore::Open(path);
  ASSERT_TRUE(opened.ok()) << opened.message();
  auto store = std::move(opened).value();
  EXPECT_EQ((**store->GetJob(started)).kernels(), kV1);
  EXPECT_EQ((**store->GetJob(queued)).kernels(), "");
  EXPECT_EQ((**store->LeaseNext("v3", kV3, At(103.0), 10.0)).job_id, queued);
  EXPECT_FALSE(*store->LeaseNext("v3", kV3, At(103.0), 10.0));
  EXPECT_EQ((**store->LeaseNext("v1", kV1, At(104.0), 10.0)).job_id, started);
}

TEST(JobStore, GivesUpAfterMaxAttemptsAndCancelsQueuedAndRunningJobs) {
  auto store = std::move(JobStore::Open(FreshPath("attempts"))).value();
  const int64_t a = *store->CreateJob(Spec(), 2, 0.0);
  for (int attempt = 1; attempt <= 2; ++attempt) {
    Result<std::optional<Lease>> l = store->LeaseNext("w", kV3, At(10.0 * attempt), 1.0);
    ASSERT_TRUE(*l);
    store->ExpireLeases(At(10.0 * attempt + 2));
  }
  const v1::Job failed = **store->GetJob(a);
  EXPECT_EQ(failed.state(), v1::FAILED);
  EXPECT_NE(failed.failure().find("gave up after 2 attempts"), std::string::npos) << failed.failure();

  const int64_t queued = *store->CreateJob(Spec(), 2, 0.0);
  EXPECT_EQ((**store->Cancel(queued, 1.0)).state(), v1::CANCELLED);
  const int64_t running = *store->CreateJob(Spec(), 2, 0.0);
  Result<std::optional<Lease>> l = store->LeaseNext("w", kV3, At(1.0), 100.0);
  ASSERT_EQ((*l)->job_id, running);
  const v1::Job asked = **store->Cancel(running, 2.0);
  EXPECT_EQ(asked.state(), v1::RUNNING);  // until the worker stops
  EXPECT_TRUE(asked.cancel_requested());
  EXPECT_EQ(*store->EndLease(running, (*l)->lease_id, v1::QUEUED, "", 3.0), v1::CANCELLED);
  EXPECT_FALSE(*store->GetJob(12345));
  EXPECT_FALSE(*store->Cancel(12345, 1.0));
}

TEST(JobStore, ListsNewestFirstInPagesWithAStateFilter) {
  auto store = std::move(JobStore::Open(FreshPath("list"))).value();
  for (int i = 0; i < 5; ++i) store->CreateJob(Spec(), 2, i);
  store->Cancel(2, 10.0);
  std::vector<v1::Job> page = *store->ListJobs(v1::JOB_STATE_UNSPECIFIED, 0, 3);
  ASSERT_EQ(page.size(), 3u);
  EXPECT_EQ(page[0].id(), 5);
  EXPECT_EQ(page[2].id(), 3);
  page = *store->ListJobs(v1::JOB_STATE_UNSPECIFIED, page.back().id(), 3);
  ASSERT_EQ(page.size(), 2u);
  EXPECT_EQ(page[1].id(), 1);
  page = *store->ListJobs(v1::CANCELLED, 0, 10);
  ASSERT_EQ(page.size(), 1u);
  EXPECT_EQ(page[0].id(), 2);
}

}  // namespace
}  // namespace kgd::server
