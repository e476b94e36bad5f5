// The job service: everything the design service does, with no transport in it. The gRPC services
// (server/design_server.h) and any other door (HTTP) are thin layers that turn requests into these
// calls and ServiceStatus codes into their own.
//
// It owns one data folder:
//   DIR/kgd.sqlite       the job store (server/job_store.h): queue, leases, iteration metrics
//   DIR/jobs/job-N.h5    each job's design file (store/design_file.h), written from worker reports
//   DIR/jobs/job-N.evaluation.h5   its finished design over the motion and beside the baselines
//                        (store/design_evaluation.h), when the worker sends one after the last iteration
// It stores and streams; it never simulates. An iteration is acknowledged to its worker after it is
// in the HDF5 file (flushed, SWMR) and then in SQLite (committed), in that order, so a service killed
// at any moment restarts with every acknowledged iteration; on open it trims any HDF5 iteration SQLite
// never acknowledged and queues the jobs whose workers it lost.
//
// Leases: a worker holds a job while its RunJob stream is open and its heartbeats arrive within
// lease_duration_s; a lost worker's job is queued again (and resumes from its last acknowledged
// iteration, on a worker of the kernel level its iterations were computed at: Job.kernels) until it
// has had max_attempts attempts.
//
// Thread-safe: every call may come from any thread; WatchJob, LeaseJob and RunJob block (each polls
// its `cancelled` callback and returns when the service stops).
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "core/util/status.h"
#include "kgd/v1/kgd.pb.h"
#include "server/auth.h"

namespace kgd::server {

// The canonical status codes of Google APIs (the same numbers and names as gRPC's), so that every
// transport reports the same code for the same problem.
enum class ServiceCode {
  kOk = 0,
  kCancelled = 1,
  kInvalidArgument = 3,
  kNotFound = 5,
  kPermissionDenied = 7,
  kResourceExhausted = 8,
  kFailedPrecondition = 9,
  kInternal = 13,
  kUnavailable = 14,
  kUnauthenticated = 16,
};

// "NOT_FOUND", "INVALID_ARGUMENT", ...
const char* ServiceCodeName(ServiceCode code);

struct ServiceStatus {
  ServiceCode code = ServiceCode::kOk;
  std::string message;  // names the problem: the field, the job, the iteration

  bool ok() const { return code == ServiceCode::kOk; }
  static ServiceStatus Ok() { return {}; }
};

// What one request or user may ask of the service; beyond a limit the answer is RESOURCE_EXHAUSTED
// naming the limit, the value asked for and the flag that sets it. 0: no limit.
struct ServiceLimits {
  int max_iterations = 2000;               // a job's optimizer.max_iterations (--max-iterations)
  int64_t max_mesh_vertices = 500000;      // vertices of each uploaded mesh file (--max-mesh-vertices)
  int64_t max_mesh_faces = 1000000;        // faces of each uploaded mesh file (--max-mesh-faces)
  int max_frames = 200;                    // motion frames of an uploaded scene (--max-frames)
  int max_queued_per_user = 50;            // a user's jobs waiting in the queue (--max-queued-per-user)
  int max_watchers_per_job = 64;           // open watches of one job, gRPC and HTTP (--max-watchers-per-job)
  int64_t max_design_file_bytes = int64_t(4) << 30;  // a job's design file; beyond it the job fails
  double max_jobs_per_minute = 30;         // job creations per user per minute, burst of as many (--max-jobs-per-minute)
  // Open watches on a door that holds one of its threads for each (HTTP Server-Sent Events), all jobs
  // together (--max-watchers); such a door sizes its threads by it.
  int max_held_watches = 200;
};

// A place among ServiceLimits::max_held_watches, given back when the last copy is destroyed.
using WatchPlace = std::shared_ptr<const void>;

struct JobServiceOptions {
  std::string data_dir;  // created if missing
  double lease_duration_s = 30;
  int max_attempts = 5;
  bool quiet = false;  // no log lines on stderr
  TokenTable tokens;   // no tokens: one anonymous caller that may do everything
  ServiceLimits limits;
};

class JobService {
 public:
  // Opens the data folder, repairs it after a crash, and starts expiring lost workers' leases.
  // Creates the data folder (and jobs/) with mode 0700 when missing. The files in it get the process's
  // umask: kgd-server and `kgd serve` set 077, so they are 0600.
  static Result<std::unique_ptr<JobService>> Open(const JobServiceOptions& options);
  ~JobService();  // Close()

  const JobServiceOptions& options() const;

  // The caller of a request from its authorization value ("Bearer TOKEN"), or from a bare token;
  // errors (for UNAUTHENTICATED) say what is missing or wrong, never the token.
  Result<Caller> Authenticate(const std::string& authorization) const;
  Result<Caller> AuthenticateToken(const std::string& token) const;

  // -- For clients ---------------------------------------------------------------------------------
  // Every call names its caller (server/auth.h). A `user` sees only the jobs it created: another's
  // job is NOT_FOUND, as if it did not exist; an `admin` sees all; a `worker` may not call these
  // (PERMISSION_DENIED).
  // The built-in scenes and the parametric body's measurements (a fixed table: nothing is built), the
  // iteration limit, and the predictions at the workers' machine factor (learned from the jobs they
  // finish; before the first, from the speed a worker measured: LeaseJobRequest.speed).
  ServiceStatus ListScenes(v1::ListScenesResponse* response);
  // Prometheus text exposition of the service's figures (server/service_metrics.h).
  std::string MetricsText();
  // Whether the service can take work (readiness, apart from liveness): OK, or UNAVAILABLE saying why
  // not: a job is paused because the server cannot store (Job.paused), the data folder's file system
  // has less than 2 MiB free, or the server drains. CreateJob refuses new jobs with the same reason.
  ServiceStatus Ready();
  ServiceStatus CreateJob(const Caller& caller, const v1::CreateJobRequest& request, v1::Job* job);
  ServiceStatus GetJob(const Caller& caller, int64_t id, v1::Job* job);
  ServiceStatus ListJobs(const Caller& caller, const v1::ListJobsRequest& request, v1::ListJobsResponse* response);
  ServiceStatus CancelJob(const Caller& caller, int64_t id, v1::Job* job);
  ServiceStatus GetIteration(const Caller& caller, const v1::GetIterationRequest& request, v1::GetIterationResponse* response);
  // The finished design over the motion and beside the baselines (DIR/jobs/job-N.evaluation.h5).
  ServiceStatus GetEvaluation(const Caller& caller, int64_t id, v1::DesignEvaluation* evaluation);
  // The job's garment (rest shape, faces, body, materials); NOT_FOUND while it has no iteration.
  ServiceStatus GetGarment(const Caller& caller, int64_t id, v1::Garment* garment);
  // The bytes of the job's design file (DIR/jobs/job-N.h5) once it has ended: FAILED_PRECONDITION while
  // it is queued or running, NOT_FOUND when it stored no iteration.
  ServiceStatus GetDesignFile(const Caller& caller, int64_t id, std::string* bytes);
  // Cut files of one stored iteration, by geometry alone (job/fabrication_export.h, ExportGeometry);
  // the report of the job's last iteration at the default cleaning gives the cleaned design's density
  // ratio its worker simulated (kgd.v1.CleanedDesign). `progress` (optional) is called as each stage of
  // a computed export starts.
  ServiceStatus ExportDesign(const Caller& caller, const v1::ExportDesignRequest& request, v1::ExportDesignResponse* response,
                             const std::function<void(const v1::ExportProgress&)>& progress = nullptr);
  // Sends the job, its stored iterations from request.from_iteration(), then every new one and every
  // state change as they come, until the job ends (OK), `write` returns false (the client is gone:
  // OK) or `cancelled` returns true / the service stops (CANCELLED).
  // What WatchJob would refuse at once: an unknown job, one watched by as many as the limit.
  ServiceStatus CanWatch(const Caller& caller, int64_t id);
  // A place for a watch that holds a door's thread (take it after CanWatch); RESOURCE_EXHAUSTED
  // naming --max-watchers when all are taken.
  ServiceStatus TakeWatchPlace(WatchPlace* place);
  ServiceStatus WatchJob(const Caller& caller, const v1::WatchJobRequest& request, const std::function<bool(const v1::WatchJobEvent&)>& write,
                         const std::function<bool()>& cancelled);

  // -- For workers ---------------------------------------------------------------------------------
  // Callers with the `worker` or `admin` role; a `user` gets PERMISSION_DENIED.
  // Leases the oldest queued job the worker may run (a new one, or one whose stored iterations were
  // computed with the kernels of request.kernels(): JobStore::LeaseNext), waiting up to
  // request.wait_s() for one (response.leased() false when none came, or the service drains or stops). A request's speed is taken as the workers' machine
  // factor while no job has finished here.
  ServiceStatus LeaseJob(const Caller& caller, const v1::LeaseJobRequest& request, v1::LeaseJobResponse* response, const std::function<bool()>& cancelled);
  // One worker's RunJob stream on a leased job: `read` gives the worker's messages (false: the stream
  // ended), `write` sends the replies. Returns when the worker ends the lease, the stream ends, or the
  // service refuses a report (the lease ends and the job is queued again or fails).
  ServiceStatus RunJob(const Caller& caller, const std::function<bool(v1::WorkerMessage*)>& read, const std::function<bool(const v1::ServerMessage&)>& write,
                       const std::function<bool()>& cancelled);

  // -- Life cycle ----------------------------------------------------------------------------------
  // Stops leasing and asks running workers to stop after their current iteration (their jobs are
  // queued again, to resume later); waits up to timeout_s for their streams to end.
  void Drain(double timeout_s);
  // Ends every blocking call (they return CANCELLED or, for LeaseJob, nothing leased); idempotent.
  void Stop();
  // Stop(), then closes the open design files; idempotent. The transports stop calling first.
  void Close();

 private:
  JobService() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kgd::server
