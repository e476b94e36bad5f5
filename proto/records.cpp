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
