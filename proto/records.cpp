#include "proto/records.h"

#include <string>

namespace kgd {
namespace {

template <typename Field>
Eigen::VectorXd ToVector(const Field& f) {
  Eigen::VectorXd v(f.size());
  for (int i = 0; i < f.size(); ++i) v[i] = f[i];
  return v;
}

template <typename Field>
void Append(const double* data, Eigen::Index n, Field* out) {
  out->Reserve(static_cast<int>(n));
  for (Eigen::Index i = 0; i < n; ++i) out->Add(data[i]);
}

Result<SolveStatus> StatusFromName(const std::string& name) {
  for (int k = 0; k <= static_cast<int>(kLastSolveStatus); ++k)
    if (name == ToString(static_cast<SolveStatus>(k))) return static_cast<SolveStatus>(k);
  return Status::Error("metrics.solve_status: unknown status '" + name + "'");
}

}  // namespace

v1::IterationMetrics MetricsToProto(const BesoIteration& it) {
  v1::IterationMetrics m;
  m.set_iteration(it.iteration);
  m.set_target_area_m2(it.target_area_m2);
  m.set_area_fraction(it.area_fraction);
  m.set_energy_j(it.energy_J);
  m.set_reinforced_energy_j(it.reinforced_energy_J);
  m.set_reinforced_density_j_per_m2(it.reinforced_density_J_per_m2);
  m.set_density_ratio(it.density_ratio);
  m.set_solve_status(ToString(it.status));
  m.set_solver_iterations(it.solver_iterations);
  m.set_cold_restart(it.cold_restart);
  m.set_simulation_s(it.simulation_s);
  m.set_sensitivity_s(it.sensitivity_s);
  m.set_filter_s(it.filter_s);
  m.set_update_s(it.update_s);
  m.set_total_s(it.total_s);
  return m;
}

BesoIteration MetricsFromProto(const v1::IterationMetrics& m) {
  BesoIteration it;
  it.iteration = m.iteration();
  it.target_area_m2 = m.target_area_m2();
  it.area_fraction = m.area_fraction();
  it.energy_J = m.energy_j();
  it.reinforced_energy_J = m.reinforced_energy_j();
  it.reinforced_density_J_per_m2 = m.reinforced_density_j_per_m2();
  it.density_ratio = m.density_ratio();
  Result<SolveStatus> st = StatusFromName(m.solve_status());
  it.status = st.ok() ? *st : SolveStatus::kInvalidState;
  it.solver_iterations = m.solver_iterations();
  it.cold_restart = m.cold_restart();
  it.simulation_s = m.simulation_s();
  it.sensitivity_s = m.sensitivity_s();
  it.filter_s = m.filter_s();
  it.update_s = m.update_s();
  it.total_s = m.total_s();
  return it;
}

v1::IterationRecord RecordToProto(const BesoIteration& it, const RecordArrays& arrays) {
  v1::IterationRecord r;
  *r.mutable_metrics() = MetricsToProto(it);
  if (arrays.design) r.set_design(std::string(it.design.begin(), it.design.end()));
  if (arrays.positions) Append(it.positions.data(), it.positions.size(), r.mutable_positions());
  if (arrays.energy_density) Append(it.energy_density_Pa.data(), it.energy_density_Pa.size(), r.mutable_energy_density_pa());
  if (arrays.sensitivity) Append(it.sensitivity.data(), it.sensitivity.size(), r.mutable_sensitivity());
  return r;
}

Result<BesoIteration> RecordFromProto(const v1::IterationRecord& r, int faces, int vertices) {
  if (Result<SolveStatus> st = StatusFromName(r.metrics().solve_status()); !st.ok()) return st.status();
  BesoIteration it = MetricsFromProto(r.metrics());
  const std::string where = "iteration " + std::to_string(it.iteration) + ": ";
  if (faces > 0) {
    if (static_cast<int>(r.design().size()) != faces)
      return Status::Error(where + "design has " + std::to_string(r.design().size()) + " faces, the garment " + std::to_string(faces));
    if (r.energy_density_pa_size() != faces)
      return Status::Error(where + "energy_density_Pa has " + std::to_string(r.energy_density_pa_size()) + " values for " +
                           std::to_string(faces) + " faces");
    if (r.sensitivity_size() != 0 && r.sensitivity_size() != faces)
      return Status::Error(where + "sensitivity has " + std::to_string(r.sensitivity_size()) + " values for " +
                           std::to_string(faces) + " faces");
  }
  if (vertices > 0 && r.positions_size() != 3 * vertices)
    return Status::Error(where + "positions has " + std::to_string(r.positions_size()) + " values for " + std::to_string(vertices) +
                         " vertices");
  if (r.positions_size() % 3 != 0) return Status::Error(where + "positions is not a multiple of 3 long");
  it.design.assign(r.design().begin(), r.design().end());
  for (uint8_t& d : it.design)
    if (d > 1) return Status::Error(where + "design value " + std::to_string(d) + " is not 0 or 1");
  it.positions.resize(r.positions_size() / 3, 3);
  for (int i = 0; i < r.positions_size(); ++i) it.positions.data()[i] = r.positions(i);
  it.energy_density_Pa = ToVector(r.energy_density_pa());
  it.sensitivity = ToVector(r.sensitivity());
  return it;
}

v1::Garment GarmentToProto(const DesignFileHeader& h) {
  v1::Garment g;
  Append(h.garment.vertices.data(), h.garment.vertices.size(), g.mutable_rest_vertices());
  for (Eigen::Index f = 0; f < h.garment.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) g.add_faces(h.garment.faces(f, k));
  Append(h.rest_area_m2.data(), h.rest_area_m2.size(), g.mutable_rest_area_m2());
  Append(h.initial.data(), h.initial.size(), g.mutable_initial_positions());
  for (int a : h.attachment_faces) g.add_attachment_faces(a);
  return g;
}

Status GarmentFromProto(const v1::Garment& g, DesignFileHeader* h) {
  const int nv = g.rest_vertices_size() / 3, nf = g.faces_size() / 3;
  if (g.rest_vertices_size() % 3 || g.faces_size() % 3 || nv == 0 || nf == 0)
    return Status::Error("garment: rest_vertices and faces must be non-empty lists of triples");
  if (g.initial_positions_size() != 3 * nv) return Status::Error("garment: initial_positions does not match rest_vertices");
  if (g.rest_area_m2_size() != nf) return Status::Error("garment: rest_area_m2 does not match faces");
  h->garment.vertices.resize(nv, 3);
  h->initial.resize(nv, 3);
  for (int i = 0; i < 3 * nv; ++i) {
    h->garment.vertices.data()[i] = g.rest_vertices(i);
    h->initial.data()[i] = g.initial_positions(i);
  }
  h->garment.faces.resize(nf, 3);
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = g.faces(3 * f + k);
      if (v < 0 || v >= nv) return Status::Error("garment: face " + std::to_string(f) + " names vertex " + std::to_string(v));
      h->garment.faces(f, k) = v;
    }
  h->rest_area_m2 = ToVector(g.rest_area_m2());
  h->attachment_faces.assign(g.attachment_faces().begin(), g.attachment_faces().end());
  for (int a : h->attachment_faces)
    if (a < 0 || a >= nf) return Status::Error("garment: attachment face " + std::to_string(a) + " is not a face");
  return Status::Ok();
}

}  // namespace kgd
