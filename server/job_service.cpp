#include "server/job_service.h"

#include <algorithm>
#include <cmath>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include <sys/statvfs.h>

#include "core/scene/builtin_scenes.h"
#include "core/util/fault_point.h"
#include "job/cost_calibration.h"
#include "job/fabrication_export.h"
#include "proto/job_spec.h"
#include "proto/records.h"
#include "server/job_store.h"
#include "server/service_metrics.h"
#include "store/design_file.h"
#include "store/file_lock.h"

namespace kgd::server {
namespace fs = std::filesystem;

namespace {

// Unix seconds: the times users see (a job's create and update times).
double Now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }
// Seconds of the monotonic clock, which a step of the wall clock does not move: every duration the
// service measures (lease deadlines, long polls, the drain, the rate limit, the storage-failure grace).
double SteadyNow() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
StoreTime StoreNow() { return {Now(), SteadyNow()}; }

ServiceStatus Error(ServiceCode code, std::string message) { return ServiceStatus{code, std::move(message)}; }
ServiceStatus Internal(const Status& st) { return Error(ServiceCode::kInternal, st.message()); }

// Bytes free to this process on the file system that holds `path`; -1 when it cannot be told.
long long FreeBytes(const std::string& path) {
  struct statvfs st;
  if (statvfs(path.c_str(), &st) != 0) return -1;
  return static_cast<long long>(st.f_bavail) * static_cast<long long>(st.f_frsize);
}

// Below this much free space in the data folder the service is not ready and takes no new jobs.
constexpr long long kReadyFreeBytes = 2 << 20;

}  // namespace

namespace {

std::string FormatLimit(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

// Vertices and faces of a mesh file's bytes, by its lines (OBJ: v, f) or header (PLY: element).
std::pair<int64_t, int64_t> CountMesh(const std::string& bytes) {
  int64_t vertices = 0, faces = 0;
  if (bytes.rfind("ply", 0) == 0) {
    std::istringstream header(bytes.substr(0, std::min<size_t>(bytes.size(), 4096)));
    std::string line;
    while (std::getline(header, line) && line.rfind("end_header", 0) != 0) {
      std::istringstream f(line);
      std::string word, kind;
      int64_t n = 0;
      if (f >> word >> kind >> n && word == "element") (kind == "vertex" ? vertices : kind == "face" ? faces : n) = n;
    }
    return {vertices, faces};
  }
  for (size_t at = 0; at < bytes.size();) {
    size_t end = bytes.find('\n', at);
    if (end == std::string::npos) end = bytes.size();
    if (end - at > 1 && bytes[at + 1] == ' ') {
      if (bytes[at] == 'v') ++vertices;
      if (bytes[at] == 'f') ++faces;
    }
    at = end + 1;
  }
  return {vertices, faces};
}

// The limits a job spec can break before it is validated: iterations, uploaded meshes, frames. An
// iteration limit above the server's is a bad argument (INVALID_ARGUMENT: the same spec is refused
// whenever it is sent); the sizes of what was sent are RESOURCE_EXHAUSTED.
ServiceStatus CheckLimits(const ServiceLimits& limits, const v1::JobSpec& spec) {
  auto over = [](const std::string& what, int64_t value, int64_t limit, const std::string& flag) {
    return Error(ServiceCode::kResourceExhausted, what + " " + std::to_string(value) + " is over the limit of " + std::to_string(limit) + " (" + flag + ")");
  };
  if (limits.max_iterations > 0 && spec.optimizer().max_iterations() > limits.max_iterations)
    return Error(ServiceCode::kInvalidArgument, "spec.optimizer.max_iterations: " + std::to_string(spec.optimizer().max_iterations()) +
                                                    " is above this server's limit of " + std::to_string(limits.max_iterations) +
                                                    " iterations (--max-iterations)");
  if (!spec.has_scene_files()) return ServiceStatus::Ok();
  const v1::SceneFiles& files = spec.scene_files();
  // The frames of every motion and body: the body's own, the scene's other motions' and other bodies'.
  const v1::Scene& scene = files.scene();
  int frames = scene.body().frames_size();
  std::string where = "body.frames";
  for (const v1::SceneMotion& m : scene.motions()) frames += m.frames_size();
  for (const v1::SceneRangeBody& b : scene.bodies()) frames += b.frames_size();
  if (scene.motions_size()) where += ", motions[].frames";
  if (scene.bodies_size()) where += ", bodies[].frames";
  if (limits.max_frames > 0 && frames > limits.max_frames)
    return over(where + ": " + std::to_string(frames) + " frames;", frames, limits.max_frames, "--max-frames");
  for (const auto& [name, bytes] : files.files()) {
    const auto [vertices, faces] = CountMesh(bytes);
    if (limits.max_mesh_vertices > 0 && vertices > limits.max_mesh_vertices)
      return over(name + ": vertices", vertices, limits.max_mesh_vertices, "--max-mesh-vertices");
    if (limits.max_mesh_faces > 0 && faces > limits.max_mesh_faces) return over(name + ": faces", faces, limits.max_mesh_faces, "--max-mesh-faces");
  }
  return ServiceStatus::Ok();
}

// The worker's figures of a cleaned design (CleanedDesign) in an export's report, when the export's
// cleaned design is the one the worker simulated (the same cleaning of the same design gives the same
// bits): what `kgd export` reports for it.
void ApplyCleanedSimulation(const v1::CleanedDesign& c, ExportFiles* files) {
  ExportReport& r = files->report;
  if (std::string(r.cleaned.design.begin(), r.cleaned.design.end()) != c.design()) return;
  r.cleaned_density_ratio = c.density_ratio();
  r.cleaned_area_fraction = c.area_fraction();
  r.cleaned_solve_status = c.solve_status();
  for (auto& [name, contents] : files->files)
    if (name == "report.json") contents = ExportReportJson(r);
}

}  // namespace

const char* ServiceCodeName(ServiceCode code) {
  switch (code) {
    case ServiceCode::kOk: return "OK";
    case ServiceCode::kCancelled: return "CANCELLED";
    case ServiceCode::kInvalidArgument: return "INVALID_ARGUMENT";
    case ServiceCode::kNotFound: return "NOT_FOUND";
    case ServiceCode::kPermissionDenied: return "PERMISSION_DENIED";
    case ServiceCode::kResourceExhausted: return "RESOURCE_EXHAUSTED";
    case ServiceCode::kFailedPrecondition: return "FAILED_PRECONDITION";
    case ServiceCode::kInternal: return "INTERNAL";
    case ServiceCode::kUnavailable: return "UNAVAILABLE";
    case ServiceCode::kUnauthenticated: return "UNAUTHENTICATED";
  }
  return "UNKNOWN";
}

struct JobService::Impl {
  JobServiceOptions options;
  FileLock folder_lock;  // on DATA/kgd.lock while this service is open: one server per data folder
  std::unique_ptr<JobStore> store;

  // Commits (HDF5 + SQLite), leases and the open design files go through commit_mu.
  std::mutex commit_mu;
  // A job's open design file belongs to one lease: a RunJob stream whose lease was lost (expired, re-leased)
  // can neither write to nor close the file of the lease that replaced it.
  struct OpenFile {
    std::string lease_id;
    std::unique_ptr<DesignFileWriter> writer;
    // A write failed: the writer is reopened at the acknowledged iterations before the next append.
    bool reopen = false;
  };
  std::map<int64_t, OpenFile> files;
  ServiceMetrics metrics;

  // The last few exports (ExportDesign), most recent first: the web page asks for each cut file of an
  // iteration separately, and a stored iteration never changes, so they share one export.
  std::mutex exports_mu;
  std::vector<std::pair<std::string, std::shared_ptr<const ExportFiles>>> exports;
  static constexpr size_t kExportsKept = 4;
  // Exports being made, by the request that asked first; the same export asked for meanwhile (the
  // page's downloads of one iteration, fired together) waits for it instead of making it again.
  struct ExportOutcome {
    ServiceStatus status;
    std::shared_ptr<const ExportFiles> files;
  };
  std::map<std::string, std::shared_future<ExportOutcome>> exports_in_progress;

  // These workers' speed against the cost model's reference machine (job/cost_calibration.h), learned
  // from the jobs they finish; ListScenes' predictions use it.
  std::mutex calibration_mu;
  std::string CostCalibrationFile() const { return (fs::path(options.data_dir) / "cost_calibration.json").string(); }
  // A worker's speed measured before its first job: these workers' factor until a job has finished here.
  void LearnFromWorkerSpeed(const v1::MachineSpeed& speed, const std::string& worker) {
    std::lock_guard lock(calibration_mu);
    if (ReadMachineFactor(CostCalibrationFile()).jobs > 0) return;
    RecordDesignTime(CostCalibrationFile(), speed.predicted_s(), speed.measured_s());
    const MachineFactor f = ReadMachineFactor(CostCalibrationFile());
    if (f.jobs > 0)
      Log("machine factor " + FormatLimit(f.factor) + " from worker " + worker + "'s measurement (" + speed.what() + ": " +
          FormatLimit(speed.measured_s()) + " s, the reference machine " + FormatLimit(speed.predicted_s()) + " s)");
  }
  void LearnFromFinishedJob(int64_t id) {
    Result<std::optional<v1::Job>> job = store->GetJob(id);
    if (!job.ok() || !*job || (*job)->iterations() < 2 || (*job)->garment_faces() <= 0) return;
    const v1::Job& j = **job;
    Result<std::vector<v1::IterationMetrics>> metrics = store->Metrics(id, 0, j.iterations());
    if (!metrics.ok()) return;
    // Every stored iteration's time, whichever worker measured it (a resumed job's included).
    double measured_s = 0;
    for (const v1::IterationMetrics& it : *metrics) measured_s += it.total_s();
    const double predicted_s = PredictedSolvesSeconds(j.garment_faces(), QualityOfJob(j.spec().optimizer().quality()), j.iterations() - 1,
                                                      std::max(1, j.last().motions_size()));
    std::lock_guard lock(calibration_mu);
    RecordDesignTime(CostCalibrationFile(), predicted_s, measured_s);
  }

  // Limits kept in memory: open watches per job, and each user's job-creation bucket.
  std::mutex limits_mu;
  std::map<int64_t, int> watchers;
  struct Bucket {
    double tokens = 0, time = -1;
  };
  std::map<std::string, Bucket> creations;
  int held_watches = 0;  // places taken of limits.max_held_watches

  // RESOURCE_EXHAUSTED when job `id` has as many open watches as the limit; call under limits_mu.
  ServiceStatus WatchLimit(int64_t id) {
    const int limit = options.limits.max_watchers_per_job;
    auto it = watchers.find(id);
    if (limit > 0 && it != watchers.end() && it->second >= limit)
      return Error(ServiceCode::kResourceExhausted,
                   "job " + std::to_string(id) + " has " + std::to_string(limit) + " open watches, the limit (--max-watchers-per-job)");
    return ServiceStatus::Ok();
  }

  // Takes one job creation from `user`'s bucket (max_jobs_per_minute per minute, burst of as many).
  bool TakeCreation(const std::string& user) {
    const double rate = options.limits.max_jobs_per_minute;
    if (rate <= 0) return true;
    std::lock_guard lock(limits_mu);
    Bucket& b = creations[user];
    const double now = SteadyNow();
    b.tokens = b.time < 0 ? rate : std::min(rate, b.tokens + (now - b.time) * rate / 60);
    b.time = now;
    if (b.tokens < 1) return false;
    b.tokens -= 1;
    return true;
  }

  // Anything a watcher or a waiting worker may care about bumps `version`.
  std::mutex event_mu;
  std::condition_variable event_cv;
  uint64_t version = 0;

  // The latest committed iterations (metrics and design), so that many watchers of a running job share
  // one copy instead of each reading SQLite. Bounded; older iterations come from the store.
  std::mutex recent_mu;
  std::map<std::pair<int64_t, int>, std::shared_ptr<const v1::IterationRecord>> recent;
  static constexpr size_t kRecentLimit = 512;

  // Jobs waiting because their work cannot be stored (Job.paused), with the reason; when storage last
  // failed (leases are not expired within a lease duration of it: their renewals may have failed too).
  mutable std::mutex storage_mu;
  std::map<int64_t, std::string> paused;
  double storage_failed_s = -1e300;

  // The reason a storage failure gives users, or "" when `st` is none: a full disk (ENOSPC, EDQUOT,
  // SQLITE_FULL, the design file's refusal for want of space) or a disk that fails writes (EIO,
  // SQLITE_IOERR). Both pass by themselves once space is freed or the disk is back.
  std::string StorageFault(const Status& st) const {
    const std::string& e = st.message();
    auto has = [&e](const char* what) { return e.find(what) != std::string::npos; };
    if (has("(ENOSPC)") || has("(EDQUOT)") || has("database or disk is full") || has("No space left on device"))
      return "the server's disk is full (data folder " + options.data_dir + ", " + std::to_string(FreeBytes(options.data_dir)) + " bytes free)";
    if (has("(EIO)") || has("disk I/O error") || has("Input/output error"))
      return "the server cannot write to its data folder " + options.data_dir + " (an I/O error)";
    return "";
  }
  // Records a storage failure (no job paused by it).
  void StorageFailed() {
    std::lock_guard lock(storage_mu);
    storage_failed_s = SteadyNow();
  }
  bool StorageFailedRecently() const {
    std::lock_guard lock(storage_mu);
    return SteadyNow() - storage_failed_s < options.lease_duration_s;
  }
  std::string PausedReason(int64_t id) const {
    std::lock_guard lock(storage_mu);
    auto it = paused.find(id);
    return it == paused.end() ? std::string() : it->second;
  }
  void Pause(int64_t id, const std::string& reason, const Status& error) {
    bool first = false;
    {
      std::lock_guard lock(storage_mu);
      storage_failed_s = SteadyNow();
      first = !paused.count(id);
      paused[id] = reason;
    }
    if (!first) return;
    Log("job " + std::to_string(id) + " paused: " + reason + " (" + error.message() + "); it continues when the server can store again");
    Notify();
  }
  void Unpause(int64_t id, bool stored) {
    {
      std::lock_guard lock(storage_mu);
      if (!paused.erase(id)) return;
    }
    if (stored) Log("job " + std::to_string(id) + " continues: the server stores again");
    Notify();
  }
  // Runs `store_it` until it succeeds or fails other than by storage (that error is returned). While
  // storage fails, job `id` is paused (Job.paused), its lease kept, and `store_it` tried again every
  // half second until `give_up` (the storage error is then returned).
  Status StoreOrPause(int64_t id, const std::function<Status()>& store_it, const std::function<bool()>& give_up) {
    for (;;) {
      Status st = store_it();
      const std::string reason = st.ok() ? std::string() : StorageFault(st);
      if (reason.empty()) {
        Unpause(id, st.ok());
        return st;
      }
      Pause(id, reason, st);
      if (stopping || give_up()) {
        Unpause(id, false);
        return st;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
  }

  std::atomic<bool> draining{false}, stopping{false};
  std::atomic<int> active_streams{0};
  std::thread expiry;
  std::mutex stop_mu;
  bool closed = false;

  void Log(const std::string& line) {
    if (!options.quiet) std::fprintf(stderr, "kgd-server: %s\n", line.c_str());
  }

  void Notify() {
    {
      std::lock_guard lock(event_mu);
      ++version;
    }
    event_cv.notify_all();
  }

  // Waits until the event version passes `seen` or `timeout_s` elapses; returns the current version.
  uint64_t WaitEvent(uint64_t seen, double timeout_s) {
    std::unique_lock lock(event_mu);
    event_cv.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return version != seen || stopping; });
    return version;
  }
  uint64_t CurrentVersion() {
    std::lock_guard lock(event_mu);
    return version;
  }

  std::string FilePath(int64_t id) const { return (fs::path(options.data_dir) / "jobs" / ("job-" + std::to_string(id) + ".h5")).string(); }

  // A job as callers see it: its design file named, and its spec without the uploaded files' contents
  // (megabytes of meshes per job in every listing and watch event; workers get them with their lease).
  void Decorate(v1::Job* job) const {
    if (std::error_code ec; fs::exists(FilePath(job->id()), ec)) job->set_data_file(FilePath(job->id()));
    if (job->state() == v1::RUNNING) job->set_paused(PausedReason(job->id()));
    if (job->spec().has_scene_files()) job->mutable_spec()->mutable_scene_files()->clear_files();
  }

  // Opening repair: every job's design file holds exactly the iterations SQLite acknowledged, and none
  // is left marked open by a killed writer.
  Status Repair() {
    const int released = store->ReleaseAllLeases(Now());
    if (released > 0) Log(std::to_string(released) + " jobs of the previous server queued again");
    Result<std::vector<v1::Job>> jobs = store->ListJobs(v1::JOB_STATE_UNSPECIFIED, 0, 1 << 30);
    if (!jobs.ok()) return jobs.status();
    for (const v1::Job& job : *jobs) {
      const std::string path = FilePath(job.id());
      if (!fs::exists(path)) {
        if (job.iterations() > 0) Log(path + ": missing; job " + std::to_string(job.id()) + " lost its arrays");
        continue;
      }
      // All intact iterations first (a file left by a killed server is rebuilt from them), then
      // trimmed to what the job store acknowledged.
      Result<std::unique_ptr<DesignFileWriter>> w = DesignFileWriter::Reopen(path);
      if (!w.ok()) {
        Log(w.message());
        continue;
      }
      if (!(*w)->repair_note().empty()) Log(path + ": " + (*w)->repair_note());
      const int on_disk = (*w)->num_iterations();
      FaultPoint("repair.after_reopen", on_disk);
      if (on_disk < job.iterations()) {
        Log(path + ": holds fewer iterations than acknowledged; trimming job " + std::to_string(job.id()));
        KGD_RETURN_IF_ERROR(store->TruncateIterations(job.id(), on_disk));
      } else if (on_disk > job.iterations()) {
        w->reset();
        w = DesignFileWriter::Reopen(path, job.iterations());
        if (!w.ok()) Log(w.message());
      }
    }
    return Status::Ok();
  }

  // Job `id` as `caller` may see it: another user's job does not exist for a `user`.
  ServiceStatus FindJob(const Caller& caller, int64_t id, v1::Job* out) {
    if (caller.role == Role::kWorker) return Error(ServiceCode::kPermissionDenied, "a worker's token cannot read jobs");
    Result<std::optional<v1::Job>> job = store->GetJob(id);
    if (!job.ok()) return Internal(job.status());
    if (!*job || (caller.role == Role::kUser && (*job)->owner() != caller.user))
      return Error(ServiceCode::kNotFound, "job " + std::to_string(id) + " does not exist");
    *out = **job;
    Decorate(out);
    return ServiceStatus::Ok();
  }

  // What a reader of job `id`'s design file is told when reading it failed with `st`: a file that is
  // gone (moved away or deleted by a clean-up) or damaged is named for the job, without the server's own
  // path, which means nothing to a client (the server's log has it).
  ServiceStatus DesignFileError(int64_t id, const Status& st) {
    const std::string job = "job " + std::to_string(id);
    const std::string path = FilePath(id);
    Log(st.message());
    if (std::error_code ec; !fs::exists(path, ec))
      return Error(ServiceCode::kNotFound, job + "'s design file is missing from the server's data folder (moved or deleted): its designs and arrays "
                                                 "cannot be served; its metrics still can (kgd job " + std::to_string(id) + ")");
    std::string what = st.message();
    if (what.rfind(path + ": ", 0) == 0) what = what.substr(path.size() + 2);
    return Error(ServiceCode::kInternal, job + "'s design file: " + what);
  }

  // Positions, energy densities and sensitivities of iteration k from the job's design file.
  Result<BesoIteration> ReadArrays(int64_t id, int k) {
    std::lock_guard lock(commit_mu);  // HDF5 calls are serialized with the writers
    Result<DesignFile> f = ReadDesignFile(FilePath(id), {.arrays = true, .only_iteration = k});
    if (!f.ok()) return f.status();
    if (k >= static_cast<int>(f->iterations.size())) return Status::Error(FilePath(id) + ": iteration " + std::to_string(k) + " is missing");
    return f->iterations[k];
  }

  // Stores one reported iteration: HDF5 first, then SQLite (the acknowledgement).
  Status Commit(int64_t job_id, const std::string& lease_id, const v1::IterationRecord& record) {
    std::lock_guard lock(commit_mu);
    if (!store->LeaseValid(job_id, lease_id)) return Status::Error("the lease on job " + std::to_string(job_id) + " is no longer held");
    auto it = files.find(job_id);
    if (it == files.end() || it->second.lease_id != lease_id)
      return Status::Error("job " + std::to_string(job_id) + ": iteration reported before start");
    if (it->second.reopen || !it->second.writer) {
      // After a failed write: the file as the job store acknowledges it (an iteration in HDF5 whose
      // SQLite commit failed is dropped), then the append again.
      it->second.writer.reset();
      const std::optional<JobProgress> progress = store->Progress(job_id);
      if (!progress) return Status::Error("job " + std::to_string(job_id) + " vanished");
      Result<std::unique_ptr<DesignFileWriter>> reopened = DesignFileWriter::Rebuild(FilePath(job_id), progress->iterations);
      if (!reopened.ok()) return reopened.status();
      if ((*reopened)->num_iterations() < progress->iterations)
        return Status::Error(FilePath(job_id) + ": " + (*reopened)->repair_note() + "; the job needs a server restart to be trimmed");
      it->second.writer = std::move(reopened).value();
      it->second.reopen = false;
    }
    DesignFileWriter& w = *it->second.writer;
    if (record.metrics().iteration() != w.num_iterations())
      return Status::Error("job " + std::to_string(job_id) + ": iteration " + std::to_string(record.metrics().iteration()) + " reported after " +
                           std::to_string(w.num_iterations()) + " stored");
    const int64_t max_bytes = options.limits.max_design_file_bytes;
    std::error_code size_error;
    if (const auto size = fs::file_size(FilePath(job_id), size_error); max_bytes > 0 && !size_error && static_cast<int64_t>(size) > max_bytes)
      return Status::Error("job " + std::to_string(job_id) + ": its design file has reached " + std::to_string(size >> 20) +
                           " MiB, the limit (--max-design-file-mb)");
    Result<BesoIteration> it_rec = RecordFromProto(record, w.faces(), w.vertices());
    if (!it_rec.ok()) return it_rec.status();
    const int k = record.metrics().iteration();
    FaultPoint("commit.before_hdf5", k);
    const auto t0 = std::chrono::steady_clock::now();
    if (Status st = w.Append(*it_rec); !st.ok()) {
      it->second.reopen = true;
      return st;
    }
    FaultPoint("commit.after_hdf5", k);
    const auto t1 = std::chrono::steady_clock::now();
    if (Status st = store->AppendIteration(job_id, lease_id, record.metrics(), record.design()); !st.ok()) {
      it->second.reopen = true;
      return st;
    }
    FaultPoint("commit.after_sqlite", k);
    const auto t2 = std::chrono::steady_clock::now();
    metrics.IterationStored(record.metrics().total_s(), record.metrics().report_time_s(), std::chrono::duration<double>(t1 - t0).count(),
                            std::chrono::duration<double>(t2 - t1).count());
    auto shared = std::make_shared<v1::IterationRecord>();
    *shared->mutable_metrics() = record.metrics();
    shared->set_design(record.design());
    std::lock_guard recent_lock(recent_mu);
    recent[{job_id, record.metrics().iteration()}] = std::move(shared);
    while (recent.size() > kRecentLimit) recent.erase(std::min_element(recent.begin(), recent.end(), [](const auto& a, const auto& b) {
                                             return a.second->metrics().report_time_s() < b.second->metrics().report_time_s();
                                           }));
    return Status::Ok();
  }

  // Iteration k's metrics and design: from the recent commits, else from the store.
  Result<std::shared_ptr<const v1::IterationRecord>> StoredIteration(int64_t id, int k) {
    {
      std::lock_guard lock(recent_mu);
      auto it = recent.find({id, k});
      if (it != recent.end()) return it->second;
    }
    Result<std::optional<v1::IterationRecord>> rec = store->Iteration(id, k);
    if (!rec.ok()) return rec.status();
    if (!*rec) return Status::Error("job " + std::to_string(id) + ": iteration " + std::to_string(k) + " vanished");
    return std::shared_ptr<const v1::IterationRecord>(std::make_shared<v1::IterationRecord>(std::move(**rec)));
  }

  void CloseFile(int64_t job_id, const std::string& lease_id) {
    std::lock_guard lock(commit_mu);
    auto it = files.find(job_id);
    if (it != files.end() && it->second.lease_id == lease_id) files.erase(it);
  }

  // The kernels a start report says its worker runs; "unknown" when it does not say (an older worker).
  static std::string KernelsOfStart(const v1::JobStart& start) { return start.kernels().empty() ? "unknown" : start.kernels(); }

  // Why job `id` cannot go on with its stored iterations on a worker that runs `start`'s kernels
  // (another level would change its designs); Ok when it can. LeaseNext leases no such job: this
  // catches a worker that reports other kernels in its lease than in its start.
  Status CheckResumeKernels(int64_t id, const v1::JobStart& start) {
    Result<std::optional<v1::Job>> job = store->GetJob(id);
    if (!job.ok()) return job.status();
    if (!*job || (*job)->iterations() == 0 || (*job)->kernels() == KernelsOfStart(start)) return Status::Ok();
    return Status::Error("job " + std::to_string(id) + "'s iterations were computed with the " + (*job)->kernels() +
                         " kernels and this worker runs " + KernelsOfStart(start) + ": it resumes on a worker of its level");
  }

  // Opens the job's design file for `lease_id` from the worker's start report: a new file for a new
  // job (recording the worker's kernels there and in the job store), the stored one (cut to the
  // acknowledged iterations) for a resumed one.
  Status OpenJobFile(int64_t job_id, const std::string& lease_id, const v1::JobStart& start) {
    std::lock_guard lock(commit_mu);
    if (!store->LeaseValid(job_id, lease_id)) return Status::Error("the lease on job " + std::to_string(job_id) + " is no longer held");
    Result<std::optional<v1::Job>> job = store->GetJob(job_id);
    if (!job.ok()) return job.status();
    if (!*job) return Status::Error("job " + std::to_string(job_id) + " vanished");
    const std::string path = FilePath(job_id);
    Result<std::unique_ptr<DesignFileWriter>> w = Status::Error("");
    if ((*job)->iterations() == 0) {
      DesignFileHeader header;
      header.scene = start.scene();
      header.body = start.body();
      header.kernels = KernelsOfStart(start);
      header.grad_tol = std::isfinite(start.grad_tol()) ? std::max(0.0, start.grad_tol()) : 0.0;
      header.max_newton_iterations = std::max(0, start.max_newton_iterations());
      Result<BesoSettings> settings = BesoSettingsFromJson(start.settings_json());
      if (!settings.ok()) return Status::Error("bad start report: " + settings.message());
      KGD_RETURN_IF_ERROR(GarmentFromProto(start.garment(), &header).WithContext("bad start report: "));
      header.settings = *settings;
      fs::create_directories(fs::path(path).parent_path());
      KGD_RETURN_IF_ERROR(store->SetKernels(job_id, lease_id, header.kernels));
      w = DesignFileWriter::Create(path, header);
      store->SetGarmentFaces(job_id, static_cast<int>(header.garment.faces.rows()));
    } else {
      w = DesignFileWriter::Reopen(path, (*job)->iterations());
      // Repair() rebuilt every file a killed server left; one found here would have lost iterations
      // the worker was told are stored.
      if (w.ok() && (*w)->num_iterations() < (*job)->iterations())
        return Status::Error(path + ": " + (*w)->repair_note() + "; the job needs a server restart to be trimmed");
    }
    if (!w.ok()) return w.status();
    FaultPoint("open_job_file.after_open", (*job)->iterations());
    files[job_id] = OpenFile{lease_id, std::move(w).value()};
    return Status::Ok();
  }

  void ExpireLeases() {
    uint64_t seen = CurrentVersion();
    while (!stopping) {
      seen = WaitEvent(seen, std::min(0.5, options.lease_duration_s / 4));
      std::vector<int64_t> expired;
      // Renewals fail with the store: no lease expires within a lease duration of a storage failure.
      if (StorageFailedRecently()) continue;
      {
        std::lock_guard lock(commit_mu);
        expired = store->ExpireLeases(StoreNow());
        for (int64_t id : expired) files.erase(id);
      }
      for (int64_t id : expired) Log("job " + std::to_string(id) + ": the worker's lease expired");
      if (!expired.empty()) metrics.LeasesExpired(static_cast<int>(expired.size()));
      if (!expired.empty()) Notify();
    }
  }
};

Result<std::unique_ptr<JobService>> JobService::Open(const JobServiceOptions& options) {
  auto s = std::unique_ptr<JobService>(new JobService);
  s->impl_ = std::make_unique<Impl>();
  Impl& m = *s->impl_;
  m.options = options;
  std::error_code ec;
  // The folders this creates are the owner's alone (designs and specs may be unpublished work); an
  // existing folder keeps the permissions its owner gave it.
  for (const fs::path& dir : {fs::path(options.data_dir), fs::path(options.data_dir) / "jobs"}) {
    if (fs::exists(dir, ec)) continue;
    fs::create_directories(dir, ec);
    if (ec) return Status::Error(options.data_dir + ": cannot create the data folder: " + ec.message());
    fs::permissions(dir, fs::perms::owner_all, ec);
  }
  // One server per data folder: a second one would release the first's leases as a restart does, and
  // the first's running jobs would fail on their design files.
  const std::string lock_path = (fs::path(options.data_dir) / "kgd.lock").string();
  Result<FileLock> lock = FileLock::Acquire(lock_path, /*create=*/true, [&](const std::string& holder) {
    return "--data " + options.data_dir + ": another server uses this data folder (" + holder + "); stop it, or give this one another --data";
  });
  if (!lock.ok()) return lock.status();
  m.folder_lock = std::move(lock).value();
  Result<std::unique_ptr<JobStore>> store = JobStore::Open((fs::path(options.data_dir) / "kgd.sqlite").string());
  if (!store.ok()) return store.status();
  m.store = std::move(store).value();
  KGD_RETURN_IF_ERROR(m.Repair());
  m.expiry = std::thread([&m] { m.ExpireLeases(); });
  return s;
}

JobService::~JobService() { Close(); }

const JobServiceOptions& JobService::options() const { return impl_->options; }

Result<Caller> JobService::Authenticate(const std::string& authorization) const { return impl_->options.tokens.Authenticate(authorization); }
Result<Caller> JobService::AuthenticateToken(const std::string& token) const { return impl_->options.tokens.AuthenticateToken(token); }

ServiceStatus JobService::CreateJob(const Caller& caller, const v1::CreateJobRequest& req, v1::Job* out) {
  Impl& m = *impl_;
  if (caller.role == Role::kWorker) return Error(ServiceCode::kPermissionDenied, "a worker's token cannot create jobs");
  if (ServiceStatus st = Ready(); !st.ok()) return Error(st.code, "the server takes no new jobs now: " + st.message);
  if (ServiceStatus st = CheckLimits(m.options.limits, req.spec()); !st.ok()) return st;
  if (Status st = ValidateJobSpec(req.spec()); !st.ok()) return Error(ServiceCode::kInvalidArgument, st.message());
  const ServiceLimits& limits = m.options.limits;
  if (limits.max_queued_per_user > 0 && m.store->QueuedJobsOf(caller.user) >= limits.max_queued_per_user)
    return Error(ServiceCode::kResourceExhausted, (caller.user.empty() ? std::string("the queue") : "user " + caller.user) + " has " +
                                                      std::to_string(limits.max_queued_per_user) +
                                                      " jobs waiting, the limit (--max-queued-per-user); wait for some to start or cancel them");
  if (!m.TakeCreation(caller.user))
    return Error(ServiceCode::kResourceExhausted, "more than " + FormatLimit(limits.max_jobs_per_minute) +
                                                      " jobs created per minute (--max-jobs-per-minute); try again in a few seconds");
  Result<int64_t> id = m.store->CreateJob(req.spec(), m.options.max_attempts, Now(), caller.user);
  if (!id.ok() && !m.StorageFault(id.status()).empty()) {
    m.StorageFailed();
    return Error(ServiceCode::kUnavailable, "the server takes no new jobs now: " + m.StorageFault(id.status()));
  }
  if (!id.ok()) return Internal(id.status());
  Result<std::optional<v1::Job>> job = m.store->GetJob(*id);
  if (!job.ok() || !*job) return Internal(job.status());
  *out = **job;
  m.Decorate(out);
  m.Log("job " + std::to_string(*id) + " queued");
  m.metrics.JobCreated();
  m.Notify();
  return ServiceStatus::Ok();
}

ServiceStatus JobService::Ready() {
  Impl& m = *impl_;
  if (m.draining || m.stopping) return Error(ServiceCode::kUnavailable, "the server is shutting down");
  {
    std::lock_guard lock(m.storage_mu);
    if (!m.paused.empty()) return Error(ServiceCode::kUnavailable, m.paused.rbegin()->second);
  }
  if (const long long free = FreeBytes(m.options.data_dir); free >= 0 && free < kReadyFreeBytes)
    return Error(ServiceCode::kUnavailable, "the server's disk is full (data folder " + m.options.data_dir + ", " + std::to_string(free) + " bytes free)");
  return ServiceStatus::Ok();
}

std::string JobService::MetricsText() {
  std::map<std::string, double> by_state;
  for (int s = v1::JobState_MIN; s <= v1::JobState_MAX; ++s)
    if (v1::JobState_IsValid(s) && s != v1::JOB_STATE_UNSPECIFIED) by_state[v1::JobState_Name(static_cast<v1::JobState>(s))] = 0;
  const std::map<v1::JobState, int64_t> counts = impl_->store->CountByState();
  for (const auto& [state, n] : counts) by_state[v1::JobState_Name(state)] = static_cast<double>(n);
  const auto queued = counts.find(v1::QUEUED);
  return impl_->metrics.Text(by_state, queued == counts.end() ? 0 : static_cast<double>(queued->second));
}

ServiceStatus JobService::ListScenes(v1::ListScenesResponse* out) {
  const MachineFactor machine = [&] {
    std::lock_guard lock(impl_->calibration_mu);
    return ReadMachineFactor(impl_->CostCalibrationFile());
  }();
  out->set_machine_factor(machine.factor);
  out->set_machine_factor_jobs(machine.jobs);
  out->set_max_iterations(impl_->options.limits.max_iterations);
  for (const BuiltinSceneInfo& s : BuiltinSceneInfos()) {
    v1::BuiltinScene* b = out->add_scenes();
    b->set_name(s.name);
    b->set_garment(s.garment);
    b->set_description(s.description);
    b->set_budget(s.budget);
    b->set_frames(s.frames);
    b->set_subdivisions(s.subdivisions);
    b->set_parametric_body(s.parametric_body);
    b->set_garment_faces(s.garment_faces);
    b->set_garment_area_m2(s.garment_area_m2);
    for (const BuiltinSceneInfo::Motion& m : s.motions) {
      v1::BuiltinSceneMotion* bm = b->add_motions();
      bm->set_name(m.name);
      bm->set_role(ToString(m.role));
      bm->set_weight(m.weight);
    }
    b->set_symmetric(s.symmetric);
    b->set_body_objective(s.body_objective);
    for (const auto& [preset, seconds] : PredictedSceneSeconds(s, machine.factor)) (*b->mutable_predicted_job_s())[preset] = seconds;
  }
  for (const MeasurementRange& r : BodyMeasurementRanges()) {
    v1::BodyMeasurement* m = out->add_body_measurements();
    m->set_name(r.name);
    m->set_default_value(r.default_value);
    m->set_min(r.min);
    m->set_max(r.max);
  }
  return ServiceStatus::Ok();
}

ServiceStatus JobService::GetJob(const Caller& caller, int64_t id, v1::Job* out) { return impl_->FindJob(caller, id, out); }

ServiceStatus JobService::ListJobs(const Caller& caller, const v1::ListJobsRequest& req, v1::ListJobsResponse* out) {
  Impl& m = *impl_;
  if (caller.role == Role::kWorker) return Error(ServiceCode::kPermissionDenied, "a worker's token cannot list jobs");
  if (req.page_size() < 0) return Error(ServiceCode::kInvalidArgument, "page_size: must not be negative");
  const int size = req.page_size() == 0 ? 50 : std::min(req.page_size(), 1000);
  int64_t before = 0;
  if (!req.page_token().empty()) {
    char* end = nullptr;
    before = std::strtoll(req.page_token().c_str(), &end, 10);
    if (*end != '\0' || before <= 0) return Error(ServiceCode::kInvalidArgument, "page_token: not a token from ListJobs");
  }
  Result<std::vector<v1::Job>> jobs = m.store->ListJobs(req.state_filter(), before, size,
                                                             caller.role == Role::kUser ? std::optional<std::string>(caller.user) : std::nullopt);
  if (!jobs.ok()) return Internal(jobs.status());
  for (v1::Job& j : *jobs) {
    m.Decorate(&j);
    *out->add_jobs() = std::move(j);
  }
  if (static_cast<int>(out->jobs_size()) == size) out->set_next_page_token(std::to_string(out->jobs(size - 1).id()));
  return ServiceStatus::Ok();
}

ServiceStatus JobService::CancelJob(const Caller& caller, int64_t id, v1::Job* out) {
  Impl& m = *impl_;
  v1::Job visible;
  if (ServiceStatus st = m.FindJob(caller, id, &visible); !st.ok()) return st;
  Result<std::optional<v1::Job>> job = m.store->Cancel(id, Now());
  if (!job.ok() && !m.StorageFault(job.status()).empty())
    return Error(ServiceCode::kUnavailable, "job " + std::to_string(id) + " cannot be cancelled now: " + m.StorageFault(job.status()) +
                                                "; cancel it again once the server can store (the job waits, paused, meanwhile)");
  if (!job.ok()) return Internal(job.status());
  if (!*job) return Error(ServiceCode::kNotFound, "job " + std::to_string(id) + " does not exist");
  *out = **job;
  m.Decorate(out);
  m.Log("job " + std::to_string(id) + ": cancel requested");
  m.Notify();
  return ServiceStatus::Ok();
}

ServiceStatus JobService::CanWatch(const Caller& caller, int64_t id) {
  Impl& m = *impl_;
  v1::Job job;
  if (ServiceStatus st = m.FindJob(caller, id, &job); !st.ok()) return st;
  std::lock_guard lock(m.limits_mu);
  return m.WatchLimit(id);
}

ServiceStatus JobService::TakeWatchPlace(WatchPlace* place) {
  Impl& m = *impl_;
  const int limit = m.options.limits.max_held_watches;
  std::lock_guard lock(m.limits_mu);
  if (limit > 0 && m.held_watches >= limit)
    return Error(ServiceCode::kResourceExhausted,
                 "the server has its limit of " + std::to_string(limit) + " open watches (--max-watchers); try again later");
  ++m.held_watches;
  *place = WatchPlace(nullptr, [&m](const void*) {
    std::lock_guard lock(m.limits_mu);
    --m.held_watches;
  });
  return ServiceStatus::Ok();
}

ServiceStatus JobService::WatchJob(const Caller& caller, const v1::WatchJobRequest& req, const std::function<bool(const v1::WatchJobEvent&)>& write,
                                   const std::function<bool()>& cancelled) {
  Impl& m = *impl_;
  if (req.from_iteration() < 0) return Error(ServiceCode::kInvalidArgument, "from_iteration: must not be negative");
  v1::Job job;
  if (ServiceStatus st = m.FindJob(caller, req.id(), &job); !st.ok()) return st;
  {
    std::lock_guard lock(m.limits_mu);
    if (ServiceStatus st = m.WatchLimit(req.id()); !st.ok()) return st;
    ++m.watchers[req.id()];
  }
  m.metrics.WatcherOpened();
  struct Closed {
    Impl& m;
    int64_t id;
    ~Closed() {
      m.metrics.WatcherClosed();
      std::lock_guard lock(m.limits_mu);
      if (--m.watchers[id] <= 0) m.watchers.erase(id);
    }
  } closed{m, req.id()};
  v1::WatchJobEvent first;
  *first.mutable_job() = job;
  if (!write(first)) return ServiceStatus::Ok();
  v1::JobState sent_state = job.state();
  bool sent_ended = !job.ended().empty();
  bool sent_paused = !job.paused().empty();
  int next = req.from_iteration();
  uint64_t seen = m.CurrentVersion();
  while (!cancelled() && !m.stopping) {
    // One snapshot (state, count, end) decides both what to send and whether the stream is complete.
    const std::optional<JobProgress> progress = m.store->Progress(req.id());
    if (!progress) return Error(ServiceCode::kNotFound, "job " + std::to_string(req.id()) + " does not exist");
    const auto [state, stored, ended] = *progress;
    for (; next < stored; ++next) {
      Result<std::shared_ptr<const v1::IterationRecord>> rec = m.StoredIteration(req.id(), next);
      if (!rec.ok()) return Internal(rec.status());
      v1::WatchJobEvent ev;
      *ev.mutable_iteration() = **rec;
      if (req.with_positions()) {
        Result<BesoIteration> arrays = m.ReadArrays(req.id(), next);
        if (!arrays.ok()) return m.DesignFileError(req.id(), arrays.status());
        for (Eigen::Index i = 0; i < arrays->positions.size(); ++i) ev.mutable_iteration()->add_positions(arrays->positions.data()[i]);
      }
      if (!write(ev)) return ServiceStatus::Ok();
    }
    // A state change, the design loop's end (the job's phase turns to EVALUATING), a pause or its end.
    const bool paused = !m.PausedReason(req.id()).empty();
    if (state != sent_state || ended != sent_ended || paused != sent_paused) {
      if (ServiceStatus st = m.FindJob(caller, req.id(), &job); !st.ok()) return st;
      v1::WatchJobEvent ev;
      *ev.mutable_job() = job;
      if (!write(ev)) return ServiceStatus::Ok();
      sent_state = job.state();
      sent_ended = !job.ended().empty();
      sent_paused = !job.paused().empty();
    }
    if (IsTerminal(state) && next >= stored) return ServiceStatus::Ok();
    seen = m.WaitEvent(seen, 1.0);
  }
  return Error(ServiceCode::kCancelled, "the watch ended (client gone or server stopping)");
}

ServiceStatus JobService::GetIteration(const Caller& caller, const v1::GetIterationRequest& req, v1::GetIterationResponse* out) {
  Impl& m = *impl_;
  v1::Job job;
  if (ServiceStatus st = m.FindJob(caller, req.id(), &job); !st.ok()) return st;
  const int k = req.iteration() < 0 ? job.iterations() - 1 : req.iteration();
  if (k < 0 || k >= job.iterations())
    return Error(ServiceCode::kNotFound, "job " + std::to_string(req.id()) + ": iteration " + std::to_string(req.iteration()) +
                                             " is not stored (" + (job.iterations() ? "0.." + std::to_string(job.iterations() - 1) : "none yet") + ")");
  std::lock_guard lock(m.commit_mu);
  Result<DesignFile> f = ReadDesignFile(m.FilePath(req.id()), {.arrays = true, .only_iteration = k});
  if (!f.ok()) return m.DesignFileError(req.id(), f.status());
  if (k >= static_cast<int>(f->iterations.size())) return Error(ServiceCode::kInternal, "design file misses iteration " + std::to_string(k));
  *out->mutable_record() = RecordToProto(f->iterations[k]);
  if (req.with_garment()) *out->mutable_garment() = GarmentToProto(f->header);
  return ServiceStatus::Ok();
}

ServiceStatus JobService::GetEvaluation(const Caller& caller, int64_t id, v1::DesignEvaluation* out) {
  Impl& m = *impl_;
  v1::Job job;
  if (ServiceStatus st = m.FindJob(caller, id, &job); !st.ok()) return st;
  const std::string path = EvaluationPath(m.FilePath(id));
  if (!fs::exists(path))
    return Error(ServiceCode::kNotFound, "job " + std::to_string(id) + " has no evaluation" +
                                             (job.state() == v1::QUEUED || job.state() == v1::RUNNING ? " yet (it comes after the last iteration)" : ""));
  Result<DesignEvaluation> e = ReadDesignEvaluation(path);
  if (!e.ok()) return Internal(e.status());
  *out = EvaluationToProto(*e);
  return ServiceStatus::Ok();
}

ServiceStatus JobService::GetGarment(const Caller& caller, int64_t id, v1::Garment* out) {
  Impl& m = *impl_;
  v1::Job job;
  if (ServiceStatus st = m.FindJob(caller, id, &job); !st.ok()) return st;
  if (job.iterations() == 0)
    return Error(ServiceCode::kNotFound, "job " + std::to_string(id) + " has no garment yet (it has no iteration; watch it until the first arrives)");
  std::lock_guard lock(m.commit_mu);
  Result<DesignFile> f = ReadDesignFile(m.FilePath(id), {.arrays = false});
  if (!f.ok()) return m.DesignFileError(id, f.status());
  *out = GarmentToProto(f->header);
  return ServiceStatus::Ok();
}

ServiceStatus JobService::GetDesignFile(const Caller& caller, int64_t id, std::string* bytes) {
  Impl& m = *impl_;
  v1::Job job;
  if (ServiceStatus st = m.FindJob(caller, id, &job); !st.ok()) return st;
  if (job.state() == v1::QUEUED || job.state() == v1::RUNNING)
    return Error(ServiceCode::kFailedPrecondition, "job " + std::to_string(id) + " is " + v1::JobState_Name(job.state()) +
                                                       ": its design file is still being written; download it once the job has ended (an iteration's PLY is ready now)");
  if (job.iterations() == 0) return Error(ServiceCode::kNotFound, "job " + std::to_string(id) + " has no design file (it stored no iteration)");
  // Verified before it is served: a damaged file is named, not sent.
  std::unique_lock lock(m.commit_mu);
  if (Result<DesignFileCheck> check = CheckDesignFile(m.FilePath(id)); !check.ok() || !check->ok())
    return m.DesignFileError(id, check.ok() ? Status::Error(check->first_damage) : check.status());
  lock.unlock();
  std::ifstream in(m.FilePath(id), std::ios::binary);
  if (!in) return m.DesignFileError(id, Status::Error(m.FilePath(id) + ": cannot be opened"));
  std::ostringstream contents;
  contents << in.rdbuf();
  *bytes = std::move(contents).str();
  return ServiceStatus::Ok();
}

ServiceStatus JobService::ExportDesign(const Caller& caller, const v1::ExportDesignRequest& req, v1::ExportDesignResponse* out,
                                       const std::function<void(const v1::ExportProgress&)>& progress) {
  Impl& m = *impl_;
  v1::Job job;
  if (ServiceStatus st = m.FindJob(caller, req.id(), &job); !st.ok()) return st;
  const int k = req.iteration() < 0 ? job.iterations() - 1 : req.iteration();
  if (k < 0 || k >= job.iterations())
    return Error(ServiceCode::kNotFound, "job " + std::to_string(req.id()) + ": iteration " + std::to_string(req.iteration()) + " is not stored (" +
                                             (job.iterations() ? "0.." + std::to_string(job.iterations() - 1) : "none yet") + ")");
  ExportOptions o;
  if (req.has_min_feature_mm()) o.cleaning.min_feature_m = req.min_feature_mm() / 1000;
  if (req.has_seam_allowance_mm()) o.sheet.seam_allowance_mm = req.seam_allowance_mm();
  if (req.has_sheet_width_mm()) o.sheet.sheet_width_mm = req.sheet_width_mm();
  o.sheet.mirror = !req.no_mirror();
  if (progress)
    o.progress = [&progress](const std::string& stage, double fraction) {
      v1::ExportProgress p;
      p.set_stage(stage);
      p.set_fraction(fraction);
      progress(p);
    };
  // The worker simulated the job's last design cleaned at the default options (CleanedDesign): an export
  // of it with that cleaning reports the figures.
  std::optional<v1::CleanedDesign> simulated;
  if (Result<std::optional<v1::CleanedDesign>> c = m.store->Cleaned(req.id());
      c.ok() && *c && (*c)->iteration() == k && (*c)->min_feature_m() == o.cleaning.min_feature_m && o.cleaning.min_area_m2 == 0)
    simulated = **c;
  // The caller may see this job (FindJob above): a cached export of it is theirs to have.
  char key[160];
  std::snprintf(key, sizeof key, "%lld/%d/%.17g/%.17g/%.17g/%d/%zx", static_cast<long long>(req.id()), k, o.cleaning.min_feature_m,
                o.sheet.seam_allowance_mm, o.sheet.sheet_width_mm, o.sheet.mirror ? 1 : 0,
                simulated ? std::hash<std::string>()(simulated->SerializeAsString()) : size_t(0));
  std::shared_ptr<const ExportFiles> files;
  std::shared_future<Impl::ExportOutcome> in_progress;
  std::promise<Impl::ExportOutcome> made_here;
  {
    std::lock_guard lock(m.exports_mu);
    const auto it = std::find_if(m.exports.begin(), m.exports.end(), [&](const auto& e) { return e.first == key; });
    if (it != m.exports.end()) {
      files = it->second;
      std::rotate(m.exports.begin(), it, it + 1);
    } else if (const auto pending = m.exports_in_progress.find(key); pending != m.exports_in_progress.end()) {
      in_progress = pending->second;
    } else {
      m.exports_in_progress.emplace(key, made_here.get_future().share());
    }
  }
  if (in_progress.valid()) {
    // get() throws where the maker could not even hand over an outcome (a broken promise): nothing
    // throws across the service boundary.
    try {
      const Impl::ExportOutcome& outcome = in_progress.get();
      if (!outcome.status.ok()) return outcome.status;
      files = outcome.files;
    } catch (const std::exception& e) {
      return Error(ServiceCode::kInternal, "job " + std::to_string(req.id()) + ": the export failed: " + e.what());
    }
  }
  if (files) {
    m.metrics.ExportServed(/*from_cache=*/true);
  } else {
    // Every way out of making it gives the requests waiting for it an outcome (an exception, such as an
    // allocation failing, included), so none waits forever and the next request may try again.
    const Impl::ExportOutcome outcome = [&]() -> Impl::ExportOutcome {
      try {
        Result<DesignFile> f = [&] {
          std::lock_guard lock(m.commit_mu);
          return ReadDesignFile(m.FilePath(req.id()), {.arrays = true, .only_iteration = k});
        }();
        if (!f.ok()) return {m.DesignFileError(req.id(), f.status()), nullptr};
        Result<ExportFiles> made = ExportGeometry(f->header, f->iterations[k], o);
        if (!made.ok()) return {Error(ServiceCode::kInvalidArgument, "job " + std::to_string(req.id()) + ": " + made.message()), nullptr};
        if (simulated) ApplyCleanedSimulation(*simulated, &*made);
        return {ServiceStatus::Ok(), std::make_shared<const ExportFiles>(std::move(made).value())};
      } catch (const std::exception& e) {
        return {Error(ServiceCode::kInternal, "job " + std::to_string(req.id()) + ": the export failed: " + e.what()), nullptr};
      }
    }();
    {
      std::lock_guard lock(m.exports_mu);
      m.exports_in_progress.erase(key);
      if (outcome.status.ok()) {
        try {
          m.exports.insert(m.exports.begin(), {key, outcome.files});
          if (m.exports.size() > Impl::kExportsKept) m.exports.pop_back();
        } catch (const std::exception&) {
          // The cache only saves work: an export it could not keep is made again when asked for.
        }
      }
    }
    made_here.set_value(outcome);
    if (!outcome.status.ok()) return outcome.status;
    files = outcome.files;
    m.metrics.ExportServed(/*from_cache=*/false);  // counted once made: a failed export is no export
  }
  for (const auto& [name, contents] : files->files) (*out->mutable_files())[name] = contents;
  return ServiceStatus::Ok();
}

ServiceStatus JobService::LeaseJob(const Caller& caller, const v1::LeaseJobRequest& req, v1::LeaseJobResponse* out,
                                   const std::function<bool()>& cancelled) {
  Impl& m = *impl_;
  if (caller.role == Role::kUser) return Error(ServiceCode::kPermissionDenied, "only a worker's token may lease jobs");
  if (req.has_speed()) m.LearnFromWorkerSpeed(req.speed(), req.worker());
  const double deadline = SteadyNow() + std::clamp(req.wait_s(), 0.0, 60.0);
  uint64_t seen = m.CurrentVersion();
  while (!m.draining && !m.stopping && !cancelled()) {
    {
      std::lock_guard lock(m.commit_mu);
      Result<std::optional<Lease>> lease = m.store->LeaseNext(req.worker(), req.kernels(), StoreNow(), m.options.lease_duration_s);
      if (!lease.ok()) return Internal(lease.status());
      if (*lease) {
        const Lease& l = **lease;
        m.files.erase(l.job_id);  // a writer left by a lost lease
        out->set_leased(true);
        out->set_lease_id(l.lease_id);
        out->set_job_id(l.job_id);
        *out->mutable_spec() = l.spec;
        out->set_attempt(l.attempt);
        out->set_lease_duration_s(m.options.lease_duration_s);
        if (l.iterations > 0) {
          Result<std::vector<v1::IterationMetrics>> history = m.store->Metrics(l.job_id, 0, l.iterations);
          Result<DesignFile> f = ReadDesignFile(m.FilePath(l.job_id), {.arrays = true, .only_iteration = l.iterations - 1});
          if (!f.ok()) {
            // A file whose writer's last write failed (marked open for write, or torn) is rebuilt from
            // the iterations that read back, cut to the acknowledged ones, and read again.
            Result<std::unique_ptr<DesignFileWriter>> repaired = DesignFileWriter::Reopen(m.FilePath(l.job_id), l.iterations);
            if (repaired.ok()) {
              repaired->reset();
              f = ReadDesignFile(m.FilePath(l.job_id), {.arrays = true, .only_iteration = l.iterations - 1});
            } else if (!m.StorageFault(repaired.status()).empty()) {
              // The disk fails the repair: the job waits in the queue (this lease counts as an attempt).
              m.StorageFailed();
              m.store->EndLease(l.job_id, l.lease_id, v1::QUEUED, "cannot resume yet: " + repaired.message(), Now());
              m.Notify();
              return Error(ServiceCode::kUnavailable, "job " + std::to_string(l.job_id) + " cannot resume yet: " + repaired.message());
            }
          }
          if (!history.ok() || !f.ok() || static_cast<int>(f->iterations.size()) < l.iterations) {
            const std::string why = !history.ok() ? history.message() : !f.ok() ? f.message() : "the design file misses iterations";
            m.store->EndLease(l.job_id, l.lease_id, v1::FAILED, "cannot resume: " + why, Now());
            m.Notify();
            return Error(ServiceCode::kInternal, "job " + std::to_string(l.job_id) + " cannot resume: " + why);
          }
          for (const v1::IterationMetrics& h : *history) *out->add_history() = h;
          *out->mutable_last() = RecordToProto(f->iterations[l.iterations - 1]);
        }
        m.Log("job " + std::to_string(l.job_id) + " leased to " + req.worker() + " (attempt " + std::to_string(l.attempt) + ", from iteration " +
              std::to_string(l.iterations) + ", kernels " + (req.kernels().empty() ? "unknown" : req.kernels()) + ")");
        m.Notify();
        return ServiceStatus::Ok();
      }
    }
    const double left = deadline - SteadyNow();
    if (left <= 0) break;
    seen = m.WaitEvent(seen, left);
  }
  out->set_leased(false);
  return ServiceStatus::Ok();
}

ServiceStatus JobService::RunJob(const Caller& caller, const std::function<bool(v1::WorkerMessage*)>& read,
                                 const std::function<bool(const v1::ServerMessage&)>& write, const std::function<bool()>& cancelled) {
  Impl& m = *impl_;
  if (caller.role == Role::kUser) return Error(ServiceCode::kPermissionDenied, "only a worker's token may run jobs");
  v1::WorkerMessage msg;
  if (!read(&msg)) return ServiceStatus::Ok();
  const std::string lease_id = msg.lease_id();
  const int64_t job_id = std::atoll(lease_id.c_str());
  if (job_id <= 0 || !m.store->LeaseValid(job_id, lease_id)) {
    v1::ServerMessage reply;
    reply.set_error("lease '" + lease_id + "' is not held");
    write(reply);
    return Error(ServiceCode::kFailedPrecondition, reply.error());
  }
  ++m.active_streams;
  // How the lease ends when the stream does: by default the worker is lost and the job queued again.
  v1::JobState end = v1::QUEUED;
  std::string failure = "the worker disconnected";
  bool started = false, ended = false;
  // What the server cannot store for want of space (or a failing disk) is tried again, the job paused
  // meanwhile with its lease kept, until it is stored or the worker, the server or a cancel ends it.
  const auto give_up = [&] { return cancelled() || m.draining || m.store->CancelRequested(job_id); };
  const auto store_or_pause = [&](const std::function<Status()>& store_it) { return m.StoreOrPause(job_id, store_it, give_up); };
  do {
    v1::ServerMessage reply;
    std::string refused;
    if (msg.has_heartbeat()) {
      Result<bool> renewed = m.store->Renew(job_id, lease_id, SteadyNow(), m.options.lease_duration_s);
      if (!renewed.ok() && m.StorageFault(renewed.status()).empty()) refused = renewed.message();
      else if (!renewed.ok()) m.StorageFailed();  // neither renewed nor lost: no lease expires meanwhile
      else if (!*renewed) refused = "the lease on job " + std::to_string(job_id) + " is no longer held";
    } else if (msg.has_start()) {
      if (Status st = started ? Status::Ok() : m.CheckResumeKernels(job_id, msg.start()); !st.ok()) {
        refused = st.message();  // the job is queued again, for a worker of its level
      } else if (st = started ? Status::Error("a second start report")
                              : store_or_pause([&] { return m.OpenJobFile(job_id, lease_id, msg.start()); });
                 !st.ok()) {
        refused = st.message();
        end = v1::FAILED;  // a worker that cannot describe its garment, or a file that cannot be written
        if (!m.StorageFault(st).empty()) end = v1::QUEUED, failure = st.message();  // given up while paused: it resumes later
      }
      started = true;
    } else if (msg.has_iteration()) {
      if (Status st = store_or_pause([&] { return m.Commit(job_id, lease_id, msg.iteration()); }); !st.ok()) refused = st.message();
      else {
        m.Notify();  // watchers first: the lease renewal is one more SQLite commit
        if (Result<bool> renewed = m.store->Renew(job_id, lease_id, SteadyNow(), m.options.lease_duration_s); !renewed.ok()) m.StorageFailed();
      }
    } else if (msg.has_ended()) {
      if (Status st = started ? store_or_pause([&] { return m.store->SetEnded(job_id, lease_id, msg.ended()); })
                              : Status::Error("an end report before start");
          !st.ok())
        refused = st.message();
      else
        m.Notify();  // watchers: the job's phase is now EVALUATING
    } else if (msg.has_cleaned()) {
      // An extra after the last iteration, as the evaluation: one that cannot be stored is logged.
      if (Status st = store_or_pause([&] { return m.store->SetCleaned(job_id, lease_id, msg.cleaned()); }); !st.ok())
        m.Log("job " + std::to_string(job_id) + ": cleaned design not stored: " + st.message());
    } else if (msg.has_evaluation()) {
      // An extra after the last iteration: one that cannot be stored is logged, and the job goes on.
      int faces = 0, vertices = 0;
      {
        std::lock_guard lock(m.commit_mu);
        auto it = m.files.find(job_id);
        if (it != m.files.end() && it->second.writer) faces = it->second.writer->faces(), vertices = it->second.writer->vertices();
      }
      Result<DesignEvaluation> e = faces ? EvaluationFromProto(msg.evaluation(), faces, vertices) : Status::Error("no design file is open");
      Status st = e.ok() ? store_or_pause([&] { return WriteDesignEvaluation(EvaluationPath(m.FilePath(job_id)), *e); }) : e.status();
      if (!st.ok()) m.Log("job " + std::to_string(job_id) + ": evaluation not stored: " + st.message());
    } else if (msg.has_complete()) {
      end = started ? v1::SUCCEEDED : v1::FAILED, failure = started ? "" : "completed without starting", ended = true;
    } else if (msg.has_fail()) {
      end = v1::FAILED, failure = msg.fail(), ended = true;
    } else if (msg.has_release()) {
      end = v1::QUEUED, failure.clear(), ended = true;
    }
    if (!refused.empty()) {
      reply.set_error(refused);
      write(reply);
      failure = refused;
      break;
    }
    if (!ended) {
      std::lock_guard lock(m.commit_mu);
      auto it = m.files.find(job_id);
      reply.set_acknowledged_iterations(it == m.files.end() || !it->second.writer ? 0 : it->second.writer->num_iterations());
      reply.set_cancel(m.store->CancelRequested(job_id));
      reply.set_drain(m.draining);
      write(reply);
    }
  } while (!ended && read(&msg));
  m.CloseFile(job_id, lease_id);
  // The job's end is stored whenever the store can (a full disk pauses the job until then), or given up
  // when the server drains: the lease it leaves is released when the server starts again, and the job
  // queued (a server told to stop on a full disk stops).
  Result<v1::JobState> state = v1::JOB_STATE_UNSPECIFIED;
  m.StoreOrPause(
      job_id,
      [&] {
        state = m.store->EndLease(job_id, lease_id, end, failure, Now());
        return state.status();
      },
      [&] { return m.draining.load(); });
  if (state.ok()) m.Log("job " + std::to_string(job_id) + " " + v1::JobState_Name(*state) + (failure.empty() ? "" : " (" + failure + ")"));
  if (state.ok() && *state == v1::SUCCEEDED) m.LearnFromFinishedJob(job_id);
  m.Notify();
  --m.active_streams;
  return cancelled() ? Error(ServiceCode::kCancelled, "stream ended") : ServiceStatus::Ok();
}

void JobService::Drain(double timeout_s) {
  Impl& m = *impl_;
  m.draining = true;
  m.Notify();
  m.Log("draining: no new leases; running jobs stop after their current iteration");
  const double deadline = SteadyNow() + timeout_s;
  while (m.active_streams > 0 && SteadyNow() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(20));
}

void JobService::Stop() {
  Impl& m = *impl_;
  m.stopping = true;
  m.Notify();
}

void JobService::Close() {
  Impl& m = *impl_;
  Stop();
  {
    std::lock_guard lock(m.stop_mu);
    if (m.closed) return;
    m.closed = true;
  }
  if (m.expiry.joinable()) m.expiry.join();
  std::lock_guard lock(m.commit_mu);
  m.files.clear();
}

}  // namespace kgd::server
