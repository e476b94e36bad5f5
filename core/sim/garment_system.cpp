#include "core/sim/garment_system.h"

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include <omp.h>

#include "core/mesh/topology.h"
#include "core/util/serial_blas.h"

namespace kgd {
namespace {

using Clock = std::chrono::steady_clock;
double SecondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

Status CheckMaterial(const Material& m, const std::string& name) {
  std::ostringstream os;
  if (!(m.youngs_modulus_Pa > 0) || !std::isfinite(m.youngs_modulus_Pa))
    os << name << ": youngs_modulus_Pa must be > 0, got " << m.youngs_modulus_Pa;
  else if (!(m.poisson_ratio > -1 && m.poisson_ratio < 0.5))
    os << name << ": poisson_ratio must be in (-1, 0.5), got " << m.poisson_ratio;
  else if (!(m.thickness_m > 0) || !std::isfinite(m.thickness_m))
    os << name << ": thickness_m must be > 0, got " << m.thickness_m;
  else
    return Status::Ok();
  return Status::Error(os.str());
}

}  // namespace

Status ValidateModel(const GarmentModel& m) {
  if (Status s = ValidateMesh(m.rest, m.faces, "garment rest mesh"); !s.ok()) return s;
  if (m.design.size() != static_cast<size_t>(m.faces.rows()))
    return Status::Error("design has " + std::to_string(m.design.size()) + " values for " +
                         std::to_string(m.faces.rows()) + " faces");
  for (size_t f = 0; f < m.design.size(); ++f)
    if (m.design[f] > 1)
      return Status::Error("design value of face " + std::to_string(f) + " is " + std::to_string(m.design[f]) +
                           " (expected 0 = cloth or 1 = reinforced)");
  if (Status s = CheckMaterial(m.cloth, "materials.cloth"); !s.ok()) return s;
  if (Status s = CheckMaterial(m.reinforced, "materials.reinforced"); !s.ok()) return s;
  if (!(m.effects.friction >= 0 && std::isfinite(m.effects.friction)))
    return Status::Error("effects.friction (the friction coefficient) must be >= 0, got " + std::to_string(m.effects.friction));
  if (m.effects.friction > 0 && m.effects.contact == ContactModel::kNone)
    return Status::Error("effects.friction needs contact with the body (effects.contact)");
  if (m.effects.friction > 0 && !(m.friction_slip_m > 0))
    return Status::Error("friction slip distance must be > 0, got " + std::to_string(m.friction_slip_m));
  if (m.effects.contact != ContactModel::kNone) {
    if (!m.body) return Status::Error("effects.contact is on but the scene has no body");
    if (!(m.contact_stiffness_N_per_m > 0))
      return Status::Error("contact.stiffness_N_per_m must be > 0, got " + std::to_string(m.contact_stiffness_N_per_m));
  }
  if (m.effects.attachments) {
    if (Status s = ValidateFaceList(m.attachments.faces, m.faces.rows(), "attachments.faces"); !s.ok()) return s;
    if (m.attachments.anchors.rows() != static_cast<Eigen::Index>(m.attachments.faces.size()))
      return Status::Error("attachments: " + std::to_string(m.attachments.anchors.rows()) + " anchors for " +
                           std::to_string(m.attachments.faces.size()) + " faces");
    if (!(m.attachments.stiffness_N_per_m >= 0))
      return Status::Error("attachments.stiffness_N_per_m must be >= 0");
  }
  if (m.effects.clamps) {
    std::vector<char> used(m.rest.rows(), 0);
    for (size_t c = 0; c < m.clamps.size(); ++c) {
      const Clamp& cl = m.clamps[c];
      const std::string name = "clamps[" + std::to_string(c) + "] (" + cl.name + ")";
      if (cl.vertices.empty()) return Status::Error(name + ": selects no vertex");
      for (int v : cl.vertices) {
        if (v < 0 || v >= m.rest.rows())
          return Status::Error(name + ": vertex " + std::to_string(v) + " out of range [0, " +
                               std::to_string(m.rest.rows()) + ")");
        if (used[v]) return Status::Error(name + ": vertex " + std::to_string(v) + " is already clamped");
        used[v] = 1;
      }
      if (!cl.displacement_m.allFinite()) return Status::Error(name + ": displacement is not finite");
    }
  }
  return Status::Ok();
}

GarmentSystem::GarmentSystem(GarmentModel model, const Positions& initial) : model_(std::move(model)) {
  UseSerialBlas();  // before our first parallel region: OpenBLAS's idle workers would take a core from it
  const int nv = num_vertices(), nf = num_faces();
  rest_area_.resize(nf);
  for (int f = 0; f < nf; ++f) {
    // Half the determinant of the rest edge matrix in the triangle's own frame, as the membrane's
    // rest shape has it (MakeMembraneElement), bit for bit.
    const Eigen::Vector3d x0 = model_.rest.row(model_.faces(f, 0)), x1 = model_.rest.row(model_.faces(f, 1)),
                          x2 = model_.rest.row(model_.faces(f, 2));
    const Eigen::Vector3d e1 = x1 - x0, e2 = x2 - x0;
    const Eigen::Vector3d b0 = e1.normalized();
    const Eigen::Vector3d b1 = (e1.cross(e2)).cross(e1).normalized();
    Eigen::Matrix2d dm;
    dm << e1.norm(), e2.dot(b0), 0.0, e2.dot(b1);
    rest_area_[f] = 0.5 * dm.determinant();
  }
  const Material mats[2] = {model_.cloth, model_.reinforced};
  mean_edge_ = MeanEdgeLength(model_.rest, model_.faces);
  stiffness_scale_ = std::max(mats[0].youngs_modulus_Pa * mats[0].thickness_m, mats[1].youngs_modulus_Pa * mats[1].thickness_m);
  force_scale_ = stiffness_scale_ * mean_edge_;

  // Degrees of freedom left free by the clamps, and the clamp targets.
  free_index_.assign(3 * nv, 0);
  clamp_target_ = initial;
  if (model_.effects.clamps)
    for (const Clamp& c : model_.clamps)
      for (int v : c.vertices)
        for (int k = 0; k < 3; ++k)
          if (c.axes[k]) {
            free_index_[3 * v + k] = -1;
            clamp_target_(v, k) = initial(v, k) + c.displacement_m[k];
          }
  num_free_ = 0;
  for (int& d : free_index_)
    if (d == 0) d = num_free_++;

  if (model_.body) caches_.resize(nv);
  hinges_ = MeshHinges(model_.faces);

  // The terms the effects switch on, each in the group of its stencil.
  const TermContext context{model_, initial, caches_, hinges_};
  const std::vector<TermRegistration>& registry = EnergyTermRegistry();
  std::vector<size_t> registry_index;  // per term: its registry entry
  for (size_t i = 0; i < registry.size(); ++i) {
    const TermRegistration& reg = registry[i];
    std::unique_ptr<EnergyTerm> term = reg.make(context);
    registered_term_.push_back(term ? static_cast<int>(terms_.size()) : -1);
    if (!term) continue;
    term_names_.push_back(reg.name);
    registry_index.push_back(i);
    record_width_.push_back(term->RecordWidth());
    lagged_ = lagged_ || term->lagged();
    terms_.push_back(std::move(term));
  }
  term_seconds_.assign(terms_.size(), 0.0);
  term_elements_.assign(terms_.size(), 0);
  term_sample_stride_ = static_cast<int>(terms_.size()) + 8;
  term_sample_ns_.assign(static_cast<size_t>(omp_get_max_threads()) * term_sample_stride_, 0.0);
  for (Stencil stencil : {Stencil::kFace, Stencil::kHinge, Stencil::kVertex}) {
    Group g;
    g.stencil = stencil;
    g.k = StencilSize(stencil);
    // In the order of the term list's sum places.
    for (size_t t = 0; t < terms_.size(); ++t)
      if (terms_[t]->stencil() == stencil) g.terms.push_back(static_cast<int>(t));
    std::sort(g.terms.begin(), g.terms.end(),
              [&](int a, int b) { return registry[registry_index[a]].sum_place < registry[registry_index[b]].sum_place; });
    // Faces always: their couplings make the Hessian's pattern whatever the terms.
    if (g.terms.empty() && stencil != Stencil::kFace) continue;
    std::vector<std::vector<int>> faces_of;  // per element: the faces whose design it reads
    if (stencil == Stencil::kFace) {
      g.count = nf;
      for (int f = 0; f < nf; ++f) {
        for (int a = 0; a < 3; ++a) g.vertices.push_back(model_.faces(f, a));
        faces_of.push_back({f});
      }
    } else if (stencil == Stencil::kHinge) {
      g.count = static_cast<int>(hinges_.vertices.size());
      for (int h = 0; h < g.count; ++h) {
        for (int a = 0; a < 4; ++a) g.vertices.push_back(hinges_.vertices[h][a]);
        faces_of.push_back({hinges_.faces[h][0], hinges_.faces[h][1]});
      }
    } else {
      g.count = nv;
      for (int v = 0; v < nv; ++v) g.vertices.push_back(v);
      faces_of.resize(nv);
    }
    // Greedy colouring so that no two elements of one colour share a vertex.
    std::vector<std::vector<int>> vertex_colors(nv);
    g.color_of.resize(g.count);
    for (int e = 0; e < g.count; ++e) {
      const int* v = &g.vertices[g.k * e];
      int c = 0;
      for (;; ++c) {
        bool clash = false;
        for (int a = 0; a < g.k && !clash; ++a) {
          const auto& vc = vertex_colors[v[a]];
          clash = std::find(vc.begin(), vc.end(), c) != vc.end();
        }
        if (!clash) break;
      }
      g.color_of[e] = c;
      for (int a = 0; a < g.k; ++a) vertex_colors[v[a]].push_back(c);
      if (c >= static_cast<int>(g.colors.size())) g.colors.resize(c + 1);
      g.colors[c].push_back(e);
    }
    // The elements around each vertex and on each face, compressed.
    auto compress = [](int rows, const std::vector<std::pair<int, int>>& pairs, std::vector<int>* begin, std::vector<int>* items) {
      begin->assign(rows + 1, 0);
      for (const auto& [row, item] : pairs) ++(*begin)[row + 1];
      for (int r = 0; r < rows; ++r) (*begin)[r + 1] += (*begin)[r];
      items->resize(pairs.size());
      std::vector<int> next(begin->begin(), begin->end() - 1);
      for (const auto& [row, item] : pairs) (*items)[next[row]++] = item;
    };
    std::vector<std::pair<int, int>> by_vertex, by_face;
    for (int e = 0; e < g.count; ++e) {
      for (int a = 0; a < g.k; ++a) by_vertex.push_back({g.vertices[g.k * e + a], e});
      for (int f : faces_of[e]) by_face.push_back({f, e});
    }
    compress(nv, by_vertex, &g.around_vertex_begin, &g.around_vertex);
    compress(nf, by_face, &g.around_face_begin, &g.around_face);
    g.mark.assign(g.count, 0);
    groups_.push_back(std::move(g));
  }

  // Sparsity: every element couples its vertices; vertex blocks cover the vertex terms.
  std::vector<Eigen::Triplet<double>> trips;
  auto add = [&](int di, int dj) {
    const int p = free_index_[di], q = free_index_[dj];
    if (p >= 0 && q >= 0 && p <= q) trips.emplace_back(p, q, 0.0);
  };
  for (const Group& g : groups_)
    for (int e = 0; e < g.count; ++e)
      for (int a = 0; a < g.k; ++a)
        for (int b = 0; b < g.k; ++b)
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) add(3 * g.vertices[g.k * e + a] + i, 3 * g.vertices[g.k * e + b] + j);
  for (int v = 0; v < nv; ++v)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) add(3 * v + i, 3 * v + j);
  pattern_.resize(num_free_, num_free_);
  pattern_.setFromTriplets(trips.begin(), trips.end());
  pattern_.makeCompressed();
  pattern_.coeffs().setZero();

  auto value_index = [&](int di, int dj) -> int {
    int p = free_index_[di], q = free_index_[dj];
    if (p < 0 || q < 0) return -1;
    if (p > q) std::swap(p, q);
    const int* begin = pattern_.innerIndexPtr() + pattern_.outerIndexPtr()[q];
    const int* end = pattern_.innerIndexPtr() + pattern_.outerIndexPtr()[q + 1];
    const int* it = std::lower_bound(begin, end, p);
    return static_cast<int>(it - pattern_.innerIndexPtr());
  };
  // Both (row, col) and (col, row) of a local matrix map to the same upper entry; only one of each
  // mirrored pair (and the diagonal) is kept so that every coupling is added exactly once.
  for (Group& g : groups_) {
    const int n = 3 * g.k;
    g.scatter.clear();
    g.scatter_begin.assign(g.count + 1, 0);
    for (int e = 0; e < g.count; ++e) {
      const int* v = &g.vertices[g.k * e];
      for (int r = 0; r < n; ++r)
        for (int c = 0; c < n; ++c) {
          const int dr = 3 * v[r / 3] + r % 3, dc = 3 * v[c / 3] + c % 3;
          const int p = free_index_[dr], q = free_index_[dc];
          if (p < 0 || q < 0 || p > q) continue;
          g.scatter.push_back({n * c + r, value_index(dr, dc)});  // column-major local index
        }
      g.scatter_begin[e + 1] = static_cast<int>(g.scatter.size());
    }
  }
  vertex_mark_.assign(nv, 0);
  entry_mark_.assign(pattern_.nonZeros(), 0);
}

int GarmentSystem::term_index(std::string_view name) const {
  for (size_t t = 0; t < term_names_.size(); ++t)
    if (name == term_names_[t]) return static_cast<int>(t);
  return -1;
}

double EnergyBreakdown::operator[](std::string_view name) const {
  for (const Term& t : terms)
    if (name == t.name) return t.energy_J;
  return 0;
}

double EnergyBreakdown::total_J() const {
  double total = 0;
  for (const Term& t : terms) total += t.energy_J;
  return total;
}

void GarmentSystem::SetDesign(const std::vector<uint8_t>& design) {
  model_.design = design;
}

void GarmentSystem::ApplyClamps(Positions* x) const {
  for (int d = 0; d < 3 * num_vertices(); ++d)
    if (free_index_[d] < 0) (*x)(d / 3, d % 3) = clamp_target_(d / 3, d % 3);
}

void GarmentSystem::ApplyClampsSmoothly(Positions* x) const {
  const int nv = num_vertices();
  // Unit-weight graph Laplacian over mesh edges, built only when some clamp actually has to move:
  // warm re-solves skip all of this.
  std::vector<std::vector<int>> nbrs;
  for (int k = 0; k < 3; ++k) {
    bool moves = false;
    for (int v = 0; v < nv && !moves; ++v)
      if (free_index_[3 * v + k] < 0 && clamp_target_(v, k) != (*x)(v, k)) moves = true;
    if (!moves) continue;
    if (nbrs.empty()) nbrs = VertexNeighbors(model_.faces, nv);
    std::vector<int> unknown(nv, -1);
    int n = 0;
    for (int v = 0; v < nv; ++v)
      if (free_index_[3 * v + k] >= 0) unknown[v] = n++;
    std::vector<Eigen::Triplet<double>> trips;
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
    for (int v = 0; v < nv; ++v) {
      if (unknown[v] < 0) continue;
      // A tiny diagonal keeps pieces that touch no clamp solvable: their displacement decays to zero.
      trips.emplace_back(unknown[v], unknown[v], nbrs[v].size() * (1.0 + 1e-9));
      for (int w : nbrs[v]) {
        if (unknown[w] >= 0) trips.emplace_back(unknown[v], unknown[w], -1.0);
        else rhs[unknown[v]] += clamp_target_(w, k) - (*x)(w, k);
      }
    }
    Eigen::SparseMatrix<double> L(n, n);
    L.setFromTriplets(trips.begin(), trips.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(L);
    if (ldlt.info() != Eigen::Success) continue;  // keep the plain clamp application
    const Eigen::VectorXd u = ldlt.solve(rhs);
    if (!u.allFinite()) continue;
    for (int v = 0; v < nv; ++v)
      if (unknown[v] >= 0) (*x)(v, k) += u[unknown[v]];
  }
  ApplyClamps(x);
}

double GarmentSystem::MaxSafeStep(const Positions& x, const Positions& d) const {
  double step = 1.0;
  for (const auto& term : terms_) step = std::min(step, term->MaxSafeStep(x, d));
  return step;
}

// One element's terms summed: each term's energy (in the group's term order), and the summed gradient
// and Hessian (3k and 3k x 3k, column-major) when asked for.
struct GarmentSystem::ElementSum {
  static constexpr int kMaxTerms = 8;
  std::array<double, kMaxTerms> energy_J{};
  bool scatter = false;  // false when a term is not finite: the element adds nothing to the derivatives
  std::array<double, 12> g;
  std::array<double, 144> H;
};

void GarmentSystem::EvaluateElement(const Group& group, int e, const Positions& x, bool want_grad, bool want_hess, ElementSum* out,
                                    double* sample_ns) {
  const int n = 3 * group.k, nn = n * n;
  const int* v = &group.vertices[group.k * e];
  out->scatter = false;
  if (want_grad) std::fill_n(out->g.begin(), n, 0.0);
  if (want_hess) std::fill_n(out->H.begin(), nn, 0.0);
  std::array<double, 12> ge;
  std::array<double, 144> He;
  for (size_t i = 0; i < group.terms.size(); ++i) out->energy_J[i] = 0;
  for (size_t i = 0; i < group.terms.size(); ++i) {
    const auto t0 = sample_ns ? Clock::now() : Clock::time_point();
    const ElementEnergy r = terms_[group.terms[i]]->Evaluate(e, v, x, want_grad ? ge.data() : nullptr, want_hess ? He.data() : nullptr);
    if (sample_ns) sample_ns[group.terms[i]] += std::chrono::duration<double, std::nano>(Clock::now() - t0).count();
    out->energy_J[i] = r.energy_J;
    if (!std::isfinite(r.energy_J)) return;
    if (!r.derivatives) continue;
    if (want_grad)
      for (int j = 0; j < n; ++j) out->g[j] += ge[j];
    if (want_hess)
      for (int j = 0; j < nn; ++j) out->H[j] += He[j];
  }
  out->scatter = true;
}

double* GarmentSystem::TermSample(size_t i) {
  if (i % kTermTimeSample != 0) return nullptr;
  const size_t thread = static_cast<size_t>(omp_get_thread_num());
  if ((thread + 1) * term_sample_stride_ > term_sample_ns_.size()) return nullptr;  // more threads than at construction
  return &term_sample_ns_[thread * term_sample_stride_];
}

void GarmentSystem::AddGroupTime(const Group& group, double seconds, long long elements) {
  const size_t threads = term_sample_ns_.size() / term_sample_stride_;
  double sampled = 0;
  std::vector<double> per_term(group.terms.size(), 0.0);
  for (size_t i = 0; i < group.terms.size(); ++i) {
    for (size_t th = 0; th < threads; ++th) {
      double& ns = term_sample_ns_[th * term_sample_stride_ + group.terms[i]];
      per_term[i] += ns;
      ns = 0;
    }
    sampled += per_term[i];
  }
  for (size_t i = 0; i < group.terms.size(); ++i) {
    // No sample (no element evaluated): an even split of what little time the loop took.
    const double share = sampled > 0 ? per_term[i] / sampled : 1.0 / group.terms.size();
    term_seconds_[group.terms[i]] += share * seconds;
    term_elements_[group.terms[i]] += elements;
  }
}

std::vector<GarmentSystem::TermTime> GarmentSystem::term_times() const {
  std::vector<TermTime> out;
  for (size_t t = 0; t < terms_.size(); ++t) out.push_back({term_names_[t], term_seconds_[t], term_elements_[t]});
  return out;
}

void GarmentSystem::StoreElement(const Group& group, int e, const ElementSum& sum, EvaluationRecord* r) const {
  for (size_t i = 0; i < group.terms.size(); ++i) {
    const int t = group.terms[i];
    r->energy_J[t][e] = sum.energy_J[i];
    const int w = record_width_[t];
    if (w > 0 && !r->recorded[t].empty()) terms_[t]->RecordElement(e, &r->recorded[t][static_cast<size_t>(w) * e]);
  }
}

void GarmentSystem::Scatter(const Group& group, int e, const ElementSum& sum, Eigen::VectorXd* gradient, double* values,
                            const std::vector<int>* vertex_mark, const std::vector<int>* entry_mark, int changed) const {
  if (!sum.scatter) return;
  const int* v = &group.vertices[group.k * e];
  if (gradient)
    for (int a = 0; a < group.k; ++a)
      if (!vertex_mark || (*vertex_mark)[v[a]] == changed)
        for (int i = 0; i < 3; ++i) (*gradient)[3 * v[a] + i] += sum.g[3 * a + i];
  if (values)
    for (int s = group.scatter_begin[e]; s < group.scatter_begin[e + 1]; ++s) {
      const ScatterEntry& entry = group.scatter[s];
      if (!entry_mark || (*entry_mark)[entry.value] == changed) values[entry.value] += sum.H[entry.local];
    }
}

void GarmentSystem::PrepareRecord(EvaluationRecord* r, bool want_grad) const {
  r->energy_J.resize(terms_.size());
  r->recorded.resize(terms_.size());
  for (const Group& g : groups_)
    for (int t : g.terms) {
      r->energy_J[t].assign(g.count, 0.0);
      r->recorded[t].assign(want_grad ? static_cast<size_t>(record_width_[t]) * g.count : 0, 0.0);
    }
}

double GarmentSystem::SumEnergies(const EvaluationRecord& r, EnergyBreakdown* breakdown) const {
  // Serial sums in a fixed order keep results bit-identical whatever the thread count, and whether the
  // record was filled by Evaluate or EvaluateFrom.
  std::vector<double> term_J(terms_.size(), 0.0);
  for (size_t t = 0; t < terms_.size(); ++t)
    for (double e : r.energy_J[t]) term_J[t] += e;
  const std::vector<TermRegistration>& registry = EnergyTermRegistry();
  EnergyBreakdown b;
  for (size_t i = 0; i < registry.size(); ++i) {
    const int t = registered_term_[i];
    b.terms.push_back({registry[i].name, t >= 0 ? term_J[t] : 0.0});
  }
  const double total = b.total_J();
  if (breakdown) *breakdown = std::move(b);
  return std::isnan(total) ? std::numeric_limits<double>::infinity() : total;
}

std::string GarmentSystem::DescribeNonFiniteEnergy(const Positions& x) {
  for (Eigen::Index v = 0; v < x.rows(); ++v)
    if (!x.row(v).allFinite()) return "vertex " + std::to_string(v) + " has a non-finite coordinate";
  EvaluationRecord r;
  if (std::isfinite(Evaluate(x, nullptr, nullptr, nullptr, &r))) return "";
  std::string out;
  for (const Group& g : groups_)
    for (int t : g.terms) {
      const std::vector<double>& energy_J = r.energy_J[t];
      for (size_t i = 0; i < energy_J.size(); ++i) {
        if (std::isfinite(energy_J[i])) continue;
        std::string name = term_names_[t];
        std::replace(name.begin(), name.end(), '_', ' ');
        const char* element = g.stencil == Stencil::kFace ? "face" : g.stencil == Stencil::kHinge ? "edge" : "vertex";
        std::ostringstream m;
        m << (out.empty() ? "" : "; ") << name << " energy not finite at " << element << " " << i << " (" << energy_J[i] << " J"
          << terms_[t]->NonFiniteMeaning() << ")";
        out += m.str();
        break;
      }
    }
  return out.empty() ? "the terms are finite but their sum is not" : out;
}

double GarmentSystem::Evaluate(const Positions& x, Eigen::VectorXd* gradient, Eigen::SparseMatrix<double>* hessian,
                               EnergyBreakdown* breakdown, EvaluationRecord* record) {
  const int nv = num_vertices();
  const bool want_grad = gradient != nullptr, want_hess = hessian != nullptr;
  if (want_grad) gradient->setZero(3 * nv);
  double* values = want_hess ? hessian->valuePtr() : nullptr;
  if (want_hess) std::fill(values, values + hessian->nonZeros(), 0.0);
  EvaluationRecord& r = record ? *record : scratch_;
  PrepareRecord(&r, want_grad);
  // Group by group (faces, hinges, vertices), one colour at a time: elements of a colour share no vertex.
  for (const Group& g : groups_) {
    if (g.terms.empty()) continue;
    const auto t0 = Clock::now();
    for (const std::vector<int>& color : g.colors) {
#pragma omp parallel for schedule(static)
      for (size_t i = 0; i < color.size(); ++i) {
        const int e = color[i];
        ElementSum sum;
        EvaluateElement(g, e, x, want_grad, want_hess, &sum, TermSample(i));
        StoreElement(g, e, sum, &r);
        Scatter(g, e, sum, gradient, values, nullptr, nullptr, 0);
      }
    }
    AddGroupTime(g, SecondsSince(t0), g.count);
  }
  if (record) {
    r.x = x;
    r.design = model_.design;
    r.lag_version = lag_version_;
  }
  return SumEnergies(r, breakdown);
}

double GarmentSystem::EvaluateFrom(const EvaluationRecord& base, const Eigen::VectorXd* base_gradient,
                                   const Eigen::SparseMatrix<double>* base_hessian, const Positions& x,
                                   Eigen::VectorXd* gradient, Eigen::SparseMatrix<double>* hessian,
                                   EnergyBreakdown* breakdown, EvaluationRecord* record) {
  const int nv = num_vertices(), nf = num_faces();
  const bool want_grad = gradient != nullptr, want_hess = hessian != nullptr;
  bool usable = base.lag_version == lag_version_ && base.x.rows() == nv && base.energy_J.size() == terms_.size() &&
                base.recorded.size() == terms_.size() && base.design.size() == model_.design.size() &&
                (!want_grad || (base_gradient && base_gradient->size() == 3 * nv)) &&
                (!want_hess || (want_grad && base_hessian && base_hessian->nonZeros() == pattern_.nonZeros() &&
                                hessian->nonZeros() == pattern_.nonZeros()));
  for (const Group& g : groups_)
    for (int t : g.terms)
      usable = usable && static_cast<int>(base.energy_J[t].size()) == g.count &&
               (!want_grad || base.recorded[t].size() == static_cast<size_t>(record_width_[t]) * g.count);
  std::vector<int> moved, redesigned;
  if (usable) {
    for (int v = 0; v < nv; ++v)
      if (x(v, 0) != base.x(v, 0) || x(v, 1) != base.x(v, 1) || x(v, 2) != base.x(v, 2)) moved.push_back(v);
    for (int f = 0; f < nf; ++f)
      if (base.design[f] != model_.design[f]) redesigned.push_back(f);
  }
  if (!usable || 3 * (moved.size() + 3 * redesigned.size()) > static_cast<size_t>(nv))
    return Evaluate(x, gradient, hessian, breakdown, record);

  if (mark_ > std::numeric_limits<int>::max() - 4) {
    for (Group& g : groups_) std::fill(g.mark.begin(), g.mark.end(), 0);
    std::fill(vertex_mark_.begin(), vertex_mark_.end(), 0);
    std::fill(entry_mark_.begin(), entry_mark_.end(), 0);
    mark_ = 0;
  }
  mark_ += 2;
  const int changed = mark_, near = mark_ + 1;  // element marks: terms changed; only recomputed for the sums
  EvaluationRecord& r = record ? *record : scratch_;
  if (&r != &base) {
    r.energy_J = base.energy_J;
    if (want_grad) r.recorded = base.recorded;
  }
  if (!want_grad) {
    r.recorded.resize(terms_.size());
    for (std::vector<double>& d : r.recorded) d.clear();
  }
  // The elements whose terms change: those on a face of another design, and those around a moved vertex.
  std::vector<std::vector<int>> changed_elements(groups_.size());
  for (size_t gi = 0; gi < groups_.size(); ++gi) {
    Group& g = groups_[gi];
    auto add = [&](int e) {
      if (g.mark[e] != changed) {
        g.mark[e] = changed;
        changed_elements[gi].push_back(e);
      }
    };
    for (int f : redesigned)
      for (int k = g.around_face_begin[f]; k < g.around_face_begin[f + 1]; ++k) add(g.around_face[k]);
    for (int v : moved)
      for (int k = g.around_vertex_begin[v]; k < g.around_vertex_begin[v + 1]; ++k) add(g.around_vertex[k]);
  }

  if (!want_grad && !want_hess) {
    for (size_t gi = 0; gi < groups_.size(); ++gi) {
      const Group& g = groups_[gi];
      if (g.terms.empty()) continue;
      const std::vector<int>& elements = changed_elements[gi];
      const auto t0 = Clock::now();
#pragma omp parallel for schedule(static)
      for (size_t i = 0; i < elements.size(); ++i) {
        ElementSum sum;
        EvaluateElement(g, elements[i], x, false, false, &sum, TermSample(i));
        StoreElement(g, elements[i], sum, &r);
      }
      AddGroupTime(g, SecondsSince(t0), static_cast<long long>(elements.size()));
    }
  } else {
    // The vertices whose gradient and Hessian entries change: those of changed elements, and moved ones.
    // Each of their entries is summed again from all its terms, in Evaluate's order (group by group,
    // colour by colour), from zero.
    std::vector<int> vertices;
    auto add_vertex = [&](int v) {
      if (vertex_mark_[v] != changed) {
        vertex_mark_[v] = changed;
        vertices.push_back(v);
      }
    };
    for (int v : moved) add_vertex(v);
    for (size_t gi = 0; gi < groups_.size(); ++gi)
      for (int e : changed_elements[gi])
        for (int a = 0; a < groups_[gi].k; ++a) add_vertex(groups_[gi].vertices[groups_[gi].k * e + a]);
    double* values = nullptr;
    if (want_hess) {
      values = hessian->valuePtr();
      if (hessian != base_hessian) std::copy(base_hessian->valuePtr(), base_hessian->valuePtr() + pattern_.nonZeros(), values);
      for (size_t gi = 0; gi < groups_.size(); ++gi) {
        const Group& g = groups_[gi];
        for (int e : changed_elements[gi])
          for (int s = g.scatter_begin[e]; s < g.scatter_begin[e + 1]; ++s) {
            entry_mark_[g.scatter[s].value] = changed;
            values[g.scatter[s].value] = 0.0;
          }
      }
    }
    if (gradient != base_gradient) *gradient = *base_gradient;
    for (int v : vertices) gradient->segment<3>(3 * v).setZero();
    for (size_t gi = 0; gi < groups_.size(); ++gi) {
      Group& g = groups_[gi];
      if (g.terms.empty()) continue;
      // Every element that adds to those entries: the elements around their vertices, by colour.
      std::vector<std::vector<int>> by_color(g.colors.size());
      for (int v : vertices)
        for (int k = g.around_vertex_begin[v]; k < g.around_vertex_begin[v + 1]; ++k) {
          const int e = g.around_vertex[k];
          if (g.mark[e] == changed) continue;
          if (g.mark[e] != near) {
            g.mark[e] = near;
            by_color[g.color_of[e]].push_back(e);
          }
        }
      for (int e : changed_elements[gi]) by_color[g.color_of[e]].push_back(e);
      // Vertex terms of every vertex evaluated are stored (unmoved ones give the same values).
      const bool store_all = g.stencil == Stencil::kVertex;
      const auto t0 = Clock::now();
      long long evaluated = 0;
      for (const std::vector<int>& color : by_color) {
        evaluated += static_cast<long long>(color.size());
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < color.size(); ++i) {
          const int e = color[i];
          ElementSum sum;
          EvaluateElement(g, e, x, true, want_hess, &sum, TermSample(i));
          if (store_all || g.mark[e] == changed) StoreElement(g, e, sum, &r);
          Scatter(g, e, sum, gradient, values, &vertex_mark_, &entry_mark_, changed);
        }
      }
      AddGroupTime(g, SecondsSince(t0), evaluated);
    }
  }
  if (record) {
    r.x = x;
    r.design = model_.design;
    r.lag_version = lag_version_;
  }
  return SumEnergies(r, breakdown);
}

void GarmentSystem::FaceDensities(const Positions& x, Eigen::VectorXd* density, std::vector<MembraneRegime>* regime) const {
  Eigen::VectorXd d;
  for (const auto& term : terms_)
    if (term->FaceDensities(x, density ? density : &d, regime)) return;
  if (density) density->setZero(num_faces());
  if (regime) regime->clear();
}

Eigen::VectorXd GarmentSystem::VertexPhi(const Positions& x, Positions* grad) {
  Eigen::VectorXd phi = Eigen::VectorXd::Constant(num_vertices(), std::numeric_limits<double>::quiet_NaN());
  if (grad) grad->setZero(num_vertices(), 3);
  if (!model_.body) return phi;
  if (caches_.empty()) caches_.resize(num_vertices());
  const auto t0 = Clock::now();
#pragma omp parallel for schedule(static)
  for (int v = 0; v < num_vertices(); ++v) {
    const FieldSample s = model_.body->Evaluate(x.row(v).transpose(), &caches_[v], grad != nullptr, false);
    if (s.supported) phi[v] = s.phi_m;
    if (s.supported && grad) grad->row(v) = s.grad.transpose();
  }
  body_field_query_s_ += SecondsSince(t0);
  return phi;
}

int GarmentSystem::ProjectTrial(const EvaluationRecord& from, Positions* trial) {
  if (from.recorded.size() != terms_.size()) return 0;
  int moved = 0;
  const auto t0 = Clock::now();
  for (size_t t = 0; t < terms_.size(); ++t) moved += terms_[t]->ProjectTrial(from.recorded[t], from.x, free_index_, trial);
  body_field_query_s_ += SecondsSince(t0);
  return moved;
}

Eigen::Vector3d GarmentSystem::ClampReaction(int clamp, const Eigen::VectorXd& gradient) const {
  Eigen::Vector3d r = Eigen::Vector3d::Zero();
  for (int v : model_.clamps[clamp].vertices) r += gradient.segment<3>(3 * v);
  return r;
}

void GarmentSystem::Lag(const Positions& x) {
  if (!lagged_) return;
  for (const auto& term : terms_)
    if (term->lagged()) term->Lag(x);
  ++lag_version_;
}

}  // namespace kgd
