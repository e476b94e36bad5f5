#include "store/design_evaluation.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <sstream>

#include "store/hdf5.h"

namespace kgd {
namespace {

using namespace hdf5;
constexpr const char* kFormat = "kgd design evaluation";
constexpr int kFormatVersion = 1;

Status Fail(const std::string& path, const std::string& what) { return Status::Error(path + ": " + what); }

std::string JoinLines(const std::vector<std::string>& items) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? "\n" : "") + items[i];
  return out;
}

std::vector<std::string> SplitLines(const std::string& text, size_t n) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  out.resize(n);
  return out;
}

// Rows of equal-shaped matrices, stacked row-major.
template <typename Get>
std::vector<double> Stack(size_t n, Get get) {
  std::vector<double> out;
  for (size_t i = 0; i < n; ++i) {
    const auto& m = get(i);
    out.insert(out.end(), m.data(), m.data() + m.size());
  }
  return out;
}

Positions RowsOf(const std::vector<double>& data, size_t k, size_t rows) {
  Positions x(rows, 3);
  std::copy(data.begin() + k * rows * 3, data.begin() + (k + 1) * rows * 3, x.data());
  return x;
}

Eigen::VectorXd SliceOf(const std::vector<double>& data, size_t k, size_t n) {
  return Eigen::Map<const Eigen::VectorXd>(data.data() + k * n, static_cast<Eigen::Index>(n));
}

}  // namespace

std::string EvaluationPath(const std::string& design_file) {
  std::filesystem::path p(design_file);
  p.replace_extension(".evaluation.h5");
  return p.string();
}

Status WriteDesignEvaluation(const std::string& path, const DesignEvaluation& e) {
  SilenceHdf5();
  const size_t k = e.frames.size(), b = e.baselines.size();
  const hsize_t nv = k ? e.frames[0].garment.rows() : b ? e.baselines[0].positions.rows() : 0;
  const hsize_t nf = k ? e.frames[0].energy_density_Pa.size() : b ? e.baselines[0].design.size() : 0;
  const hsize_t nb = k ? e.frames[0].body.rows() : 0;
  const hsize_t np = k ? e.frames[0].skin_pressure_Pa.size() : 0;
  for (const EvaluatedFrame& f : e.frames)
    if (static_cast<hsize_t>(f.garment.rows()) != nv || static_cast<hsize_t>(f.energy_density_Pa.size()) != nf ||
        static_cast<hsize_t>(f.body.rows()) != nb || static_cast<hsize_t>(f.skin_pressure_Pa.size()) != np)
      return Fail(path, "evaluation frames differ in size");
  if (np > 0 && np != nb) return Fail(path, "the skin pressure has " + std::to_string(np) + " values for " + std::to_string(nb) + " body vertices");
  for (const EvaluatedBaseline& s : e.baselines)
    if (static_cast<hsize_t>(s.positions.rows()) != nv || s.design.size() != nf || static_cast<hsize_t>(s.energy_density_Pa.size()) != nf)
      return Fail(path, "evaluation baselines differ in size");

  const std::string temporary = path + ".tmp" + std::to_string(getpid());
  {
    Id file(H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (!file.ok()) return Fail(path, "cannot create the HDF5 file (does the folder exist, is it writable?)");
    bool ok = WriteStringAttribute(file, "format", kFormat) && WriteIntAttribute(file, "format_version", kFormatVersion) &&
              WriteIntAttribute(file, "iteration", e.iteration) && WriteStringAttribute(file, "note", e.note);
    if (k > 0) {
      Id g(H5Gcreate2(file, "frames", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
      const std::vector<double> x = Stack(k, [&](size_t i) -> const Positions& { return e.frames[i].garment; });
      const std::vector<double> w = Stack(k, [&](size_t i) -> const Eigen::VectorXd& { return e.frames[i].energy_density_Pa; });
      std::vector<double> energy(k);
      std::vector<std::string> status(k);
      for (size_t i = 0; i < k; ++i) energy[i] = e.frames[i].energy_J, status[i] = e.frames[i].status;
      ok = ok && g.ok() && WriteFixed(g, "positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {k, nv, 3}, x.data()) &&
           WriteFixed(g, "energy_density_Pa", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {k, nf}, w.data()) &&
           WriteFixed(g, "energy_J", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {k}, energy.data());
      if (ok && nb > 0) {
        const std::vector<double> body = Stack(k, [&](size_t i) -> const Positions& { return e.frames[i].body; });
        ok = WriteFixed(g, "body", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {k, nb, 3}, body.data());
      }
      if (ok && np > 0) {
        const std::vector<double> p = Stack(k, [&](size_t i) -> const Eigen::VectorXd& { return e.frames[i].skin_pressure_Pa; });
        ok = WriteFixed(g, "skin_pressure_Pa", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {k, np}, p.data());
      }
      if (ok) {
        Id set(H5Dopen2(g, "energy_J", H5P_DEFAULT), H5Dclose);
        ok = set.ok() && WriteStringAttribute(set, "status", JoinLines(status));
      }
    }
    if (b > 0) {
      Id g(H5Gcreate2(file, "baselines", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
      std::vector<uint8_t> design;
      std::vector<double> figures;
      std::vector<std::string> names, status;
      for (const EvaluatedBaseline& s : e.baselines) {
        design.insert(design.end(), s.design.begin(), s.design.end());
        figures.insert(figures.end(), {s.area_fraction, s.energy_J, s.reinforced_energy_J, s.reinforced_density_J_per_m2, s.density_ratio});
        names.push_back(s.name);
        status.push_back(s.status);
      }
      const std::vector<double> x = Stack(b, [&](size_t i) -> const Positions& { return e.baselines[i].positions; });
      const std::vector<double> w = Stack(b, [&](size_t i) -> const Eigen::VectorXd& { return e.baselines[i].energy_density_Pa; });
      ok = ok && g.ok() && WriteFixed(g, "design", H5T_STD_U8LE, H5T_NATIVE_UINT8, {b, nf}, design.data()) &&
           WriteFixed(g, "positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {b, nv, 3}, x.data()) &&
           WriteFixed(g, "energy_density_Pa", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {b, nf}, w.data()) &&
           WriteFixed(g, "figures", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {b, 5}, figures.data());
      if (ok) {
        Id set(H5Dopen2(g, "design", H5P_DEFAULT), H5Dclose);
        Id fig(H5Dopen2(g, "figures", H5P_DEFAULT), H5Dclose);
        ok = set.ok() && fig.ok() && WriteStringAttribute(set, "names", JoinLines(names)) && WriteStringAttribute(fig, "status", JoinLines(status));
      }
    }
    if (!ok || H5Fflush(file, H5F_SCOPE_GLOBAL) < 0) {
      file.reset();
      std::filesystem::remove(temporary);
      return Fail(path, "cannot write the evaluation (disk full?)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary);
    return Fail(path, "cannot rename the finished evaluation into place: " + ec.message());
  }
  return Status::Ok();
}

Result<DesignEvaluation> ReadDesignEvaluation(const std::string& path) {
  SilenceHdf5();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return Fail(path, "no such file");
  Id file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) return Fail(path, "not an HDF5 file");
  std::string format;
  int version = 0;
  DesignEvaluation e;
  if (!ReadStringAttribute(file, "format", &format) || format != kFormat) return Fail(path, "not a kgd design evaluation");
  if (!ReadIntAttribute(file, "format_version", &version) || version != kFormatVersion)
    return Fail(path, "evaluation format_version " + std::to_string(version) + " is not supported");
  if (!ReadIntAttribute(file, "iteration", &e.iteration) || !ReadStringAttribute(file, "note", &e.note))
    return Fail(path, "the evaluation's attributes are missing");
  if (H5Lexists(file, "frames", H5P_DEFAULT) > 0) {
    Id g(H5Gopen2(file, "frames", H5P_DEFAULT), H5Gclose);
    const std::vector<hsize_t> xs = Shape(g, "positions"), ws = Shape(g, "energy_density_Pa"), es = Shape(g, "energy_J"), bs = Shape(g, "body"),
                               ps = Shape(g, "skin_pressure_Pa");
    if (xs.size() != 3 || ws.size() != 2 || es.size() != 1 || ws[0] != xs[0] || es[0] != xs[0] || (!bs.empty() && (bs.size() != 3 || bs[0] != xs[0])) ||
        (!ps.empty() && (bs.empty() || ps != std::vector<hsize_t>{xs[0], bs[1]})))
      return Fail(path, "/frames datasets are missing or have inconsistent shapes");
    const size_t k = xs[0], nv = xs[1], nf = ws[1], nb = bs.empty() ? 0 : bs[1], np = ps.empty() ? 0 : ps[1];
    std::vector<double> x(k * nv * 3), w(k * nf), energy(k), body(k * nb * 3), pressure(k * np);
    std::string status;
    Id set(H5Dopen2(g, "energy_J", H5P_DEFAULT), H5Dclose);
    if (!ReadAll(g, "positions", H5T_NATIVE_DOUBLE, x.data()) || !ReadAll(g, "energy_density_Pa", H5T_NATIVE_DOUBLE, w.data()) ||
        !ReadAll(g, "energy_J", H5T_NATIVE_DOUBLE, energy.data()) || (nb && !ReadAll(g, "body", H5T_NATIVE_DOUBLE, body.data())) ||
        (np && !ReadAll(g, "skin_pressure_Pa", H5T_NATIVE_DOUBLE, pressure.data())) ||
        !set.ok() || !ReadStringAttribute(set, "status", &status))
      return Fail(path, "cannot read /frames (damaged?)");
    const std::vector<std::string> statuses = SplitLines(status, k);
    for (size_t i = 0; i < k; ++i)
      e.frames.push_back({RowsOf(x, i, nv), RowsOf(body, i, nb), SliceOf(w, i, nf), energy[i], statuses[i], SliceOf(pressure, i, np)});
  }
  if (H5Lexists(file, "baselines", H5P_DEFAULT) > 0) {
    Id g(H5Gopen2(file, "baselines", H5P_DEFAULT), H5Gclose);
    const std::vector<hsize_t> ds = Shape(g, "design"), xs = Shape(g, "positions"), ws = Shape(g, "energy_density_Pa"), fs = Shape(g, "figures");
    if (ds.size() != 2 || xs.size() != 3 || ws != ds || fs != std::vector<hsize_t>{ds[0], 5} || xs[0] != ds[0])
      return Fail(path, "/baselines datasets are missing or have inconsistent shapes");
    const size_t b = ds[0], nf = ds[1], nv = xs[1];
    std::vector<uint8_t> design(b * nf);
    std::vector<double> x(b * nv * 3), w(b * nf), figures(b * 5);
    std::string names, status;
    Id set(H5Dopen2(g, "design", H5P_DEFAULT), H5Dclose);
    Id fig(H5Dopen2(g, "figures", H5P_DEFAULT), H5Dclose);
    if (!ReadAll(g, "design", H5T_NATIVE_UINT8, design.data()) || !ReadAll(g, "positions", H5T_NATIVE_DOUBLE, x.data()) ||
        !ReadAll(g, "energy_density_Pa", H5T_NATIVE_DOUBLE, w.data()) || !ReadAll(g, "figures", H5T_NATIVE_DOUBLE, figures.data()) ||
        !set.ok() || !fig.ok() || !ReadStringAttribute(set, "names", &names) || !ReadStringAttribute(fig, "status", &status))
      return Fail(path, "cannot read /baselines (damaged?)");
    const std::vector<std::string> name = SplitLines(names, b), statuses = SplitLines(status, b);
    for (size_t i = 0; i < b; ++i) {
      EvaluatedBaseline s;
      s.name = name[i];
      s.design.assign(design.begin() + i * nf, design.begin() + (i + 1) * nf);
      s.positions = RowsOf(x, i, nv);
      s.energy_density_Pa = SliceOf(w, i, nf);
      const double* f = figures.data() + 5 * i;
      s.area_fraction = f[0], s.energy_J = f[1], s.reinforced_energy_J = f[2], s.reinforced_density_J_per_m2 = f[3], s.density_ratio = f[4];
      s.status = statuses[i];
      e.baselines.push_back(std::move(s));
    }
  }
  return e;
}

}  // namespace kgd
