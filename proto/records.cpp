#include "proto/records.h"

#include <string>
#include <type_traits>

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

// The IterationMetrics field of a KGD_BESO_METRICS entry; null (the value is then not carried) only
// when the schema lacks it, which CheckMetricFields reports.
const google::protobuf::FieldDescriptor* MetricField(const char* name) { return v1::IterationMetrics::descriptor()->FindFieldByName(name); }

void SetField(const google::protobuf::Reflection* r, v1::IterationMetrics* m, const google::protobuf::FieldDescriptor* f, double v) {
  if (f) r->SetDouble(m, f, v);
}
void SetField(const google::protobuf::Reflection* r, v1::IterationMetrics* m, const google::protobuf::FieldDescriptor* f, int v) {
  if (f) r->SetInt32(m, f, v);
}
void GetField(const google::protobuf::Reflection* r, const v1::IterationMetrics& m, const google::protobuf::FieldDescriptor* f, double* v) {
  if (f) *v = r->GetDouble(m, f);
}
void GetField(const google::protobuf::Reflection* r, const v1::IterationMetrics& m, const google::protobuf::FieldDescriptor* f, int* v) {
  if (f) *v = r->GetInt32(m, f);
}

void MotionToProto(const MotionMetrics& mm, v1::MotionMetrics* p) {
  p->set_name(mm.name);
  p->set_role(ToString(mm.role));
  p->set_weight(mm.weight);
  p->set_energy_j(mm.energy_J);
  p->set_reinforced_energy_j(mm.reinforced_energy_J);
  p->set_reinforced_density_j_per_m2(mm.reinforced_density_J_per_m2);
  p->set_density_ratio(mm.density_ratio);
  p->set_simulation_s(mm.simulation_s);
  p->set_solver_iterations(mm.solver_iterations);
}

MotionMetrics MotionFromProto(const v1::MotionMetrics& p) {
  MotionMetrics mm;
  mm.name = p.name();
  mm.role = p.role() == "allow" ? MotionRole::kAllow : MotionRole::kResist;
  mm.weight = p.weight();
  mm.energy_J = p.energy_j();
  mm.reinforced_energy_J = p.reinforced_energy_j();
  mm.reinforced_density_J_per_m2 = p.reinforced_density_j_per_m2();
  mm.density_ratio = p.density_ratio();
  mm.simulation_s = p.simulation_s();
  mm.solver_iterations = p.solver_iterations();
  return mm;
}

}  // namespace

Status CheckMetricFields() {
  const google::protobuf::Descriptor* d = v1::IterationMetrics::descriptor();
  using google::protobuf::FieldDescriptor;
  auto check = [&](const char* name, FieldDescriptor::CppType type) -> Status {
    const FieldDescriptor* f = d->FindFieldByName(name);
    if (!f) return Status::Error(std::string("kgd.v1.IterationMetrics has no field '") + name + "'");
    if (f->cpp_type() != type) return Status::Error(std::string("kgd.v1.IterationMetrics.") + name + " has another type");
    return Status::Ok();
  };
#define KGD_CHECK_METRIC(type, name, what)                                                                                          \
  KGD_RETURN_IF_ERROR(check(#name, std::is_same_v<type, int> ? FieldDescriptor::CPPTYPE_INT32 : FieldDescriptor::CPPTYPE_DOUBLE));
  KGD_BESO_METRICS(KGD_CHECK_METRIC)
#undef KGD_CHECK_METRIC
  return Status::Ok();
}

v1::IterationMetrics MetricsToProto(const BesoIteration& it) {
  v1::IterationMetrics m;
  m.set_iteration(it.iteration);
  m.set_solve_status(ToString(it.status));
  const google::protobuf::Reflection* r = m.GetReflection();
#define KGD_METRIC_TO_PROTO(type, name, what) SetField(r, &m, MetricField(#name), it.name);
  KGD_BESO_METRICS(KGD_METRIC_TO_PROTO)
#undef KGD_METRIC_TO_PROTO
  for (const MotionMetrics& mm : it.motions) MotionToProto(mm, m.add_motions());
  return m;
}

BesoIteration MetricsFromProto(const v1::IterationMetrics& m) {
  BesoIteration it;
  it.iteration = m.iteration();
  Result<SolveStatus> st = StatusFromName(m.solve_status());
  it.status = st.ok() ? *st : SolveStatus::kInvalidState;
  const google::protobuf::Reflection* r = m.GetReflection();
#define KGD_METRIC_FROM_PROTO(type, name, what) GetField(r, m, MetricField(#name), &it.name);
  KGD_BESO_METRICS(KGD_METRIC_FROM_PROTO)
#undef KGD_METRIC_FROM_PROTO
  for (const v1::MotionMetrics& p : m.motions()) it.motions.push_back(MotionFromProto(p));
  return it;
}

v1::IterationRecord RecordToProto(const BesoIteration& it, const RecordArrays& arrays) {
  v1::IterationRecord r;
  *r.mutable_metrics() = MetricsToProto(it);
  if (arrays.design) r.set_design(std::string(it.design.begin(), it.design.end()));
  if (arrays.positions) Append(it.positions.data(), it.positions.size(), r.mutable_positions());
  if (arrays.positions)
    for (const Positions& p : it.motion_positions) Append(p.data(), p.size(), r.mutable_motion_positions());
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
  if (r.motion_positions_size() > 0) {
    const int nv = static_cast<int>(it.positions.rows()), others = static_cast<int>(it.motions.size()) - 1;
    if (nv == 0 || others < 1 || r.motion_positions_size() != others * 3 * nv)
      return Status::Error(where + "motion_positions has " + std::to_string(r.motion_positions_size()) + " values for " +
                           std::to_string(std::max(others, 0)) + " other motions of " + std::to_string(nv) + " vertices");
    for (int k = 0; k < others; ++k) {
      Positions p(nv, 3);
      for (int i = 0; i < 3 * nv; ++i) p.data()[i] = r.motion_positions(k * 3 * nv + i);
      it.motion_positions.push_back(std::move(p));
    }
  }
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
  g.set_cloth_thickness_m(h.cloth_thickness_m);
  g.set_reinforced_thickness_m(h.reinforced_thickness_m);
  Append(h.body_mesh.vertices.data(), h.body_mesh.vertices.size(), g.mutable_body_vertices());
  for (Eigen::Index f = 0; f < h.body_mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) g.add_body_faces(h.body_mesh.faces(f, k));
  for (const MotionMetrics& m : h.motions) MotionToProto(m, g.add_motions());
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
  if (!(g.cloth_thickness_m() >= 0) || !(g.reinforced_thickness_m() >= 0))
    return Status::Error("garment: thicknesses must be >= 0 m");
  h->cloth_thickness_m = g.cloth_thickness_m();
  h->reinforced_thickness_m = g.reinforced_thickness_m();
  const int bv = g.body_vertices_size() / 3, bf = g.body_faces_size() / 3;
  if (g.body_vertices_size() % 3 || g.body_faces_size() % 3 || (bv == 0) != (bf == 0))
    return Status::Error("garment: body_vertices and body_faces must be lists of triples, both empty or both not");
  h->body_mesh.vertices.resize(bv, 3);
  for (int i = 0; i < 3 * bv; ++i) h->body_mesh.vertices.data()[i] = g.body_vertices(i);
  h->body_mesh.faces.resize(bf, 3);
  for (int f = 0; f < bf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = g.body_faces(3 * f + k);
      if (v < 0 || v >= bv) return Status::Error("garment: body face " + std::to_string(f) + " names vertex " + std::to_string(v));
      h->body_mesh.faces(f, k) = v;
    }
  h->motions.clear();
  for (const v1::MotionMetrics& m : g.motions()) {
    Result<MotionRole> role = MotionRoleFromName(m.role(), "garment: motion '" + m.name() + "'");
    if (!role.ok()) return role.status();
    if (!(m.weight() >= 0)) return Status::Error("garment: motion '" + m.name() + "': weight must be >= 0");
    h->motions.push_back(MotionFromProto(m));
  }
  return Status::Ok();
}

namespace {

template <typename Field>
Result<Positions> PositionsFrom(const Field& f, int rows, const std::string& what) {
  if (f.size() % 3 || (rows > 0 && f.size() != 3 * rows))
    return Status::Error(what + ": " + std::to_string(f.size()) + " coordinates" + (rows > 0 ? " for " + std::to_string(rows) + " vertices" : ""));
  Positions x(f.size() / 3, 3);
  for (int i = 0; i < f.size(); ++i) x.data()[i] = f[i];
  return x;
}

}  // namespace

v1::DesignEvaluation EvaluationToProto(const DesignEvaluation& e) {
  v1::DesignEvaluation p;
  p.set_iteration(e.iteration);
  p.set_note(e.note);
  for (const EvaluatedFrame& f : e.frames) {
    v1::MotionFrame* m = p.add_frames();
    Append(f.garment.data(), f.garment.size(), m->mutable_positions());
    Append(f.body.data(), f.body.size(), m->mutable_body_vertices());
    Append(f.energy_density_Pa.data(), f.energy_density_Pa.size(), m->mutable_energy_density_pa());
    m->set_energy_j(f.energy_J);
    m->set_solve_status(f.status);
    Append(f.skin_pressure_Pa.data(), f.skin_pressure_Pa.size(), m->mutable_skin_pressure_pa());
  }
  for (const EvaluatedBaseline& b : e.baselines) {
    v1::BaselineRecord* r = p.add_baselines();
    r->set_name(b.name);
    r->set_design(std::string(b.design.begin(), b.design.end()));
    Append(b.positions.data(), b.positions.size(), r->mutable_positions());
    Append(b.energy_density_Pa.data(), b.energy_density_Pa.size(), r->mutable_energy_density_pa());
    r->set_area_fraction(b.area_fraction);
    r->set_energy_j(b.energy_J);
    r->set_reinforced_energy_j(b.reinforced_energy_J);
    r->set_reinforced_density_j_per_m2(b.reinforced_density_J_per_m2);
    r->set_density_ratio(b.density_ratio);
    r->set_solve_status(b.status);
  }
  return p;
}

Result<DesignEvaluation> EvaluationFromProto(const v1::DesignEvaluation& p, int faces, int vertices, int body_vertices) {
  DesignEvaluation e;
  e.iteration = p.iteration();
  e.note = p.note();
  for (int k = 0; k < p.frames_size(); ++k) {
    const v1::MotionFrame& m = p.frames(k);
    const std::string what = "evaluation frame " + std::to_string(k + 1);
    Result<Positions> x = PositionsFrom(m.positions(), vertices, what + " positions");
    Result<Positions> body = PositionsFrom(m.body_vertices(), m.body_vertices_size() ? body_vertices : 0, what + " body_vertices");
    if (!x.ok()) return x.status();
    if (!body.ok()) return body.status();
    if (faces > 0 && m.energy_density_pa_size() != faces) return Status::Error(what + ": energy_density_Pa does not match the faces");
    if (k > 0 && (x->rows() != e.frames[0].garment.rows() || body->rows() != e.frames[0].body.rows()))
      return Status::Error(what + ": differs in size from frame 1");
    if (m.skin_pressure_pa_size() && m.skin_pressure_pa_size() != body->rows())
      return Status::Error(what + ": skin_pressure_Pa has " + std::to_string(m.skin_pressure_pa_size()) + " values for " +
                           std::to_string(body->rows()) + " body vertices");
    e.frames.push_back({std::move(x).value(), std::move(body).value(), ToVector(m.energy_density_pa()), m.energy_j(), m.solve_status(),
                        ToVector(m.skin_pressure_pa())});
  }
  for (const v1::BaselineRecord& r : p.baselines()) {
    const std::string what = "evaluation baseline '" + r.name() + "'";
    if (r.name().empty() || r.name().find('\n') != std::string::npos) return Status::Error("evaluation baseline: a name on one line is needed");
    Result<Positions> x = PositionsFrom(r.positions(), vertices, what + " positions");
    if (!x.ok()) return x.status();
    if (static_cast<int>(r.design().size()) != r.energy_density_pa_size() || (faces > 0 && r.energy_density_pa_size() != faces))
      return Status::Error(what + ": design and energy_density_Pa do not match the faces");
    EvaluatedBaseline b;
    b.name = r.name();
    b.design.assign(r.design().begin(), r.design().end());
    b.positions = std::move(x).value();
    b.energy_density_Pa = ToVector(r.energy_density_pa());
    b.area_fraction = r.area_fraction();
    b.energy_J = r.energy_j();
    b.reinforced_energy_J = r.reinforced_energy_j();
    b.reinforced_density_J_per_m2 = r.reinforced_density_j_per_m2();
    b.density_ratio = r.density_ratio();
    b.status = r.solve_status();
    e.baselines.push_back(std::move(b));
  }
  return e;
}

}  // namespace kgd
