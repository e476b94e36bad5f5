#include "store/design_file.h"

#include <sys/statvfs.h>
#include <unistd.h>

#include <hdf5.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <filesystem>
#include <fstream>
#include <string_view>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "store/file_lock.h"
#include "core/util/fault_point.h"
#include "store/hdf5.h"

namespace kgd {
namespace {
using namespace hdf5;  // NOLINT: this file is the format over those helpers

constexpr const char* kFormat = "kgd design history";
constexpr int kFormatVersion = 1;

// Metric datasets, one per entry of KGD_BESO_METRICS: name, and whether they hold integers.
// A metric is optional when files written before it existed lack its dataset (the solve profile, the
// pressure limit's): it reads as 0 there, and appending to such a file adds the dataset.
struct MetricSpec {
  const char* name;
  bool integer;
  double BesoIteration::*real;
  int BesoIteration::*whole;
  bool optional = false;
};
template <typename T>
MetricSpec Metric(const char* name, T BesoIteration::*member) {
  if constexpr (std::is_same_v<T, int>) return {name, true, nullptr, member};
  else return {name, false, member, nullptr};
}
const std::vector<MetricSpec>& Metrics() {
  static const std::vector<MetricSpec> m = [] {
#define KGD_METRIC_SPEC(type, name, what) Metric(#name, &BesoIteration::name),
    std::vector<MetricSpec> all = {KGD_BESO_METRICS(KGD_METRIC_SPEC)};
    const std::vector<MetricSpec> profile = {KGD_BESO_PROFILE_METRICS(KGD_METRIC_SPEC) KGD_BESO_PRESSURE_METRICS(KGD_METRIC_SPEC)};
#undef KGD_METRIC_SPEC
    for (MetricSpec& s : all)
      for (const MetricSpec& p : profile) s.optional = s.optional || std::string_view(s.name) == p.name;
    return all;
  }();
  return m;
}
bool IsOptionalMetric(const std::string& name) {
  for (const MetricSpec& s : Metrics())
    if (s.optional && name == s.name) return true;
  return false;
}
bool HasDataset(hid_t group, const char* name) { return H5Lexists(group, name, H5P_DEFAULT) > 0; }

Status Fail(const std::string& path, const std::string& what) { return Status::Error(path + ": " + what); }

// Bytes free to this process on the file system that holds `path`; -1 when it cannot be told.
long long FreeBytes(const std::string& path) {
  struct statvfs st;
  if (statvfs(path.c_str(), &st) != 0) return -1;
  return static_cast<long long>(st.f_bavail) * static_cast<long long>(st.f_frsize);
}

std::string StoredSoFar(int count) {
  return count == 0 ? std::string("no iteration is stored") : "iterations 0.." + std::to_string(count - 1) + " are stored";
}

// Row-major copies of Eigen's column-major matrices.
std::vector<double> RowMajor(const Positions& p) {
  std::vector<double> out(p.rows() * 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int k = 0; k < 3; ++k) out[3 * i + k] = p(i, k);
  return out;
}
Positions FromRowMajor(const std::vector<double>& v) {
  Positions p(v.size() / 3, 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int k = 0; k < 3; ++k) p(i, k) = v[3 * i + k];
  return p;
}

const char* kArrayNames[] = {"design", "positions", "energy_density_Pa", "sensitivity"};

}  // namespace

const std::vector<std::string>& DesignFileMetricNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n{"iteration"};
    for (const MetricSpec& m : Metrics()) n.push_back(m.name);
    n.push_back("status");
    return n;
  }();
  return names;
}

std::string BesoSettingsToJson(const BesoSettings& s) {
  nlohmann::ordered_json j;
#define KGD_VALUE_TO_JSON(type, name, default_value, flag, help) j[#name] = s.name;
  KGD_BESO_VALUES(KGD_VALUE_TO_JSON)
#undef KGD_VALUE_TO_JSON
#define KGD_SWITCH_TO_JSON(name, default_value, flag, proto_field, help) j[#name] = s.name;
  KGD_BESO_SWITCHES(KGD_SWITCH_TO_JSON)
#undef KGD_SWITCH_TO_JSON
  return j.dump();
}

Result<BesoSettings> BesoSettingsFromJson(const std::string& text) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return Status::Error("BESO settings: not a JSON object");
  BesoSettings s;
  // Files written before the re-solves' tolerance factor existed ran every re-solve at the tolerance.
  if (!j.contains("resolve_tolerance_factor")) s.resolve_tolerance_factor = 1.0;
  try {
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string& k = it.key();
      bool known = false;
#define KGD_VALUE_FROM_JSON(type, name, default_value, flag, help) \
  if (k == #name) s.name = it->get<type>(), known = true;
      KGD_BESO_VALUES(KGD_VALUE_FROM_JSON)
#undef KGD_VALUE_FROM_JSON
#define KGD_SWITCH_FROM_JSON(name, default_value, flag, proto_field, help) \
  if (k == #name) s.name = it->get<bool>(), known = true;
      KGD_BESO_SWITCHES(KGD_SWITCH_FROM_JSON)
#undef KGD_SWITCH_FROM_JSON
      if (!known) return Status::Error("BESO settings: unknown key \"" + k + "\"");
    }
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(std::string("BESO settings: ") + e.what());
  }
  if (Status st = ValidateBesoSettings(s); !st.ok()) return st;
  return s;
}

struct DesignFileWriter::Impl {
  std::string path;
  FileLock lock;  // one writer per file, held while this writer lives
  Id file, iterations;
  int faces = 0, vertices = 0;
  size_t motions = 0;  // K: /iterations/motion_metrics rows hold K motions (0: no such dataset)
  bool motion_positions = false;  // /iterations/motion_positions holds motions 2..K's equilibria
  std::string failed;             // why an earlier write failed: the file takes no more iterations
};

DesignFileWriter::~DesignFileWriter() = default;
int DesignFileWriter::faces() const { return impl_->faces; }
int DesignFileWriter::vertices() const { return impl_->vertices; }

// File access for writers: the newest format (SWMR needs it).
Id WriterAccess() {
  Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_libver_bounds(fapl, H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
  // Locking off as for readers: HDF5 refuses a second open in one process (the server reading a job it
  // writes) when the flags differ. One writer per file is the caller's guarantee (the server's leases).
  H5Pset_file_locking(fapl, false, true);
  return fapl;
}

// Clears the superblock's "open for write" flags (HDF5's fapl property "clear_status_flags", which
// h5clear sets). An error only when the system failed the write (a full or failing disk: the message
// names it, e.g. "No space left on device (ENOSPC)"); a file that does not open for other reasons is
// left to the readers to judge.
Status ClearWriteMark(const std::string& path) {
  Id fapl = WriterAccess();
  hbool_t clear = true;
  if (H5Pset(fapl, "clear_status_flags", &clear) < 0) return Status::Ok();
  ClearHdf5Error();
  Id file(H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl), H5Fclose);
  const bool closed = file.ok() && file.Close();
  const bool system_error = LastHdf5Errno() != 0;
  const std::string error = LastHdf5Error();
  if (!closed && system_error) return Fail(path, "cannot clear its \"open for write\" mark: " + error);
  return Status::Ok();
}

// A design file open for reading: the header read and checked, iterations read one at a time.
struct DesignFileReader {
  std::string path;
  Id file, its;
  DesignFileHeader header;
  hsize_t marker_rows = 0;  // length of the commit marker /iterations/iteration
  hsize_t rows = 0;         // iterations to read: marker_rows, or fewer where a dataset is shorter (salvage)
};

namespace {

// Per motion and iteration: energy_J, reinforced_energy_J, reinforced_density_J_per_m2, density_ratio,
// simulation_s, solver_iterations.
constexpr int kMotionFigures = 6;
constexpr const char* kMotionMetrics = "motion_metrics";
// Per iteration: the equilibria of motions 2..K, (K-1, V, 3); rows of an iteration without them
// (salvaged from a file of before) hold NaN.
constexpr const char* kMotionPositions = "motion_positions";

std::string MotionsToJson(const std::vector<MotionMetrics>& motions) {
  nlohmann::ordered_json j = nlohmann::ordered_json::array();
  for (const MotionMetrics& m : motions) j.push_back({{"name", m.name}, {"role", ToString(m.role)}, {"weight", m.weight}});
  return j.dump();
}

Result<std::vector<MotionMetrics>> MotionsFromJson(const std::string& text) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_array()) return Status::Error("/job motions: not a JSON array");
  std::vector<MotionMetrics> out;
  try {
    for (const nlohmann::json& e : j) {
      MotionMetrics m;
      m.name = e.at("name").get<std::string>();
      Result<MotionRole> role = MotionRoleFromName(e.at("role").get<std::string>(), "/job motions: motion '" + m.name + "'");
      if (!role.ok()) return role.status();
      m.role = *role;
      m.weight = e.at("weight").get<double>();
      out.push_back(std::move(m));
    }
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(std::string("/job motions: ") + e.what());
  }
  return out;
}

void SetMotionFigures(MotionMetrics* m, const double* v) {
  m->energy_J = v[0];
  m->reinforced_energy_J = v[1];
  m->reinforced_density_J_per_m2 = v[2];
  m->density_ratio = v[3];
  m->simulation_s = v[4];
  m->solver_iterations = static_cast<int>(v[5]);
}

// Opens `path` and reads its header. Strict (salvage false): every dataset must hold the marker's
// rows. Salvage: a killed writer may leave datasets shorter than the marker; rows counts what all
// datasets hold.
Result<std::unique_ptr<DesignFileReader>> OpenDesignFileReader(const std::string& path, bool salvage) {
  auto reader = std::make_unique<DesignFileReader>();
  DesignFileReader& r = *reader;
  r.path = path;
  SilenceHdf5();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return Fail(path, "no such file");
  {
    char signature[8] = {};
    std::ifstream(path, std::ios::binary).read(signature, 8);
    if (std::memcmp(signature, "\x89HDF\r\n\x1a\n", 8) != 0) return Fail(path, "not an HDF5 file");
  }
  // Without HDF5's file lock, so that a design file can be read while its job is still writing it
  // (the writer flushes whole iterations; rows beyond /iterations/iteration are ignored).
  Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_file_locking(fapl, false, true);
  // A SWMR reader retries a metadata block whose checksum fails (it may be half written by the live
  // writer) with doubling sleeps from 1 ns: HDF5's default of 100 attempts is hours on a block a
  // killed writer left torn. 28 attempts wait ~0.3 s in all, far longer than any write of one block.
  H5Pset_metadata_read_attempts(fapl, 28);
  // SWMR read sees the last flushed iteration of a file being written, or of one whose writer was
  // killed (a plain open refuses such a file); files written before SWMR open plainly.
  ClearHdf5Error();
  r.file = Id(H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, fapl), H5Fclose);
  if (!r.file.ok()) r.file = Id(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl), H5Fclose);
  if (!r.file.ok())
    return Fail(path, "cannot open the HDF5 file: " + LastHdf5Error() +
                          " (damaged, or cut short by a full disk: `kgd design --resume FILE` repairs a file its writer could not finish)");
  std::string format;
  int version = 0;
  if (!ReadStringAttribute(r.file, "format", &format) || format != kFormat)
    return Fail(path, "not a kgd design file (attribute format is not \"" + std::string(kFormat) + "\")");
  if (!ReadIntAttribute(r.file, "format_version", &version) || version != kFormatVersion)
    return Fail(path, "design file format_version " + std::to_string(version) + " is not supported (this kgd reads " +
                          std::to_string(kFormatVersion) + ")");
  DesignFileHeader& h = r.header;
  {
    Id job(H5Gopen2(r.file, "job", H5P_DEFAULT), H5Gclose);
    std::string settings;
    // "settings_next": SetSettings killed between removing the old settings and renaming the new.
    const char* settings_name = job.ok() && H5Aexists(job, "settings") <= 0 && H5Aexists(job, "settings_next") > 0 ? "settings_next" : "settings";
    if (!job.ok() || !ReadStringAttribute(job, "scene", &h.scene) || !ReadStringAttribute(job, "body", &h.body) ||
        !ReadStringAttribute(job, settings_name, &settings))
      return Fail(path, "/job is missing or incomplete");
    Result<BesoSettings> s = BesoSettingsFromJson(settings);
    if (!s.ok()) return Fail(path, "/job settings: " + s.message());
    h.settings = *s;
    h.kernels = kKernelsX8664;  // files written before the level was recorded ran the x86-64 pin
    if (H5Aexists(job, "kernels") > 0 && !ReadStringAttribute(job, "kernels", &h.kernels))
      return Fail(path, "/job kernels cannot be read");
    if (H5Aexists(job, "solver") > 0) {
      std::string solver;
      if (!ReadStringAttribute(job, "solver", &solver)) return Fail(path, "/job solver cannot be read");
      const nlohmann::json j = nlohmann::json::parse(solver, nullptr, false);
      if (!j.is_object() || !j.value("grad_tol", nlohmann::json()).is_number() ||
          !j.value("max_newton_iterations", nlohmann::json()).is_number_integer() || !(j["grad_tol"].get<double>() >= 0) ||
          j["max_newton_iterations"].get<int>() < 0)
        return Fail(path, "/job solver '" + solver + "' is not {\"grad_tol\": >= 0, \"max_newton_iterations\": >= 0}");
      h.grad_tol = j["grad_tol"].get<double>();
      h.max_newton_iterations = j["max_newton_iterations"].get<int>();
    }
    std::string motions;
    if (H5Aexists(job, "motions") > 0) {
      if (!ReadStringAttribute(job, "motions", &motions)) return Fail(path, "/job motions cannot be read");
      Result<std::vector<MotionMetrics>> m = MotionsFromJson(motions);
      if (!m.ok()) return Fail(path, m.message());
      h.motions = std::move(m).value();
    }
  }
  {
    Id g(H5Gopen2(r.file, "garment", H5P_DEFAULT), H5Gclose);
    if (!g.ok()) return Fail(path, "/garment is missing");
    const std::vector<hsize_t> vs = Shape(g, "rest_vertices"), fs = Shape(g, "faces"), as = Shape(g, "rest_area"),
                               is = Shape(g, "initial_positions"), ts = Shape(g, "attachment_faces");
    if (vs.size() != 2 || vs[1] != 3 || fs.size() != 2 || fs[1] != 3 || as != std::vector<hsize_t>{fs[0]} || is != vs ||
        ts.size() != 1)
      return Fail(path, "/garment datasets are missing or have inconsistent shapes");
    std::vector<double> rest(vs[0] * 3), initial(vs[0] * 3);
    std::vector<int> faces(fs[0] * 3);
    h.rest_area_m2.resize(fs[0]);
    h.attachment_faces.resize(ts[0]);
    if (!ReadAll(g, "rest_vertices", H5T_NATIVE_DOUBLE, rest.data()) || !ReadAll(g, "faces", H5T_NATIVE_INT, faces.data()) ||
        !ReadAll(g, "rest_area", H5T_NATIVE_DOUBLE, h.rest_area_m2.data()) ||
        !ReadAll(g, "initial_positions", H5T_NATIVE_DOUBLE, initial.data()) ||
        (ts[0] > 0 && !ReadAll(g, "attachment_faces", H5T_NATIVE_INT, h.attachment_faces.data())))
      return Fail(path, "cannot read /garment (damaged?)");
    h.garment.vertices = FromRowMajor(rest);
    h.initial = FromRowMajor(initial);
    h.garment.faces.resize(fs[0], 3);
    for (hsize_t f = 0; f < fs[0]; ++f)
      for (int k = 0; k < 3; ++k) {
        const int v = faces[3 * f + k];
        if (v < 0 || v >= static_cast<int>(vs[0]))
          return Fail(path, "/garment/faces row " + std::to_string(f) + " has vertex index " + std::to_string(v) + " out of range");
        h.garment.faces(f, k) = v;
      }
    if (Shape(g, "thickness") == std::vector<hsize_t>{2}) {
      double t[2];
      if (!ReadAll(g, "thickness", H5T_NATIVE_DOUBLE, t)) return Fail(path, "cannot read /garment/thickness (damaged?)");
      h.cloth_thickness_m = t[0];
      h.reinforced_thickness_m = t[1];
    }
  }
  if (H5Lexists(r.file, "body", H5P_DEFAULT) > 0) {
    Id b(H5Gopen2(r.file, "body", H5P_DEFAULT), H5Gclose);
    const std::vector<hsize_t> vs = Shape(b, "vertices"), fs = Shape(b, "faces");
    if (!b.ok() || vs.size() != 2 || vs[1] != 3 || fs.size() != 2 || fs[1] != 3)
      return Fail(path, "/body datasets are missing or have inconsistent shapes");
    std::vector<double> x(vs[0] * 3);
    std::vector<int> faces(fs[0] * 3);
    if (!ReadAll(b, "vertices", H5T_NATIVE_DOUBLE, x.data()) || !ReadAll(b, "faces", H5T_NATIVE_INT, faces.data()))
      return Fail(path, "cannot read /body (damaged?)");
    h.body_mesh.vertices = FromRowMajor(x);
    h.body_mesh.faces.resize(fs[0], 3);
    for (hsize_t f = 0; f < fs[0]; ++f)
      for (int k = 0; k < 3; ++k) {
        const int v = faces[3 * f + k];
        if (v < 0 || v >= static_cast<int>(vs[0]))
          return Fail(path, "/body/faces row " + std::to_string(f) + " has vertex index " + std::to_string(v) + " out of range");
        h.body_mesh.faces(f, k) = v;
      }
  }
  r.its = Id(H5Gopen2(r.file, "iterations", H5P_DEFAULT), H5Gclose);
  if (!r.its.ok()) return Fail(path, "/iterations is missing");
  const char* kKilled = " (a writer killed mid-write? `kgd design --resume FILE` repairs the file, keeping its intact iterations)";
  const std::vector<hsize_t> ns = Shape(r.its, "iteration");
  if (ns.size() != 1 && !salvage) return Fail(path, std::string("/iterations/iteration is missing") + kKilled);
  const hsize_t nf = h.garment.faces.rows(), nv = h.garment.vertices.rows();
  r.marker_rows = r.rows = ns.size() == 1 ? ns[0] : 0;
  for (const std::string& name : DesignFileMetricNames()) {
    if (IsOptionalMetric(name) && !HasDataset(r.its, name.c_str())) continue;
    const std::vector<hsize_t> s = Shape(r.its, name.c_str());
    if (s.size() != 1 && salvage) {  // unreadable (a torn object header): no iteration is whole
      r.rows = 0;
      continue;
    }
    if (s.size() != 1) return Fail(path, "/iterations/" + name + " is missing" + kKilled);
    if (s[0] < r.rows && !salvage) return Fail(path, "/iterations/" + name + " is shorter than /iterations/iteration" + kKilled);
    r.rows = std::min(r.rows, s[0]);
  }
  if (!h.motions.empty()) {
    const std::vector<hsize_t> s = Shape(r.its, kMotionMetrics);
    const std::vector<hsize_t> row = {h.motions.size(), kMotionFigures};
    if (s.empty() && salvage) {
      r.rows = 0;
    } else {
      if (s.size() != 3 || std::vector<hsize_t>(s.begin() + 1, s.end()) != row)
        return Fail(path, std::string("/iterations/") + kMotionMetrics + " is missing or does not match /job motions");
      if (s[0] < r.rows && !salvage) return Fail(path, std::string("/iterations/") + kMotionMetrics + " is shorter than /iterations/iteration" + kKilled);
      r.rows = std::min(r.rows, s[0]);
    }
  }
  const std::vector<std::vector<hsize_t>> array_shapes = {{nf}, {nv, 3}, {nf}, {nf}};
  for (int a = 0; a < 4; ++a) {
    std::vector<hsize_t> s = Shape(r.its, kArrayNames[a]);
    if (s.empty() && salvage) {
      r.rows = 0;
      continue;
    }
    if (s.size() < 1 || std::vector<hsize_t>(s.begin() + 1, s.end()) != array_shapes[a])
      return Fail(path, std::string("/iterations/") + kArrayNames[a] + " is missing or does not match the garment");
    if (s[0] < r.rows && !salvage)
      return Fail(path, std::string("/iterations/") + kArrayNames[a] + " is shorter than /iterations/iteration" + kKilled);
    r.rows = std::min(r.rows, s[0]);
  }
  return reader;
}

// The metrics of rows [first, first + rows) into it[0, rows): one read per metric, not per row (a
// long job's file holds thousands of rows).
Status ReadMetricRows(const DesignFileReader& r, hsize_t first, hsize_t rows, BesoIteration* it) {
  const hid_t its = r.its;
  const std::string& path = r.path;
  std::vector<int> whole(rows);
  std::vector<double> real(rows);
  bool ok = ReadRows(its, "iteration", H5T_NATIVE_INT, first, rows, whole.data());
  for (hsize_t i = 0; ok && i < rows; ++i) it[i].iteration = whole[i];
  ok = ok && ReadRows(its, "status", H5T_NATIVE_INT, first, rows, whole.data());
  const int last = static_cast<int>(kLastSolveStatus);
  for (hsize_t i = 0; ok && i < rows; ++i) {
    if (whole[i] < 0 || whole[i] > last)
      return Fail(path, "/iterations/status row " + std::to_string(first + i) + " holds " + std::to_string(whole[i]) +
                            ", not a solver status (0-" + std::to_string(last) + ")");
    it[i].status = static_cast<SolveStatus>(whole[i]);
  }
  for (const MetricSpec& s : Metrics()) {
    if (s.optional && !HasDataset(its, s.name)) continue;  // a file from before the metric: it stays 0
    if (s.integer) {
      ok = ok && ReadRows(its, s.name, H5T_NATIVE_INT, first, rows, whole.data());
      for (hsize_t i = 0; ok && i < rows; ++i) it[i].*(s.whole) = whole[i];
    } else {
      ok = ok && ReadRows(its, s.name, H5T_NATIVE_DOUBLE, first, rows, real.data());
      for (hsize_t i = 0; ok && i < rows; ++i) it[i].*(s.real) = real[i];
    }
  }
  // Per motion; a file from before motions: one, the scene's, with the figures above.
  const std::vector<MotionMetrics>& motions = r.header.motions;
  if (ok && !motions.empty()) {
    const size_t k = motions.size();
    real.resize(rows * k * kMotionFigures);
    ok = ReadRows(its, kMotionMetrics, H5T_NATIVE_DOUBLE, first, rows, real.data());
    for (hsize_t i = 0; ok && i < rows; ++i) {
      it[i].motions = motions;
      for (size_t m = 0; m < k; ++m) SetMotionFigures(&it[i].motions[m], &real[(i * k + m) * kMotionFigures]);
    }
  } else if (ok) {
    for (hsize_t i = 0; i < rows; ++i) {
      MotionMetrics m;
      m.name = std::filesystem::path(r.header.scene).stem().string();
      const double v[kMotionFigures] = {it[i].energy_J, it[i].reinforced_energy_J, it[i].reinforced_density_J_per_m2, it[i].density_ratio,
                                        it[i].simulation_s, static_cast<double>(it[i].solver_iterations)};
      SetMotionFigures(&m, v);
      it[i].motions = {m};
    }
  }
  if (!ok)
    return Fail(path, (rows == 1 ? "iteration " + std::to_string(first) : "iterations " + std::to_string(first) + ".." + std::to_string(first + rows - 1)) +
                          (rows == 1 ? " is" : " are") + " damaged: their metrics do not read back (" + LastHdf5Error() + ")");
  for (hsize_t i = 0; i < rows; ++i)
    if (it[i].iteration != static_cast<int>(first + i))
      return Fail(path, "/iterations/iteration row " + std::to_string(first + i) + " holds " + std::to_string(it[i].iteration));
  return Status::Ok();
}

// Reads iteration row i: its metrics, and its arrays when `arrays`. Errors name the row.
Status ReadIteration(const DesignFileReader& r, hsize_t i, bool arrays, BesoIteration* it) {
  KGD_RETURN_IF_ERROR(ReadMetricRows(r, i, 1, it));
  if (!arrays) return Status::Ok();
  const hid_t its = r.its;
  const int nf = static_cast<int>(r.header.garment.faces.rows()), nv = static_cast<int>(r.header.garment.vertices.rows());
  it->design.resize(nf);
  std::vector<double> x(static_cast<size_t>(nv) * 3);
  it->energy_density_Pa.resize(nf);
  it->sensitivity.resize(nf);
  const std::pair<const char*, bool> read[] = {
      {"design", ReadRow(its, "design", H5T_NATIVE_UINT8, i, it->design.data())},
      {"positions", ReadRow(its, "positions", H5T_NATIVE_DOUBLE, i, x.data())},
      {"energy_density_Pa", ReadRow(its, "energy_density_Pa", H5T_NATIVE_DOUBLE, i, it->energy_density_Pa.data())},
      {"sensitivity", ReadRow(its, "sensitivity", H5T_NATIVE_DOUBLE, i, it->sensitivity.data())}};
  for (const auto& [name, ok] : read)
    if (!ok) return Fail(r.path, "iteration " + std::to_string(i) + " is damaged: /iterations/" + name + " does not read back (" + LastHdf5Error() + ")");
  it->positions = FromRowMajor(x);
  if (i == 0) it->sensitivity.resize(0);
  it->motion_positions.clear();
  if (r.header.motions.size() > 1 && HasDataset(its, kMotionPositions)) {
    const size_t others = r.header.motions.size() - 1;
    std::vector<double> all(others * nv * 3);
    if (!ReadRow(its, kMotionPositions, H5T_NATIVE_DOUBLE, i, all.data()))
      return Fail(r.path, "iteration " + std::to_string(i) + " is damaged: /iterations/" + kMotionPositions + " does not read back (" + LastHdf5Error() + ")");
    if (std::all_of(all.begin(), all.end(), [](double v) { return std::isfinite(v); }))
      for (size_t k = 0; k < others; ++k)
        it->motion_positions.push_back(FromRowMajor(std::vector<double>(all.begin() + k * nv * 3, all.begin() + (k + 1) * nv * 3)));
  }
  return Status::Ok();
}

}  // namespace

Result<std::unique_ptr<DesignFileWriter>> DesignFileWriter::Create(const std::string& path, const DesignFileHeader& h) {
  SilenceHdf5();
  ClearHdf5Error();
  const hsize_t nv = h.garment.vertices.rows(), nf = h.garment.faces.rows();
  if (h.initial.rows() != static_cast<Eigen::Index>(nv) || h.rest_area_m2.size() != static_cast<Eigen::Index>(nf))
    return Fail(path, "design file header: garment, initial positions and areas differ in size");
  auto w = std::unique_ptr<DesignFileWriter>(new DesignFileWriter);
  w->impl_ = std::make_unique<Impl>();
  Impl& m = *w->impl_;
  m.path = path;
  m.faces = static_cast<int>(nf);
  m.vertices = static_cast<int>(nv);
  // Locked before it is truncated: a file another writer has open is refused, not emptied under it.
  Result<FileLock> lock = FileLock::Acquire(path, /*create=*/true);
  if (!lock.ok()) return lock.status();
  m.lock = std::move(lock).value();
  Id fapl = WriterAccess();
  m.file = Id(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl), H5Fclose);
  // A file that could not be made whole holds nothing worth keeping (no iteration): it goes, so that
  // nothing half written is left to be read or resumed.
  auto failed = [&](const std::string& what) {
    const Status st = Fail(path, what + ": " + LastHdf5Error());
    // The group before the file: HDF5 1.10 crashes closing a group of a file whose close failed.
    m.iterations.reset();
    m.file.reset();
    std::error_code ec;
    std::filesystem::remove(path, ec);
    return st;
  };
  if (!m.file.ok()) return failed("cannot create the HDF5 file");
  bool ok = WriteStringAttribute(m.file, "format", kFormat) && WriteIntAttribute(m.file, "format_version", kFormatVersion);
  {
    Id job(H5Gcreate2(m.file, "job", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    ok = ok && job.ok() && WriteStringAttribute(job, "scene", h.scene) && WriteStringAttribute(job, "body", h.body) &&
         WriteStringAttribute(job, "settings", BesoSettingsToJson(h.settings)) &&
         WriteStringAttribute(job, "kgd_version", KGD_VERSION) && WriteStringAttribute(job, "kernels", h.kernels) &&
         WriteStringAttribute(job, "solver",
                              nlohmann::json{{"grad_tol", h.grad_tol}, {"max_newton_iterations", h.max_newton_iterations}}.dump()) &&
         (h.motions.empty() || WriteStringAttribute(job, "motions", MotionsToJson(h.motions)));
  }
  {
    Id g(H5Gcreate2(m.file, "garment", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    std::vector<int> faces(nf * 3);
    for (hsize_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) faces[3 * f + k] = h.garment.faces(f, k);
    const std::vector<double> rest = RowMajor(h.garment.vertices), initial = RowMajor(h.initial);
    ok = ok && g.ok() && WriteFixed(g, "rest_vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {nv, 3}, rest.data()) &&
         WriteFixed(g, "faces", H5T_STD_I32LE, H5T_NATIVE_INT, {nf, 3}, faces.data()) &&
         WriteFixed(g, "rest_area", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {nf}, h.rest_area_m2.data()) &&
         WriteFixed(g, "initial_positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {nv, 3}, initial.data()) &&
         WriteFixed(g, "attachment_faces", H5T_STD_I32LE, H5T_NATIVE_INT, {h.attachment_faces.size()},
                    h.attachment_faces.data());
    const double thickness[2] = {h.cloth_thickness_m, h.reinforced_thickness_m};
    ok = ok && WriteFixed(g, "thickness", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {2}, thickness);
  }
  if (h.body_mesh.faces.rows() > 0) {
    Id b(H5Gcreate2(m.file, "body", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    const hsize_t bv = h.body_mesh.vertices.rows(), bf = h.body_mesh.faces.rows();
    std::vector<int> faces(bf * 3);
    for (hsize_t f = 0; f < bf; ++f)
      for (int k = 0; k < 3; ++k) faces[3 * f + k] = h.body_mesh.faces(f, k);
    const std::vector<double> x = RowMajor(h.body_mesh.vertices);
    ok = ok && b.ok() && WriteFixed(b, "vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {bv, 3}, x.data()) &&
         WriteFixed(b, "faces", H5T_STD_I32LE, H5T_NATIVE_INT, {bf, 3}, faces.data());
  }
  m.iterations = Id(H5Gcreate2(m.file, "iterations", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  ok = ok && m.iterations.ok() && CreateGrowing(m.iterations, "iteration", H5T_STD_I32LE, {}) &&
       CreateGrowing(m.iterations, "status", H5T_STD_I32LE, {});
  for (const MetricSpec& s : Metrics())
    ok = ok && CreateGrowing(m.iterations, s.name, s.integer ? H5T_STD_I32LE : H5T_IEEE_F64LE, {});
  // Per-iteration float arrays are not deflated: double-precision positions, energies and sensitivities
  // are mostly mantissa noise and shrink by only ~25 % with shuffle + deflate, which would cost most of
  // an append's time and sit on the path from a worker's report to its watchers. Designs (bytes of 0
  // and 1) deflate to a few percent.
  ok = ok && CreateGrowing(m.iterations, "design", H5T_STD_U8LE, {nf}, Storage::kDeflated) &&
       CreateGrowing(m.iterations, "positions", H5T_IEEE_F64LE, {nv, 3}, Storage::kRaw) &&
       CreateGrowing(m.iterations, "energy_density_Pa", H5T_IEEE_F64LE, {nf}, Storage::kRaw) &&
       CreateGrowing(m.iterations, "sensitivity", H5T_IEEE_F64LE, {nf}, Storage::kRaw);
  if (!h.motions.empty()) ok = ok && CreateGrowing(m.iterations, kMotionMetrics, H5T_IEEE_F64LE, {h.motions.size(), kMotionFigures});
  if (h.motions.size() > 1) ok = ok && CreateGrowing(m.iterations, kMotionPositions, H5T_IEEE_F64LE, {h.motions.size() - 1, nv, 3}, Storage::kRaw);
  m.motions = h.motions.size();
  m.motion_positions = h.motions.size() > 1;
  if (!ok || H5Fflush(m.file, H5F_SCOPE_GLOBAL) < 0) return failed("cannot write the design file");
  if (H5Fstart_swmr_write(m.file) < 0) return failed("cannot start single-writer/multiple-reader mode");
  return w;
}

// A file whose writer could not grow it (a file-size limit, a failed write at its end) is shorter than
// the end its superblock records, and HDF5 refuses to open it. Nothing was written past the real end,
// so the file is extended to the recorded end with zeros (a hole), and the iterations in it read again.
static Status ExtendToRecordedEnd(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char sb[36] = {};
  in.read(reinterpret_cast<char*>(sb), sizeof sb);
  // Superblock versions 2 and 3 (what writers of this format make): signature, version, offset size 8,
  // length size 8, flags, base address, extension address, end-of-file address, root address, checksum.
  if (!in || std::memcmp(sb, "\x89HDF\r\n\x1a\n", 8) != 0 || (sb[8] != 2 && sb[8] != 3) || sb[9] != 8) return Status::Ok();
  uint64_t end = 0;
  for (int b = 7; b >= 0; --b) end = end << 8 | sb[28 + b];
  std::error_code ec;
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || end <= size || end > size + (uintmax_t{1} << 32)) return Status::Ok();
  if (truncate(path.c_str(), static_cast<off_t>(end)) != 0)
    return Fail(path, "is shorter than its recorded end and cannot be extended: " + std::string(std::strerror(errno)));
  return Status::Ok();
}

// An existing design file made ready for a writer: extended to its recorded end, and locked (the lock is
// held through a repair and the appends; a rebuilt file carries its own, Salvage's).
static Result<FileLock> LockExistingForWriting(const std::string& path) {
  SilenceHdf5();
  if (!std::filesystem::is_regular_file(path)) return Fail(path, "no such file");
  KGD_RETURN_IF_ERROR(ExtendToRecordedEnd(path));
  return FileLock::Acquire(path);
}

Result<std::unique_ptr<DesignFileWriter>> DesignFileWriter::Reopen(const std::string& path, int keep) {
  Result<FileLock> lock = LockExistingForWriting(path);
  if (!lock.ok()) return lock.status();
  {
    // A writer killed in SWMR mode leaves the superblock marked "open for write", which a plain open
    // refuses. Such a file is rebuilt (Salvage) rather than appended to in place.
    Id probe(H5Fopen(path.c_str(), H5F_ACC_RDWR, WriterAccess()), H5Fclose);
    if (!probe.ok() && std::filesystem::is_regular_file(path)) {
      if (access(path.c_str(), W_OK) != 0) return Fail(path, "not writable");
      // A writer whose last write failed outside SWMR mode (opening, truncating, closing) leaves the
      // superblock marked "open for write" without the SWMR flag, which SWMR readers refuse too. The
      // lock above is held, so no writer has the file: the mark is cleared (what h5clear does) and
      // the file rebuilt from the iterations that read back.
      KGD_RETURN_IF_ERROR(ClearWriteMark(path));
      Result<std::unique_ptr<DesignFileReader>> r = OpenDesignFileReader(path, /*salvage=*/true);
      if (r.ok()) {
        if (keep > static_cast<int>((*r)->marker_rows))
          return Fail(path, "cannot keep " + std::to_string(keep) + " iterations: the file has " + std::to_string((*r)->marker_rows));
        return Salvage(**r, keep);
      }
    }
  }
  {
    // Every kept iteration must read back whole before the file is appended to in SWMR mode: there
    // HDF5 retries a metadata block whose checksum fails 100 times with doubling sleeps (what
    // H5Fstart_swmr_write sets, whatever the access list says), i.e. for ever, where a reader gives up
    // within a second. A damaged file (a disk error, a bad copy; fuzzing found a single byte enough)
    // is rebuilt like a killed writer's, and the original is kept beside it.
    Result<std::unique_ptr<DesignFileReader>> r = OpenDesignFileReader(path, /*salvage=*/false);
    if (r.ok()) {
      const hsize_t check = keep >= 0 ? std::min<hsize_t>(keep, (*r)->rows) : (*r)->rows;
      for (hsize_t i = 0; i < check; ++i) {
        BesoIteration it;
        if (ReadIteration(**r, i, /*arrays=*/true, &it).ok()) continue;
        std::error_code ec;
        std::filesystem::copy_file(path, path + ".damaged", std::filesystem::copy_options::overwrite_existing, ec);
        if (ec) return Fail(path, "iteration " + std::to_string(i) + " cannot be read, and the file cannot be kept as " +
                                      path + ".damaged: " + ec.message());
        Result<std::unique_ptr<DesignFileWriter>> w = Salvage(**r, static_cast<int>(check));
        if (w.ok())
          (*w)->repair_note_ = "rebuilt: iteration " + std::to_string(i) + " cannot be read (damaged); kept " +
                               std::to_string((*w)->num_iterations()) + " of " + std::to_string(check) +
                               " iterations; the damaged file is " + path + ".damaged";
        return w;
      }
    }
  }
  Result<DesignFile> existing = ReadDesignFile(path, {.arrays = false});
  if (!existing.ok()) return existing.status();
  const int stored = static_cast<int>(existing->iterations.size());
  if (keep < 0) keep = stored;
  if (keep > stored)
    return Fail(path, "cannot keep " + std::to_string(keep) + " iterations: the file has " + std::to_string(stored));
  auto w = std::unique_ptr<DesignFileWriter>(new DesignFileWriter);
  w->impl_ = std::make_unique<Impl>();
  Impl& m = *w->impl_;
  m.path = path;
  m.faces = static_cast<int>(existing->header.garment.faces.rows());
  m.vertices = static_cast<int>(existing->header.garment.vertices.rows());
  m.motions = existing->header.motions.size();
  m.lock = std::move(lock).value();
  ClearHdf5Error();
  m.file = Id(H5Fopen(path.c_str(), H5F_ACC_RDWR, WriterAccess()), H5Fclose);
  if (!m.file.ok()) return Fail(path, "cannot open the design file for writing: " + LastHdf5Error());
  m.iterations = Id(H5Gopen2(m.file, "iterations", H5P_DEFAULT), H5Gclose);
  // The commit marker first, so a crash in between leaves a file that reads as `keep` iterations.
  bool ok = m.iterations.ok() && Truncate(m.iterations, "iteration", keep);
  // Metrics newer than the file: their datasets, 0 for the kept iterations.
  for (const MetricSpec& s : Metrics()) {
    if (!ok || !s.optional || HasDataset(m.iterations, s.name)) continue;
    ok = CreateGrowing(m.iterations, s.name, s.integer ? H5T_STD_I32LE : H5T_IEEE_F64LE, {});
    const double zero = 0;
    const int zero_int = 0;
    for (int row = 0; ok && row < keep; ++row)
      ok = WriteRow(m.iterations, s.name, s.integer ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE, row, s.integer ? static_cast<const void*>(&zero_int) : &zero);
  }
  for (const std::string& name : DesignFileMetricNames()) ok = ok && Truncate(m.iterations, name.c_str(), keep);
  for (const char* name : kArrayNames) ok = ok && Truncate(m.iterations, name, keep);
  if (m.motions > 0) ok = ok && Truncate(m.iterations, kMotionMetrics, keep);
  // Files of before the other motions' positions were stored go on without them.
  m.motion_positions = ok && m.motions > 1 && HasDataset(m.iterations, kMotionPositions);
  if (m.motion_positions) ok = Truncate(m.iterations, kMotionPositions, keep);
  if (!ok || H5Fflush(m.file, H5F_SCOPE_GLOBAL) < 0) return Fail(path, "cannot truncate the design file: " + LastHdf5Error());
  // Files of format_version 1 written before SWMR (superblock < 3) cannot enter SWMR mode; they are
  // appended to as before.
  H5Fstart_swmr_write(m.file);
  w->count_ = keep;
  return w;
}

// Rebuilds the file of a killed writer: HDF5 1.10 is not crash-safe even in SWMR mode. Killed at
// random moments while appending (store/design_file_stress.cpp), about one writer in 150 left a
// file whose end of allocation lagged the space its metadata referred to (appending failed with
// "addr overflow"), a dataset shorter than the commit marker, or a chunk index block with a bad
// checksum (tens of committed rows unreadable; a SWMR reader retried it with doubling sleeps for
// hours). Every iteration that reads back whole is copied, in order, into a fresh file that then
// replaces the old one; the first that does not ends the copy (a resumed job recomputes the rest).
Result<std::unique_ptr<DesignFileWriter>> DesignFileWriter::Rebuild(const std::string& path, int keep) {
  Result<FileLock> lock = LockExistingForWriting(path);
  if (!lock.ok()) return lock.status();
  Result<std::unique_ptr<DesignFileReader>> r = OpenDesignFileReader(path, /*salvage=*/true);
  if (!r.ok()) {
    // Marked "open for write" by the failed writer (see Reopen): cleared, as the lock is held.
    KGD_RETURN_IF_ERROR(ClearWriteMark(path));
    r = OpenDesignFileReader(path, /*salvage=*/true);
  }
  if (!r.ok()) return r.status();
  if (keep > static_cast<int>((*r)->marker_rows))
    return Fail(path, "cannot keep " + std::to_string(keep) + " iterations: the file has " + std::to_string((*r)->marker_rows));
  return Salvage(**r, keep);
}

Result<std::unique_ptr<DesignFileWriter>> DesignFileWriter::Salvage(const DesignFileReader& r, int keep) {
  const std::string tmp = r.path + ".salvage";
  Result<std::unique_ptr<DesignFileWriter>> w = Create(tmp, r.header);
  if (!w.ok()) return w.status();
  const hsize_t wanted = keep >= 0 ? static_cast<hsize_t>(keep) : r.marker_rows, rows = std::min(wanted, r.rows);
  std::string stop = rows < wanted ? "iteration " + std::to_string(rows) + " is incomplete" : "";
  for (hsize_t i = 0; i < rows; ++i) {
    BesoIteration it;
    if (Status st = ReadIteration(r, i, /*arrays=*/true, &it); !st.ok()) {
      stop = st.message();
      break;
    }
    if (Status st = (*w)->Append(it); !st.ok()) {
      std::filesystem::remove(tmp);
      return st;
    }
  }
  (*w)->repair_note_ = "rebuilt after its writer was killed: kept " + std::to_string((*w)->num_iterations()) + " of " +
                       std::to_string(wanted) + " iterations" + (stop.empty() ? "" : " (" + stop + ")");
  std::error_code ec;
  std::filesystem::rename(tmp, r.path, ec);
  if (ec) {
    std::filesystem::remove(tmp);
    return Fail(r.path, "cannot replace the file with its repaired copy: " + ec.message());
  }
  (*w)->impl_->path = r.path;
  return w;
}

Status DesignFileWriter::SetSettings(const BesoSettings& settings) {
  Impl& m = *impl_;
  SilenceHdf5();
  ClearHdf5Error();
  Id job(H5Gopen2(m.file, "job", H5P_DEFAULT), H5Gclose);
  if (!job.ok()) return Fail(m.path, "/job cannot be opened");
  if (H5Aexists(job, "settings_next") > 0 && H5Adelete(job, "settings_next") < 0) return Fail(m.path, "/job settings_next cannot be removed");
  if (!WriteStringAttribute(job, "settings_next", BesoSettingsToJson(settings)) || H5Fflush(m.file, H5F_SCOPE_GLOBAL) < 0 ||
      H5Adelete(job, "settings") < 0 || H5Arename(job, "settings_next", "settings") < 0 || H5Fflush(m.file, H5F_SCOPE_GLOBAL) < 0)
    return Fail(m.path, "/job settings cannot be replaced: " + LastHdf5Error());
  return Status::Ok();
}

Status DesignFileWriter::Append(const BesoIteration& it) {
  Impl& m = *impl_;
  SilenceHdf5();
  ClearHdf5Error();
  if (it.iteration != count_)
    return Fail(m.path, "iteration " + std::to_string(it.iteration) + " appended after " + std::to_string(count_) + " stored");
  if (static_cast<int>(it.design.size()) != m.faces || it.positions.rows() != m.vertices || it.energy_density_Pa.size() != m.faces ||
      (it.sensitivity.size() != 0 && it.sensitivity.size() != m.faces))
    return Fail(m.path, "iteration " + std::to_string(it.iteration) + ": arrays do not match the garment");
  if (m.motions > 0 && it.motions.size() != m.motions)
    return Fail(m.path, "iteration " + std::to_string(it.iteration) + ": " + std::to_string(it.motions.size()) + " motions, the file " +
                            std::to_string(m.motions));
  if (m.motion_positions && !it.motion_positions.empty() && (it.motion_positions.size() + 1 != m.motions ||
                                       std::any_of(it.motion_positions.begin(), it.motion_positions.end(),
                                                   [&](const Positions& p) { return p.rows() != m.vertices; })))
    return Fail(m.path, "iteration " + std::to_string(it.iteration) + ": the other motions' positions do not match the garment and motions");
  if (!m.failed.empty()) return Fail(m.path, "an earlier write failed (" + m.failed + "); reopen the file to go on");
  // A full disk is met before a write where it can be: a chunk that fails to write may take the rows it
  // shared with earlier iterations with it (HDF5 is not crash-safe). Room for twice the iteration's
  // arrays and 256 KiB of metadata is kept free.
  const long long needs = 2 * (static_cast<long long>(m.faces) * 25 + static_cast<long long>(m.vertices) * 24 * std::max<long long>(m.motions, 1)) + (1 << 18);
  if (const long long free = FreeBytes(m.path); free >= 0 && free < needs) {
    m.failed = "the disk is nearly full (ENOSPC)";
    return Fail(m.path, "cannot write iteration " + std::to_string(it.iteration) + ": the disk is nearly full (ENOSPC): " + std::to_string(free) +
                            " bytes free on its file system, fewer than the " + std::to_string(needs) + " kgd keeps free to store an iteration whole; " +
                            StoredSoFar(count_));
  }
  const hsize_t row = count_;
  FaultPoint("design_file.append.begin", it.iteration);
  bool ok = true;
  if (m.motions > 0) {
    std::vector<double> v;
    for (const MotionMetrics& mm : it.motions)
      v.insert(v.end(), {mm.energy_J, mm.reinforced_energy_J, mm.reinforced_density_J_per_m2, mm.density_ratio, mm.simulation_s,
                         static_cast<double>(mm.solver_iterations)});
    ok = WriteRow(m.iterations, kMotionMetrics, H5T_NATIVE_DOUBLE, row, v.data());
  }
  for (const MetricSpec& s : Metrics()) {
    if (s.integer) {
      const int v = it.*(s.whole);
      ok = ok && WriteRow(m.iterations, s.name, H5T_NATIVE_INT, row, &v);
    } else {
      const double v = it.*(s.real);
      ok = ok && WriteRow(m.iterations, s.name, H5T_NATIVE_DOUBLE, row, &v);
    }
  }
  const int status = static_cast<int>(it.status);
  const std::vector<double> x = RowMajor(it.positions);
  const Eigen::VectorXd sens = it.sensitivity.size() ? it.sensitivity : Eigen::VectorXd::Zero(m.faces);
  ok = ok && WriteRow(m.iterations, "status", H5T_NATIVE_INT, row, &status) &&
       WriteRow(m.iterations, "design", H5T_NATIVE_UINT8, row, it.design.data()) &&
       WriteRow(m.iterations, "positions", H5T_NATIVE_DOUBLE, row, x.data()) &&
       WriteRow(m.iterations, "energy_density_Pa", H5T_NATIVE_DOUBLE, row, it.energy_density_Pa.data()) &&
       WriteRow(m.iterations, "sensitivity", H5T_NATIVE_DOUBLE, row, sens.data());
  if (ok && m.motion_positions) {
    std::vector<double> all((m.motions - 1) * m.vertices * 3, std::numeric_limits<double>::quiet_NaN());
    for (size_t k = 0; k < it.motion_positions.size(); ++k) {
      const std::vector<double> xk = RowMajor(it.motion_positions[k]);
      std::copy(xk.begin(), xk.end(), all.begin() + k * m.vertices * 3);
    }
    ok = WriteRow(m.iterations, kMotionPositions, H5T_NATIVE_DOUBLE, row, all.data());
  }
  // Last, once everything else is on disk: the commit marker. (Within one flush HDF5 may write the
  // marker's extent before another dataset's chunk; a writer killed in between left a file whose
  // marker promised a row the design did not have.)
  FaultPoint("design_file.append.after_arrays", it.iteration);
  ok = ok && H5Fflush(m.file, H5F_SCOPE_GLOBAL) >= 0;
  FaultPoint("design_file.append.after_flush", it.iteration);
  ok = ok && WriteRow(m.iterations, "iteration", H5T_NATIVE_INT, row, &it.iteration);
  FaultPoint("design_file.append.after_marker", it.iteration);
  if (!ok || H5Fflush(m.file, H5F_SCOPE_GLOBAL) < 0) {
    m.failed = LastHdf5Error();
    // The commit marker back to the iterations stored, so that the file reads as them (best effort:
    // on a failing disk this may fail too, and a reopen then rebuilds the file from what reads back).
    if (Truncate(m.iterations, "iteration", count_)) H5Fflush(m.file, H5F_SCOPE_GLOBAL);
    return Fail(m.path, "cannot write iteration " + std::to_string(it.iteration) + ": " + m.failed + "; " + StoredSoFar(count_));
  }
  ++count_;
  FaultPoint("design_file.append.end", it.iteration);
  return Status::Ok();
}

Result<DesignFileCheck> CheckDesignFile(const std::string& path) {
  Result<std::unique_ptr<DesignFileReader>> r = OpenDesignFileReader(path, /*salvage=*/true);
  if (!r.ok()) return r.status();
  const DesignFileReader& reader = **r;
  DesignFileCheck check;
  check.iterations = static_cast<int>(reader.marker_rows);
  if (reader.rows < reader.marker_rows) {
    check.first_damage = Fail(path, "iteration " + std::to_string(reader.rows) + " is incomplete (a writer killed mid-write?)").message();
    for (hsize_t i = reader.rows; i < reader.marker_rows; ++i) check.damaged.push_back(static_cast<int>(i));
  }
  bool intact = true;
  for (hsize_t i = 0; i < reader.rows; ++i) {
    BesoIteration it;
    const Status st = ReadIteration(reader, i, /*arrays=*/true, &it);
    if (st.ok()) {
      if (intact) check.intact = static_cast<int>(i) + 1;
      continue;
    }
    intact = false;
    if (check.damaged.empty() || check.damaged.front() > static_cast<int>(i)) check.first_damage = st.message();
    check.damaged.push_back(static_cast<int>(i));
  }
  std::sort(check.damaged.begin(), check.damaged.end());
  return check;
}

Result<DesignFile> ReadDesignFile(const std::string& path, const DesignFileReadOptions& options) {
  Result<std::unique_ptr<DesignFileReader>> r = OpenDesignFileReader(path, /*salvage=*/false);
  if (!r.ok()) return r.status();
  const DesignFileReader& reader = **r;
  if (options.only_iteration >= static_cast<int>(reader.rows))
    return Fail(path, "iteration " + std::to_string(options.only_iteration) + " is not stored (the file has " +
                          std::to_string(reader.rows) + " iterations, 0.." + std::to_string(static_cast<int>(reader.rows) - 1) + ")");
  DesignFile out;
  out.header = reader.header;
  out.iterations.resize(reader.rows);
  KGD_RETURN_IF_ERROR(ReadMetricRows(reader, 0, reader.rows, out.iterations.data()));
  if (!options.arrays) return out;
  for (hsize_t i = 0; i < reader.rows; ++i)
    if (options.only_iteration < 0 || options.only_iteration == static_cast<int>(i))
      KGD_RETURN_IF_ERROR(ReadIteration(reader, i, /*arrays=*/true, &out.iterations[i]));
  return out;
}

}  // namespace kgd
