// The job store: the service's queue and all its state in one SQLite database (WAL mode).
//
// Tables (schema version in PRAGMA user_version; Open migrates older databases and refuses newer):
//   jobs        one row per job: spec (kgd.v1.JobSpec), state, attempts, the lease (id, worker,
//               expiry), the number of stored iterations, failure reason, cancel request, how the
//               design loop ended (Job.ended), the worker's cleaned final design (kgd.v1.CleanedDesign)
//               and the kernels its iterations are computed with (Job.kernels)
//   iterations  one row per (job, iteration): every IterationMetrics field as a column of the same
//               name, and the design (one byte per face)
//   iteration_motions  one row per (job, iteration, motion): every MotionMetrics field as a column of
//               the same name (IterationMetrics.motions, in the scene's order; none for iterations
//               stored before the table, which read with no motions)
// An iteration row is the acknowledgement: the server inserts it after the job's HDF5 file holds the
// iteration, and a job's rows are always 0..iterations-1.
//
// Thread-safe: one connection behind a mutex. Times are Unix seconds, but for lease deadlines
// (`lease_expire_s`): seconds of the server's monotonic clock (StoreTime).
#pragma once

#include <sqlite3.h>

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/util/status.h"
#include "kgd/v1/kgd.pb.h"

namespace kgd::server {

inline constexpr int kSchemaVersion = 6;

// A moment on the store's two clocks. `wall_s`: Unix seconds, the times users see (a job's create and
// update times). `lease_s`: seconds of a monotonic clock (CLOCK_MONOTONIC), which a step of the wall
// clock (settimeofday, an NTP step) does not move: lease deadlines are kept on it. They mean nothing to
// another process or after a reboot, and a server releases every lease when it opens the store
// (ReleaseAllLeases) before it grants any.
struct StoreTime {
  double wall_s = 0;
  double lease_s = 0;
};

struct Lease {
  std::string lease_id;
  int64_t job_id = 0;
  v1::JobSpec spec;
  int attempt = 0;
  int iterations = 0;  // stored so far: the job resumes after iteration iterations-1
};

// A job's state, stored iteration count and whether its design loop has ended (Job.ended).
struct JobProgress {
  v1::JobState state = v1::JOB_STATE_UNSPECIFIED;
  int iterations = 0;
  bool ended = false;
};

// What became of a job whose lease ended without the worker finishing it.
enum class Requeue { kQueued, kFailed };

class JobStore {
 public:
  // Opens (creating if needed) the database at `path`, in WAL mode, migrated to kSchemaVersion.
  static Result<std::unique_ptr<JobStore>> Open(const std::string& path);
  ~JobStore();

  Result<int64_t> CreateJob(const v1::JobSpec& spec, int max_attempts, double now, const std::string& owner = "");
  // The job as clients see it (spec, state, counts, last metrics); nullopt when there is none.
  Result<std::optional<v1::Job>> GetJob(int64_t id);
  // Newest first, ids below `before_id` (0: from the newest); `state` UNSPECIFIED: all.
  // A job's progress alone (the cheap poll of watchers); nullopt: no such job.
  std::optional<JobProgress> Progress(int64_t id);
  // `owner` given: that user's jobs only.
  Result<std::vector<v1::Job>> ListJobs(v1::JobState state, int64_t before_id, int limit, const std::optional<std::string>& owner = {});
  // Jobs of `owner` waiting in the queue.
  int64_t QueuedJobsOf(const std::string& owner);
  // Jobs in each state (states without jobs are absent).
  std::map<v1::JobState, int64_t> CountByState();

  // Leases to `worker`, which runs `kernels` (core/util/pinned_kernels.h RunningKernels), the oldest
  // queued job it may run, until now.lease_s + duration: one without stored iterations, or one whose
  // iterations were computed with the same kernels (never, for a worker with empty `kernels`: it
  // does not say its own). nullopt when there is none: a job of another level waits in the queue.
  Result<std::optional<Lease>> LeaseNext(const std::string& worker, const std::string& kernels, StoreTime now, double duration_s);
  // True while `lease_id` holds `job_id` (RUNNING, not expired); extends it to `lease_now_s` (the lease
  // clock, StoreTime::lease_s) + duration. An error when the store cannot write (a full disk): the
  // lease is then neither renewed nor lost.
  Result<bool> Renew(int64_t job_id, const std::string& lease_id, double lease_now_s, double duration_s);
  bool LeaseValid(int64_t job_id, const std::string& lease_id);

  // Stores iteration `metrics.iteration()` (it must be the next one), with its motions, of a job held
  // by `lease_id`.
  Status AppendIteration(int64_t job_id, const std::string& lease_id, const v1::IterationMetrics& metrics,
                         const std::string& design);
  // Ends a lease: SUCCEEDED, FAILED (with `failure`), or back to QUEUED (released, lost). A job whose
  // cancel was requested becomes CANCELLED instead. Returns the new state.
  Result<v1::JobState> EndLease(int64_t job_id, const std::string& lease_id, v1::JobState state, const std::string& failure,
                                double now);
  // Leases whose deadline is before `now.lease_s` end as lost: the job is queued again, or FAILED once
  // it has had max_attempts attempts. Returns the jobs affected.
  std::vector<int64_t> ExpireLeases(StoreTime now);
  // At start-up: leases of a previous server process are void; their jobs are queued again.
  int ReleaseAllLeases(double now);

  // Cancels a job: a queued one at once, a running one at its worker's next report (cancel_requested).
  // Returns the job after the change; nullopt when there is no such job.
  Result<std::optional<v1::Job>> Cancel(int64_t id, double now);
  bool CancelRequested(int64_t job_id);

  // Iterations [from, to) with their motions.
  Result<std::vector<v1::IterationMetrics>> Metrics(int64_t job_id, int from, int to);
  // Iteration k's metrics and design; nullopt when not stored.
  Result<std::optional<v1::IterationRecord>> Iteration(int64_t job_id, int k);
  // Keeps iterations 0..keep-1 of a job (start-up repair when its HDF5 file holds fewer).
  Status TruncateIterations(int64_t job_id, int keep);
  Status SetGarmentFaces(int64_t job_id, int faces);
  // How the design loop of a job held by `lease_id` ended (Job.ended; its phase is then EVALUATING).
  Status SetEnded(int64_t job_id, const std::string& lease_id, const std::string& ended);
  // The kernels the worker holding `lease_id` computes the job's iterations with (Job.kernels).
  Status SetKernels(int64_t job_id, const std::string& lease_id, const std::string& kernels);
  // The worker's cleaned final design of a job held by `lease_id`, and the one stored (nullopt: none).
  Status SetCleaned(int64_t job_id, const std::string& lease_id, const v1::CleanedDesign& cleaned);
  Result<std::optional<v1::CleanedDesign>> Cleaned(int64_t job_id);

  // PRAGMA integrity_check: "ok" or the problems.
  std::string IntegrityCheck();

 private:
  JobStore() = default;
  Status Exec(const std::string& sql);
  // COMMIT, or ROLLBACK when the commit fails (the transaction left as if never begun).
  Status CommitOrRollBack();
  Result<v1::Job> ReadJob(sqlite3_stmt* row);
  std::recursive_mutex mu_;
  sqlite3* db_ = nullptr;
  int64_t lease_counter_ = 0;
};

bool IsTerminal(v1::JobState state);

}  // namespace kgd::server
