#include "server/job_store.h"

#include "core/util/fault_point.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <random>
#include <set>

namespace kgd::server {
namespace {

using google::protobuf::FieldDescriptor;

// Migrations: entry k takes a database from version k to k + 1. Never edit one that has shipped; add
// the next.
const char* const kMigrations[] = {
    R"sql(
CREATE TABLE jobs (
  id               INTEGER PRIMARY KEY AUTOINCREMENT,
  spec             BLOB    NOT NULL,            -- kgd.v1.JobSpec, serialized
  state            INTEGER NOT NULL,            -- kgd.v1.JobState
  create_time_s    REAL    NOT NULL,
  update_time_s    REAL    NOT NULL,
  attempts         INTEGER NOT NULL DEFAULT 0,
  max_attempts     INTEGER NOT NULL,
  iterations       INTEGER NOT NULL DEFAULT 0,  -- rows in iterations: 0..iterations-1
  failure          TEXT    NOT NULL DEFAULT '',
  cancel_requested INTEGER NOT NULL DEFAULT 0,
  lease_id         TEXT,
  lease_worker     TEXT,
  lease_expire_s   REAL,                        -- the server's monotonic clock (StoreTime::lease_s)
  garment_faces    INTEGER NOT NULL DEFAULT 0
);
CREATE INDEX jobs_by_state ON jobs(state, id);
CREATE TABLE iterations (
  job_id                      INTEGER NOT NULL REFERENCES jobs(id),
  iteration                   INTEGER NOT NULL,
  target_area_m2              REAL NOT NULL,
  area_fraction               REAL NOT NULL,
  energy_J                    REAL NOT NULL,
  reinforced_energy_J         REAL NOT NULL,
  reinforced_density_J_per_m2 REAL NOT NULL,
  density_ratio               REAL NOT NULL,
  solve_status                TEXT NOT NULL,
  solver_iterations           INTEGER NOT NULL,
  cold_restart                INTEGER NOT NULL,
  simulation_s                REAL NOT NULL,
  sensitivity_s               REAL NOT NULL,
  filter_s                    REAL NOT NULL,
  update_s                    REAL NOT NULL,
  total_s                     REAL NOT NULL,
  report_time_s               REAL NOT NULL,
  design                      BLOB NOT NULL,  -- one byte per garment face, 1 = reinforced
  PRIMARY KEY (job_id, iteration)
) WITHOUT ROWID;
)sql",
    R"sql(
ALTER TABLE jobs ADD COLUMN owner TEXT NOT NULL DEFAULT '';
CREATE INDEX jobs_by_owner ON jobs(owner, id);
)sql",
    R"sql(
ALTER TABLE iterations ADD COLUMN assembly_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN factorization_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN linear_solve_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN line_search_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN body_field_query_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN membrane_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN fold_barrier_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN attachment_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN contact_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN friction_s REAL NOT NULL DEFAULT 0;
ALTER TABLE iterations ADD COLUMN bending_s REAL NOT NULL DEFAULT 0;
)sql",
    R"sql(
CREATE TABLE iteration_motions (
  job_id                      INTEGER NOT NULL,
  iteration                   INTEGER NOT NULL,
  motion                      INTEGER NOT NULL,  -- 0-based, in the scene's order (0: the scene's own)
  name                        TEXT NOT NULL,
  role                        TEXT NOT NULL,     -- "resist" or "allow"
  weight                      REAL NOT NULL,
  energy_J                    REAL NOT NULL,
  reinforced_energy_J         REAL NOT NULL,
  reinforced_density_J_per_m2 REAL NOT NULL,
  density_ratio               REAL NOT NULL,
  simulation_s                REAL NOT NULL,
  solver_iterations           INTEGER NOT NULL,
  PRIMARY KEY (job_id, iteration, motion),
  FOREIGN KEY (job_id, iteration) REFERENCES iterations(job_id, iteration)
) WITHOUT ROWID;
)sql",
    R"sql(
ALTER TABLE jobs ADD COLUMN ended TEXT NOT NULL DEFAULT '';    -- how the design loop ended (Job.ended)
ALTER TABLE jobs ADD COLUMN cleaned BLOB NOT NULL DEFAULT '';  -- kgd.v1.CleanedDesign, serialized; empty: none
)sql",
    // Iterations stored before the level was recorded ran the one pin kgd had then: x86-64.
    R"sql(
ALTER TABLE jobs ADD COLUMN kernels TEXT NOT NULL DEFAULT '';  -- Job.kernels: the level its iterations are computed at
UPDATE jobs SET kernels = 'x86-64' WHERE iterations > 0;
)sql",
};
constexpr int kNumMigrations = sizeof(kMigrations) / sizeof(kMigrations[0]);
static_assert(kNumMigrations == kSchemaVersion);

class Stmt {
 public:
  Stmt(sqlite3* db, const std::string& sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s_, nullptr) != SQLITE_OK) error_ = sqlite3_errmsg(db);
  }
  ~Stmt() { sqlite3_finalize(s_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  // A value that cannot be bound makes the statement fail at Step, with SQLite's reason.
  Stmt& Bind(int i, int64_t v) { return Check(sqlite3_bind_int64(s_, i, v)); }
  Stmt& Bind(int i, int v) { return Check(sqlite3_bind_int64(s_, i, v)); }
  Stmt& Bind(int i, double v) { return Check(sqlite3_bind_double(s_, i, v)); }
  Stmt& Bind(int i, const std::string& v) { return Check(sqlite3_bind_text(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT)); }
  Stmt& BindBlob(int i, const std::string& v) { return Check(sqlite3_bind_blob(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT)); }
  // SQLITE_ROW, SQLITE_DONE, or an error code (error() then says what).
  int Step() {
    if (!ok()) return SQLITE_ERROR;
    const int rc = sqlite3_step(s_);
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) error_ = sqlite3_errmsg(db_);
    return rc;
  }
  bool Run() { return Step() == SQLITE_DONE; }
  // Ready to run again with new values.
  void Reset() {
    sqlite3_reset(s_);
    sqlite3_clear_bindings(s_);
  }
  int64_t Int(int c) const { return sqlite3_column_int64(s_, c); }
  double Real(int c) const { return sqlite3_column_double(s_, c); }
  std::string Text(int c) const {
    const void* p = sqlite3_column_blob(s_, c);
    return p ? std::string(static_cast<const char*>(p), sqlite3_column_bytes(s_, c)) : std::string();
  }
  sqlite3_stmt* get() { return s_; }

 private:
  Stmt& Check(int rc) {
    if (rc != SQLITE_OK && error_.empty()) error_ = std::string("binding a value: ") + sqlite3_errstr(rc);
    return *this;
  }
  sqlite3* db_;
  sqlite3_stmt* s_ = nullptr;
  std::string error_;
};

// A message's single-valued fields, in declaration order, but `skip`: its columns (a list, such as
// IterationMetrics' per-motion figures, has none).
std::vector<const FieldDescriptor*> ColumnFields(const google::protobuf::Descriptor* d, const std::string& skip = "") {
  std::vector<const FieldDescriptor*> out;
  for (int i = 0; i < d->field_count(); ++i)
    if (d->field(i)->name() != skip && !d->field(i)->is_repeated() && d->field(i)->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE)
      out.push_back(d->field(i));
  return out;
}

// The metric columns of `iterations`: IterationMetrics' fields other than `iteration`.
std::vector<const FieldDescriptor*> MetricFields() { return ColumnFields(v1::IterationMetrics::descriptor(), "iteration"); }
// The figure columns of `iteration_motions`: every MotionMetrics field.
std::vector<const FieldDescriptor*> MotionFields() { return ColumnFields(v1::MotionMetrics::descriptor()); }

std::string Columns(const std::vector<const FieldDescriptor*>& fields) {
  std::string s;
  for (const FieldDescriptor* f : fields) s += ", " + f->name();
  return s;
}
std::string MetricColumns() { return Columns(MetricFields()); }

// Binds field `f` of `m` to parameter k (double, int32 or string: the kinds the metric messages have).
void BindField(Stmt& s, int k, const google::protobuf::Message& m, const FieldDescriptor* f) {
  const auto* refl = m.GetReflection();
  switch (f->cpp_type()) {
    case FieldDescriptor::CPPTYPE_DOUBLE: s.Bind(k, refl->GetDouble(m, f)); break;
    case FieldDescriptor::CPPTYPE_INT32: s.Bind(k, refl->GetInt32(m, f)); break;
    default: s.Bind(k, refl->GetString(m, f)); break;
  }
}

// Sets field `f` of `m` from column c.
void ReadField(const Stmt& s, int c, google::protobuf::Message* m, const FieldDescriptor* f) {
  const auto* refl = m->GetReflection();
  switch (f->cpp_type()) {
    case FieldDescriptor::CPPTYPE_DOUBLE: refl->SetDouble(m, f, s.Real(c)); break;
    case FieldDescriptor::CPPTYPE_INT32: refl->SetInt32(m, f, static_cast<int32_t>(s.Int(c))); break;
    default: refl->SetString(m, f, s.Text(c)); break;
  }
}

Status SqlError(const std::string& what, const std::string& error) { return Status::Error("job store: " + what + ": " + error); }

// Sets one column of a running job whose lease is `lease_id` (the caller holds the store's lock); `what`
// names it in errors. A blob is bound as bytes, anything else as text.
Status SetLeasedJobColumn(sqlite3* db, int64_t job_id, const std::string& lease_id, const char* column, const std::string& value, bool blob,
                          const char* what) {
  Stmt s(db, std::string("UPDATE jobs SET ") + column + " = ? WHERE id = ? AND lease_id = ? AND state = ?");
  if (blob) s.BindBlob(1, value);
  else s.Bind(1, value);
  s.Bind(2, job_id).Bind(3, lease_id).Bind(4, static_cast<int>(v1::RUNNING));
  if (!s.Run()) return SqlError(what, s.error());
  if (sqlite3_changes(db) == 0) return Status::Error("the lease on job " + std::to_string(job_id) + " is no longer held");
  return Status::Ok();
}

const char kJobColumns[] =
    "id, spec, state, create_time_s, update_time_s, attempts, iterations, failure, lease_worker, cancel_requested, garment_faces, owner, ended, "
    "kernels";

}  // namespace

bool IsTerminal(v1::JobState s) { return s == v1::SUCCEEDED || s == v1::FAILED || s == v1::CANCELLED; }

Result<std::unique_ptr<JobStore>> JobStore::Open(const std::string& path) {
  auto store = std::unique_ptr<JobStore>(new JobStore);
  if (sqlite3_open_v2(path.c_str(), &store->db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX, nullptr) !=
      SQLITE_OK)
    return Status::Error(path + ": cannot open the job database: " + (store->db_ ? sqlite3_errmsg(store->db_) : "out of memory"));
  sqlite3_busy_timeout(store->db_, 5000);
  {
    // A damaged database is refused, not written to: every page's structure is read (seconds for a
    // month of jobs), and the first problems named.
    Stmt s(store->db_, "PRAGMA quick_check(5)");
    std::string problems;
    int rc = SQLITE_ROW;
    while ((rc = s.Step()) == SQLITE_ROW) {
      const std::string line = s.Text(0);
      if (line != "ok") problems += (problems.empty() ? "" : "; ") + line;
    }
    if (rc != SQLITE_DONE && rc != SQLITE_NOTADB && problems.empty()) problems = s.error();
    if (!problems.empty())
      return Status::Error(path + ": the job database is damaged (SQLite quick_check: " + problems +
                           "); the server does not start on it: restore it from a backup, or move it aside to start an empty one");
  }
  // WAL: readers never block the writer; synchronous=NORMAL keeps every committed transaction through a
  // crash of the process (not through power loss, which would need FULL and an fsync per iteration).
  if (Status st = store->Exec("PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=ON;"); !st.ok())
    return st.WithContext(path + ": ");
  int version = 0;
  {
    Stmt s(store->db_, "PRAGMA user_version");
    if (s.Step() != SQLITE_ROW) return Status::Error(path + ": not an SQLite database (" + s.error() + ")");
    version = static_cast<int>(s.Int(0));
  }
  if (version > kSchemaVersion)
    return Status::Error(path + ": schema version " + std::to_string(version) + " was written by a newer kgd (this one knows " +
                         std::to_string(kSchemaVersion) + ")");
  for (int v = version; v < kSchemaVersion; ++v) {
    const std::string sql = std::string("BEGIN IMMEDIATE;") + kMigrations[v] + "PRAGMA user_version=" + std::to_string(v + 1) + ";COMMIT;";
    if (Status st = store->Exec(sql); !st.ok()) {
      store->Exec("ROLLBACK");
      return Status::Error(path + ": migration to schema version " + std::to_string(v + 1) + " failed: " + st.message());
    }
  }
  // A metric field added to IterationMetrics or MotionMetrics (a new energy term's time, say) gets
  // its column here, with 0 for the rows stored before it: the schema follows the proto, no migration
  // by hand.
  for (const auto& [table, fields] : {std::pair{"iterations", MetricFields()}, std::pair{"iteration_motions", MotionFields()}}) {
    std::set<std::string> have;
    Stmt s(store->db_, std::string("PRAGMA table_info(") + table + ")");
    while (s.Step() == SQLITE_ROW) have.insert(s.Text(1));
    if (!s.ok()) return Status::Error(path + ": reading the " + table + " table's columns failed: " + s.error());
    for (const FieldDescriptor* f : fields) {
      if (have.count(f->name())) continue;
      const bool text = f->cpp_type() == FieldDescriptor::CPPTYPE_STRING;
      const bool real = f->cpp_type() == FieldDescriptor::CPPTYPE_DOUBLE || f->cpp_type() == FieldDescriptor::CPPTYPE_FLOAT;
      const std::string sql = std::string("ALTER TABLE ") + table + " ADD COLUMN " + f->name() +
                              (text ? " TEXT NOT NULL DEFAULT ''" : real ? " REAL NOT NULL DEFAULT 0" : " INTEGER NOT NULL DEFAULT 0");
      if (Status st = store->Exec(sql); !st.ok())
        return Status::Error(path + ": adding the column " + f->name() + " to " + table + " failed: " + st.message());
    }
  }
  std::random_device rd;
  store->lease_counter_ = (static_cast<int64_t>(rd()) << 20);
  return store;
}

JobStore::~JobStore() { sqlite3_close(db_); }

Status JobStore::Exec(const std::string& sql) {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "unknown error";
    sqlite3_free(err);
    return SqlError("exec", msg);
  }
  return Status::Ok();
}

Status JobStore::CommitOrRollBack() {
  Status st = Exec("COMMIT");
  // A COMMIT that fails on a full or failing disk (SQLITE_FULL, SQLITE_IOERR) may leave the transaction
  // open: rolled back, the store reads as before it began and the next BEGIN starts afresh.
  if (!st.ok() && !sqlite3_get_autocommit(db_)) {
    if (Status rb = Exec("ROLLBACK"); !rb.ok()) return Status::Error(st.message() + "; rolling back failed too: " + rb.message());
  }
  return st;
}

Result<int64_t> JobStore::CreateJob(const v1::JobSpec& spec, int max_attempts, double now, const std::string& owner) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "INSERT INTO jobs(spec, state, create_time_s, update_time_s, max_attempts, owner) VALUES(?, ?, ?, ?, ?, ?)");
  s.BindBlob(1, spec.SerializeAsString()).Bind(2, static_cast<int>(v1::QUEUED)).Bind(3, now).Bind(4, now).Bind(5, max_attempts).Bind(6, owner);
  if (!s.Run()) return SqlError("create job", s.error());
  return static_cast<int64_t>(sqlite3_last_insert_rowid(db_));
}

Result<v1::Job> JobStore::ReadJob(sqlite3_stmt* row) {
  auto col_text = [row](int c) {
    const void* p = sqlite3_column_blob(row, c);
    return p ? std::string(static_cast<const char*>(p), sqlite3_column_bytes(row, c)) : std::string();
  };
  v1::Job job;
  job.set_id(sqlite3_column_int64(row, 0));
  if (!job.mutable_spec()->ParseFromString(col_text(1))) return SqlError("job " + std::to_string(job.id()), "stored spec does not parse");
  job.set_state(static_cast<v1::JobState>(sqlite3_column_int(row, 2)));
  job.set_create_time_s(sqlite3_column_double(row, 3));
  job.set_update_time_s(sqlite3_column_double(row, 4));
  job.set_attempts(sqlite3_column_int(row, 5));
  job.set_iterations(sqlite3_column_int(row, 6));
  job.set_failure(col_text(7));
  if (job.state() == v1::RUNNING) job.set_worker(col_text(8));
  job.set_cancel_requested(sqlite3_column_int(row, 9) != 0);
  job.set_garment_faces(sqlite3_column_int(row, 10));
  job.set_owner(col_text(11));
  job.set_ended(col_text(12));
  job.set_kernels(col_text(13));
  if (job.state() == v1::RUNNING) job.set_phase(job.ended().empty() ? v1::DESIGNING : v1::EVALUATING);
  if (job.iterations() > 0) {
    Result<std::vector<v1::IterationMetrics>> last = Metrics(job.id(), job.iterations() - 1, job.iterations());
    if (!last.ok()) return last.status();
    if (!last->empty()) *job.mutable_last() = last->front();
  }
  return job;
}

Result<std::optional<v1::Job>> JobStore::GetJob(int64_t id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?");
  s.Bind(1, id);
  const int rc = s.Step();
  if (rc == SQLITE_DONE) return std::optional<v1::Job>();
  if (rc != SQLITE_ROW) return SqlError("get job", s.error());
  Result<v1::Job> job = ReadJob(s.get());
  if (!job.ok()) return job.status();
  return std::optional<v1::Job>(std::move(job).value());
}

std::optional<JobProgress> JobStore::Progress(int64_t id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT state, iterations, ended != '' FROM jobs WHERE id = ?");
  s.Bind(1, id);
  if (s.Step() != SQLITE_ROW) return std::nullopt;
  return JobProgress{static_cast<v1::JobState>(s.Int(0)), static_cast<int>(s.Int(1)), s.Int(2) != 0};
}

Result<std::vector<v1::Job>> JobStore::ListJobs(v1::JobState state, int64_t before_id, int limit, const std::optional<std::string>& owner) {
  std::lock_guard lock(mu_);
  std::string sql = std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id < ?";
  if (state != v1::JOB_STATE_UNSPECIFIED) sql += " AND state = ?";
  if (owner) sql += " AND owner = ?";
  sql += " ORDER BY id DESC LIMIT ?";
  Stmt s(db_, sql);
  int k = 1;
  s.Bind(k++, before_id > 0 ? before_id : std::numeric_limits<int64_t>::max());
  if (state != v1::JOB_STATE_UNSPECIFIED) s.Bind(k++, static_cast<int>(state));
  if (owner) s.Bind(k++, *owner);
  s.Bind(k++, limit);
  std::vector<v1::Job> out;
  int rc;
  while ((rc = s.Step()) == SQLITE_ROW) {
    Result<v1::Job> job = ReadJob(s.get());
    if (!job.ok()) return job.status();
    out.push_back(std::move(job).value());
  }
  if (rc != SQLITE_DONE) return SqlError("list jobs", s.error());
  return out;
}

int64_t JobStore::QueuedJobsOf(const std::string& owner) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT COUNT(*) FROM jobs WHERE owner = ? AND state = ?");
  s.Bind(1, owner).Bind(2, static_cast<int>(v1::QUEUED));
  return s.Step() == SQLITE_ROW ? s.Int(0) : 0;
}

std::map<v1::JobState, int64_t> JobStore::CountByState() {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT state, COUNT(*) FROM jobs GROUP BY state");
  std::map<v1::JobState, int64_t> out;
  while (s.Step() == SQLITE_ROW) out[static_cast<v1::JobState>(s.Int(0))] = s.Int(1);
  return out;
}

Result<std::optional<Lease>> JobStore::LeaseNext(const std::string& worker, const std::string& kernels, StoreTime now, double duration_s) {
  std::lock_guard lock(mu_);
  if (Status st = Exec("BEGIN IMMEDIATE"); !st.ok()) return st;
  // A job without iterations starts afresh anywhere; one with iterations resumes at its level only,
  // and never on a worker that does not say its level.
  Stmt pick(db_,
            "SELECT id, spec, attempts, iterations FROM jobs WHERE state = ? AND (iterations = 0 OR (kernels = ? AND kernels != '')) "
            "ORDER BY id LIMIT 1");
  pick.Bind(1, static_cast<int>(v1::QUEUED)).Bind(2, kernels);
  const int rc = pick.Step();
  if (rc != SQLITE_ROW) {
    Exec("ROLLBACK");
    if (rc == SQLITE_DONE) return std::optional<Lease>();
    return SqlError("lease", pick.error());
  }
  Lease lease;
  lease.job_id = pick.Int(0);
  if (!lease.spec.ParseFromString(pick.Text(1))) {
    Exec("ROLLBACK");
    return SqlError("lease", "stored spec of job " + std::to_string(lease.job_id) + " does not parse");
  }
  lease.attempt = static_cast<int>(pick.Int(2)) + 1;
  lease.iterations = static_cast<int>(pick.Int(3));
  lease.lease_id = std::to_string(lease.job_id) + "-" + std::to_string(lease.attempt) + "-" + std::to_string(++lease_counter_);
  Stmt up(db_,
          "UPDATE jobs SET state = ?, attempts = ?, lease_id = ?, lease_worker = ?, lease_expire_s = ?, update_time_s = ? WHERE id = ?");
  up.Bind(1, static_cast<int>(v1::RUNNING)).Bind(2, lease.attempt).Bind(3, lease.lease_id).Bind(4, worker).Bind(5, now.lease_s + duration_s);
  up.Bind(6, now.wall_s).Bind(7, lease.job_id);
  if (!up.Run()) {
    Exec("ROLLBACK");
    return SqlError("lease", up.error());
  }
  if (Status st = CommitOrRollBack(); !st.ok()) return st;
  return std::optional<Lease>(std::move(lease));
}

Result<bool> JobStore::Renew(int64_t job_id, const std::string& lease_id, double lease_now_s, double duration_s) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "UPDATE jobs SET lease_expire_s = ? WHERE id = ? AND lease_id = ? AND state = ?");
  s.Bind(1, lease_now_s + duration_s).Bind(2, job_id).Bind(3, lease_id).Bind(4, static_cast<int>(v1::RUNNING));
  if (!s.Run()) return SqlError("renew lease", s.error());
  return sqlite3_changes(db_) == 1;
}

bool JobStore::LeaseValid(int64_t job_id, const std::string& lease_id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT 1 FROM jobs WHERE id = ? AND lease_id = ? AND state = ?");
  s.Bind(1, job_id).Bind(2, lease_id).Bind(3, static_cast<int>(v1::RUNNING));
  return s.Step() == SQLITE_ROW;
}

Status JobStore::AppendIteration(int64_t job_id, const std::string& lease_id, const v1::IterationMetrics& m, const std::string& design) {
  std::lock_guard lock(mu_);
  KGD_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE"));
  auto fail = [this](Status st) {
    Exec("ROLLBACK");
    return st;
  };
  Stmt check(db_, "SELECT iterations FROM jobs WHERE id = ? AND lease_id = ? AND state = ?");
  check.Bind(1, job_id).Bind(2, lease_id).Bind(3, static_cast<int>(v1::RUNNING));
  if (check.Step() != SQLITE_ROW) return fail(Status::Error("job " + std::to_string(job_id) + ": the lease is no longer held"));
  if (check.Int(0) != m.iteration())
    return fail(Status::Error("job " + std::to_string(job_id) + ": iteration " + std::to_string(m.iteration()) + " reported after " +
                              std::to_string(check.Int(0)) + " stored"));
  const std::vector<const FieldDescriptor*> fields = MetricFields();
  std::string sql = "INSERT INTO iterations(job_id, iteration" + MetricColumns() + ", design) VALUES(?, ?";
  for (size_t i = 0; i < fields.size(); ++i) sql += ", ?";
  sql += ", ?)";
  Stmt ins(db_, sql);
  ins.Bind(1, job_id).Bind(2, m.iteration());
  int k = 3;
  for (const FieldDescriptor* f : fields) BindField(ins, k++, m, f);
  ins.BindBlob(k, design);
  if (!ins.Run()) return fail(SqlError("store iteration", ins.error()));
  if (m.motions_size() > 0) {
    const std::vector<const FieldDescriptor*> motion_fields = MotionFields();
    std::string msql = "INSERT INTO iteration_motions(job_id, iteration, motion" + Columns(motion_fields) + ") VALUES(?, ?, ?";
    for (size_t i = 0; i < motion_fields.size(); ++i) msql += ", ?";
    msql += ")";
    Stmt mins(db_, msql);
    for (int j = 0; j < m.motions_size(); ++j) {
      mins.Reset();
      mins.Bind(1, job_id).Bind(2, m.iteration()).Bind(3, j);
      int c = 4;
      for (const FieldDescriptor* f : motion_fields) BindField(mins, c++, m.motions(j), f);
      if (!mins.Run()) return fail(SqlError("store iteration " + std::to_string(m.iteration()) + "'s motion " + std::to_string(j), mins.error()));
    }
  }
  Stmt up(db_, "UPDATE jobs SET iterations = iterations + 1 WHERE id = ?");
  up.Bind(1, job_id);
  if (!up.Run()) return fail(SqlError("store iteration", up.error()));
  FaultPoint("job_store.append.before_commit", m.iteration());
  return CommitOrRollBack();
}

Result<v1::JobState> JobStore::EndLease(int64_t job_id, const std::string& lease_id, v1::JobState state, const std::string& failure,
                                        double now) {
  std::lock_guard lock(mu_);
  KGD_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE"));
  Stmt check(db_, "SELECT cancel_requested, attempts, max_attempts FROM jobs WHERE id = ? AND lease_id = ? AND state = ?");
  check.Bind(1, job_id).Bind(2, lease_id).Bind(3, static_cast<int>(v1::RUNNING));
  if (check.Step() != SQLITE_ROW) {
    Exec("ROLLBACK");
    return Status::Error("job " + std::to_string(job_id) + ": the lease is no longer held");
  }
  std::string reason = failure;
  if (check.Int(0)) state = v1::CANCELLED;
  else if (state == v1::QUEUED && !failure.empty() && check.Int(1) >= check.Int(2)) {
    state = v1::FAILED;
    reason = "gave up after " + std::to_string(check.Int(1)) + " attempts; the last: " + failure;
  }
  Stmt up(db_, "UPDATE jobs SET state = ?, failure = ?, lease_id = NULL, lease_expire_s = NULL, update_time_s = ? WHERE id = ?");
  up.Bind(1, static_cast<int>(state)).Bind(2, state == v1::FAILED ? reason : std::string()).Bind(3, now).Bind(4, job_id);
  if (!up.Run()) {
    Exec("ROLLBACK");
    return SqlError("end lease", up.error());
  }
  KGD_RETURN_IF_ERROR(CommitOrRollBack());
  return state;
}

std::vector<int64_t> JobStore::ExpireLeases(StoreTime now) {
  std::vector<std::pair<int64_t, std::string>> expired;
  {
    std::lock_guard lock(mu_);
    Stmt s(db_, "SELECT id, lease_id FROM jobs WHERE state = ? AND lease_expire_s < ?");
    s.Bind(1, static_cast<int>(v1::RUNNING)).Bind(2, now.lease_s);
    while (s.Step() == SQLITE_ROW) expired.emplace_back(s.Int(0), s.Text(1));
  }
  std::vector<int64_t> out;
  for (const auto& [id, lease] : expired)
    if (EndLease(id, lease, v1::QUEUED, "the worker's lease expired (no heartbeat)", now.wall_s).ok()) out.push_back(id);
  return out;
}

int JobStore::ReleaseAllLeases(double now) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "UPDATE jobs SET state = CASE WHEN cancel_requested THEN ? ELSE ? END, lease_id = NULL, lease_expire_s = NULL, "
              "update_time_s = ? WHERE state = ?");
  s.Bind(1, static_cast<int>(v1::CANCELLED)).Bind(2, static_cast<int>(v1::QUEUED)).Bind(3, now).Bind(4, static_cast<int>(v1::RUNNING));
  return s.Run() ? sqlite3_changes(db_) : 0;
}

Result<std::optional<v1::Job>> JobStore::Cancel(int64_t id, double now) {
  {
    std::lock_guard lock(mu_);
    Stmt s(db_, "UPDATE jobs SET state = CASE WHEN state = ? THEN ? ELSE state END, "
                "cancel_requested = CASE WHEN state = ? THEN 1 ELSE cancel_requested END, update_time_s = ? WHERE id = ?");
    s.Bind(1, static_cast<int>(v1::QUEUED)).Bind(2, static_cast<int>(v1::CANCELLED)).Bind(3, static_cast<int>(v1::RUNNING));
    s.Bind(4, now).Bind(5, id);
    if (!s.Run()) return SqlError("cancel", s.error());
  }
  return GetJob(id);
}

bool JobStore::CancelRequested(int64_t job_id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT cancel_requested FROM jobs WHERE id = ?");
  s.Bind(1, job_id);
  return s.Step() == SQLITE_ROW && s.Int(0) != 0;
}

Result<std::vector<v1::IterationMetrics>> JobStore::Metrics(int64_t job_id, int from, int to) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT iteration" + MetricColumns() + " FROM iterations WHERE job_id = ? AND iteration >= ? AND iteration < ? ORDER BY iteration");
  s.Bind(1, job_id).Bind(2, from).Bind(3, to);
  const std::vector<const FieldDescriptor*> fields = MetricFields();
  std::vector<v1::IterationMetrics> out;
  int rc;
  while ((rc = s.Step()) == SQLITE_ROW) {
    v1::IterationMetrics m;
    m.set_iteration(static_cast<int>(s.Int(0)));
    int c = 1;
    for (const FieldDescriptor* f : fields) ReadField(s, c++, &m, f);
    out.push_back(std::move(m));
  }
  if (rc != SQLITE_DONE) return SqlError("read metrics", s.error());
  if (out.empty()) return out;
  // A job's iterations are stored without gaps, so the rows above are in order: iteration i is out[i - first].
  const int first = out.front().iteration();
  const std::vector<const FieldDescriptor*> motion_fields = MotionFields();
  Stmt ms(db_, "SELECT iteration" + Columns(motion_fields) +
                   " FROM iteration_motions WHERE job_id = ? AND iteration >= ? AND iteration < ? ORDER BY iteration, motion");
  ms.Bind(1, job_id).Bind(2, from).Bind(3, to);
  while ((rc = ms.Step()) == SQLITE_ROW) {
    const int64_t i = ms.Int(0) - first;
    if (i < 0 || i >= static_cast<int64_t>(out.size()) || out[i].iteration() != ms.Int(0))
      return SqlError("read metrics", "job " + std::to_string(job_id) + ": motions of iteration " + std::to_string(ms.Int(0)) + ", which is not stored");
    v1::MotionMetrics* mm = out[i].add_motions();
    int c = 1;
    for (const FieldDescriptor* f : motion_fields) ReadField(ms, c++, mm, f);
  }
  if (rc != SQLITE_DONE) return SqlError("read motions", ms.error());
  return out;
}

Result<std::optional<v1::IterationRecord>> JobStore::Iteration(int64_t job_id, int k) {
  Result<std::vector<v1::IterationMetrics>> m = Metrics(job_id, k, k + 1);
  if (!m.ok()) return m.status();
  if (m->empty()) return std::optional<v1::IterationRecord>();
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT design FROM iterations WHERE job_id = ? AND iteration = ?");
  s.Bind(1, job_id).Bind(2, k);
  if (s.Step() != SQLITE_ROW) return std::optional<v1::IterationRecord>();
  v1::IterationRecord r;
  *r.mutable_metrics() = m->front();
  r.set_design(s.Text(0));
  return std::optional<v1::IterationRecord>(std::move(r));
}

Status JobStore::TruncateIterations(int64_t job_id, int keep) {
  std::lock_guard lock(mu_);
  KGD_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE"));
  Stmt del_motions(db_, "DELETE FROM iteration_motions WHERE job_id = ? AND iteration >= ?");
  del_motions.Bind(1, job_id).Bind(2, keep);
  Stmt del(db_, "DELETE FROM iterations WHERE job_id = ? AND iteration >= ?");
  del.Bind(1, job_id).Bind(2, keep);
  Stmt up(db_, "UPDATE jobs SET iterations = ? WHERE id = ?");
  up.Bind(1, keep).Bind(2, job_id);
  if (!del_motions.Run() || !del.Run() || !up.Run()) {
    Exec("ROLLBACK");
    return SqlError("truncate iterations", del_motions.error() + del.error() + up.error());
  }
  return CommitOrRollBack();
}

Status JobStore::SetEnded(int64_t job_id, const std::string& lease_id, const std::string& ended) {
  std::lock_guard lock(mu_);
  return SetLeasedJobColumn(db_, job_id, lease_id, "ended", ended, false, "job end");
}

Status JobStore::SetKernels(int64_t job_id, const std::string& lease_id, const std::string& kernels) {
  std::lock_guard lock(mu_);
  return SetLeasedJobColumn(db_, job_id, lease_id, "kernels", kernels, false, "kernels");
}

Status JobStore::SetCleaned(int64_t job_id, const std::string& lease_id, const v1::CleanedDesign& cleaned) {
  std::lock_guard lock(mu_);
  return SetLeasedJobColumn(db_, job_id, lease_id, "cleaned", cleaned.SerializeAsString(), true, "cleaned design");
}

Result<std::optional<v1::CleanedDesign>> JobStore::Cleaned(int64_t job_id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT cleaned FROM jobs WHERE id = ?");
  s.Bind(1, job_id);
  const int rc = s.Step();
  if (rc != SQLITE_ROW && rc != SQLITE_DONE) return SqlError("cleaned design", s.error());
  const std::string bytes = rc == SQLITE_ROW ? s.Text(0) : std::string();
  if (bytes.empty()) return std::optional<v1::CleanedDesign>();
  v1::CleanedDesign c;
  if (!c.ParseFromString(bytes)) return SqlError("job " + std::to_string(job_id), "stored cleaned design does not parse");
  return std::optional<v1::CleanedDesign>(std::move(c));
}

Status JobStore::SetGarmentFaces(int64_t job_id, int faces) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "UPDATE jobs SET garment_faces = ? WHERE id = ?");
  s.Bind(1, faces).Bind(2, job_id);
  return s.Run() ? Status::Ok() : SqlError("garment faces", s.error());
}

std::string JobStore::IntegrityCheck() {
  std::lock_guard lock(mu_);
  Stmt s(db_, "PRAGMA integrity_check");
  std::string out;
  while (s.Step() == SQLITE_ROW) out += (out.empty() ? "" : "; ") + s.Text(0);
  return out;
}

}  // namespace kgd::server
