#include "core/sim/garment_system.h"

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "core/mesh/topology.h"
#include "core/util/serial_blas.h"

namespace kgd {
namespace {

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
  elements_.resize(nf);
  for (int f = 0; f < nf; ++f)
    elements_[f] = MakeMembraneElement(model_.rest.row(model_.faces(f, 0)), model_.rest.row(model_.faces(f, 1)),
                                       model_.rest.row(model_.faces(f, 2)));
  if (model_.effects.friction > 0 && model_.friction_anchor.rows() != nv) model_.friction_anchor = initial;
  // Folds are measured against the garment on the body, or the orientation it starts with.
  if (model_.effects.fold_barrier) {
    const Positions& ref = model_.fold_reference.rows() ? model_.fold_reference : initial;
    fold_reference_.resize(nf);
    for (int f = 0; f < nf; ++f) {
      const Eigen::Vector3d a = ref.row(model_.faces(f, 0)), b = ref.row(model_.faces(f, 1)), c = ref.row(model_.faces(f, 2));
      fold_reference_[f] = (b - a).cross(c - a).normalized();
    }
  }
  const Material mats[2] = {model_.cloth, model_.reinforced};
  for (int k = 0; k < 2; ++k) {
    lame_[k] = LameParameters(mats[k], model_.lame);
    thickness_[k] = mats[k].thickness_m;
  }
  mean_edge_ = MeanEdgeLength(model_.rest, model_.faces);
  stiffness_scale_ = std::max(mats[0].youngs_modulus_Pa * mats[0].thickness_m, mats[1].youngs_modulus_Pa * mats[1].thickness_m);
  force_scale_ = stiffness_scale_ * mean_edge_;

  attach_index_.assign(nf, -1);
  if (model_.effects.attachments)
    for (size_t i = 0; i < model_.attachments.faces.size(); ++i) attach_index_[model_.attachments.faces[i]] = i;

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

  // Greedy colouring of faces so that no two faces of one colour share a vertex.
  {
    std::vector<std::vector<int>> vertex_colors(nv);
    std::vector<int> color_of(nf);
    for (int f = 0; f < nf; ++f) {
      int c = 0;
      for (;; ++c) {
        bool clash = false;
        for (int k = 0; k < 3 && !clash; ++k) {
          const auto& vc = vertex_colors[model_.faces(f, k)];
          clash = std::find(vc.begin(), vc.end(), c) != vc.end();
        }
        if (!clash) break;
      }
      color_of[f] = c;
      for (int k = 0; k < 3; ++k) vertex_colors[model_.faces(f, k)].push_back(c);
      if (c >= static_cast<int>(colors_.size())) colors_.resize(c + 1);
      colors_[c].push_back(f);
    }
    face_color_ = std::move(color_of);
  }
  vertex_faces_ = VertexFaces(model_.faces, nv);

  // Sparsity: every face couples its three vertices; vertex blocks cover contact.
  std::vector<Eigen::Triplet<double>> trips;
  trips.reserve(static_cast<size_t>(nf) * 45 + static_cast<size_t>(nv) * 6);
  auto add = [&](int di, int dj) {
    const int p = free_index_[di], q = free_index_[dj];
    if (p >= 0 && q >= 0 && p <= q) trips.emplace_back(p, q, 0.0);
  };
  for (int f = 0; f < nf; ++f)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) add(3 * model_.faces(f, a) + i, 3 * model_.faces(f, b) + j);
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
  face_scatter_.clear();
  face_scatter_begin_.assign(nf + 1, 0);
  for (int f = 0; f < nf; ++f) {
    for (int r = 0; r < 9; ++r)
      for (int c = 0; c < 9; ++c) {
        const int dr = 3 * model_.faces(f, r / 3) + r % 3, dc = 3 * model_.faces(f, c / 3) + c % 3;
        const int p = free_index_[dr], q = free_index_[dc];
        if (p < 0 || q < 0 || p > q) continue;
        face_scatter_.push_back({9 * c + r, value_index(dr, dc)});  // column-major local index
      }
    face_scatter_begin_[f + 1] = static_cast<int>(face_scatter_.size());
  }
  vertex_scatter_.clear();
  vertex_scatter_begin_.assign(nv + 1, 0);
  for (int v = 0; v < nv; ++v) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const int p = free_index_[3 * v + i], q = free_index_[3 * v + j];
        if (p < 0 || q < 0 || p > q) continue;
        vertex_scatter_.push_back({3 * j + i, value_index(3 * v + i, 3 * v + j)});
      }
    vertex_scatter_begin_[v + 1] = static_cast<int>(vertex_scatter_.size());
  }

  if (model_.effects.contact != ContactModel::kNone) caches_.resize(nv);
  face_mark_.assign(nf, 0);
  vertex_mark_.assign(nv, 0);
  entry_mark_.assign(pattern_.nonZeros(), 0);
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

double GarmentSystem::MaxFoldSafeStep(const Positions& x, const Positions& d) const {
  if (!model_.effects.fold_barrier) return 1.0;
  double step = 1.0;
#pragma omp parallel for schedule(static) reduction(min : step)
  for (int f = 0; f < num_faces(); ++f) {
    const int a = model_.faces(f, 0), b = model_.faces(f, 1), c = model_.faces(f, 2);
    const Eigen::Vector3d e1 = x.row(b) - x.row(a), e2 = x.row(c) - x.row(a);
    const Eigen::Vector3d d1 = d.row(b) - d.row(a), d2 = d.row(c) - d.row(a);
    const Eigen::Vector3d& n = fold_reference_[f];
    // Projected area along the step: q(t) = q0 + q1 t + q2 t^2 (unnormalized); first root in (0, 1].
    const double q0 = e1.cross(e2).dot(n), q1 = (d1.cross(e2) + e1.cross(d2)).dot(n), q2 = d1.cross(d2).dot(n);
    if (q0 <= 0) continue;
    double root = 2.0;
    if (std::abs(q2) < 1e-300) {
      if (q1 < 0) root = -q0 / q1;
    } else {
      const double disc = q1 * q1 - 4 * q2 * q0;
      if (disc >= 0) {
        const double sq = std::sqrt(disc);
        // Numerically stable roots of q2 t^2 + q1 t + q0.
        const double t1 = (-q1 - std::copysign(sq, q1)) / (2 * q2);
        const double t2 = t1 != 0 ? q0 / (q2 * t1) : 2.0;
        for (double t : {t1, t2})
          if (t > 0 && t < root) root = t;
      }
    }
    if (root <= 1.0) step = std::min(step, 0.8 * root);
  }
  return step;
}

struct GarmentSystem::FaceTerms {
  double membrane_J = 0, fold_barrier_J = 0, attachment_J = 0;
  bool scatter = false;  // false when a term is not finite: the face adds nothing to the derivatives
  Vector9d g;
  Matrix9d H;

  void StoreIn(int f, EvaluationRecord* r) const {
    r->membrane_J[f] = membrane_J;
    if (!r->fold_barrier_J.empty()) r->fold_barrier_J[f] = fold_barrier_J;
    if (!r->attachment_J.empty()) r->attachment_J[f] = attachment_J;
  }
};

struct GarmentSystem::VertexTerms {
  double contact_J = 0, friction_J = 0;
  double phi = 0;  // NaN where the field has no support
  Eigen::Vector3d phi_grad;
  Eigen::Vector3d g;
  Eigen::Matrix3d H;

  void StoreIn(int v, EvaluationRecord* r) const {
    r->contact_J[v] = contact_J;
    if (!r->friction_J.empty()) r->friction_J[v] = friction_J;
    if (r->phi.size() > 0) {
      r->phi[v] = phi;
      r->phi_grad.row(v) = phi_grad.transpose();
    }
  }
};

void GarmentSystem::EvaluateFace(int f, const Positions& x, bool want_grad, bool want_hess, FaceTerms* t) const {
  const Effects& fx = model_.effects;
  const Eigen::Vector3d x0 = x.row(model_.faces(f, 0)), x1 = x.row(model_.faces(f, 1)), x2 = x.row(model_.faces(f, 2));
  t->membrane_J = t->fold_barrier_J = t->attachment_J = 0;
  t->scatter = false;
  if (want_grad) t->g.setZero();
  if (want_hess) t->H.setZero();
  const int m = model_.design[f];
  if (fx.membrane) {
    Vector9d ge;
    Matrix9d He;
    const ElementEvaluation ev = EvaluateMembraneElement(elements_[f], x0, x1, x2, lame_[m], thickness_[m], fx.relaxation,
                                                         want_grad ? &ge : nullptr, want_hess ? &He : nullptr, true);
    t->membrane_J = ev.energy_J;
    if (!std::isfinite(ev.energy_J)) return;
    if (want_grad) t->g += ge;
    if (want_hess) t->H += He;
  }
  if (fx.fold_barrier) {
    Vector9d gb;
    Matrix9d Hb;
    const double eb = EvaluateFoldBarrier(x0, x1, x2, fold_reference_[f], elements_[f].rest_area_m2,
                                          lame_[m].mu_Pa * thickness_[m] * elements_[f].rest_area_m2,
                                          want_grad ? &gb : nullptr, want_hess ? &Hb : nullptr, true);
    t->fold_barrier_J = eb;
    if (!std::isfinite(eb)) return;
    if (eb > 0) {
      if (want_grad) t->g += gb;
      if (want_hess) t->H += Hb;
    }
  }
  if (fx.attachments && attach_index_[f] >= 0) {
    Vector9d ga;
    t->attachment_J = EvaluateAttachmentFace(model_.attachments, attach_index_[f], x0, x1, x2, want_grad ? &ga : nullptr);
    if (want_grad) t->g += ga;
    if (want_hess) {
      const double c = 2.0 * AttachmentFaceStiffness(model_.attachments) / 9.0;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) t->H.block<3, 3>(3 * a, 3 * b).diagonal().array() += c;
    }
  }
  t->scatter = true;
}

void GarmentSystem::EvaluateVertex(int v, const Positions& x, bool want_grad, bool want_hess, VertexTerms* t) {
  const Effects& fx = model_.effects;
  const ContactEvaluation ce = EvaluateContactVertex(*model_.body, x.row(v).transpose(), &caches_[v], fx.contact,
                                                     model_.contact_stiffness_N_per_m, want_grad ? &t->g : nullptr,
                                                     want_hess ? &t->H : nullptr, true);
  t->contact_J = ce.energy_J;
  t->phi = ce.supported ? ce.phi_m : std::numeric_limits<double>::quiet_NaN();
  t->phi_grad = ce.phi_grad;
  t->friction_J = 0;
  if (!friction_.empty() && friction_[v].mu_lambda_N > 0) {
    Eigen::Vector3d gf;
    Eigen::Matrix3d Hf;
    t->friction_J = EvaluateFriction(friction_[v], x.row(v).transpose(), model_.friction_slip_m, want_grad ? &gf : nullptr,
                                     want_hess ? &Hf : nullptr);
    if (want_grad) t->g += gf;
    if (want_hess) t->H += Hf;
  }
}

double GarmentSystem::SumEnergies(const EvaluationRecord& r, EnergyBreakdown* breakdown) const {
  // Serial sums in a fixed order keep results bit-identical whatever the thread count, and whether the
  // record was filled by Evaluate or EvaluateFrom.
  EnergyBreakdown e;
  for (double fe : r.membrane_J) e.membrane_J += fe;
  for (double ae : r.attachment_J) e.attachment_J += ae;
  for (double be : r.fold_barrier_J) e.fold_barrier_J += be;
  for (double fe : r.friction_J) e.friction_J += fe;
  for (double ve : r.contact_J) e.contact_J += ve;
  if (breakdown) *breakdown = e;
  const double total = e.total_J();
  return std::isnan(total) ? std::numeric_limits<double>::infinity() : total;
}

std::string GarmentSystem::DescribeNonFiniteEnergy(const Positions& x) {
  for (Eigen::Index v = 0; v < x.rows(); ++v)
    if (!x.row(v).allFinite()) return "vertex " + std::to_string(v) + " has a non-finite coordinate";
  EvaluationRecord r;
  if (std::isfinite(Evaluate(x, nullptr, nullptr, nullptr, &r))) return "";
  std::string out;
  auto check = [&out](const std::vector<double>& energy_J, const char* term, const char* element, const char* why) {
    for (size_t i = 0; i < energy_J.size(); ++i) {
      if (std::isfinite(energy_J[i])) continue;
      std::ostringstream m;
      m << (out.empty() ? "" : "; ") << term << " energy not finite at " << element << " " << i << " (" << energy_J[i]
        << " J" << why << ")";
      out += m.str();
      return;
    }
  };
  const bool relaxed = model_.effects.relaxation != Relaxation::kNone;
  check(r.membrane_J, "membrane", "face", relaxed ? "" : ": inverted or degenerate, and the relaxation is off");
  check(r.fold_barrier_J, "fold barrier", "face", ": folded over");
  check(r.attachment_J, "attachment", "face", "");
  check(r.contact_J, "contact", "vertex", "");
  check(r.friction_J, "friction", "vertex", "");
  return out.empty() ? "the terms are finite but their sum is not" : out;
}

double GarmentSystem::Evaluate(const Positions& x, Eigen::VectorXd* gradient, Eigen::SparseMatrix<double>* hessian,
                               EnergyBreakdown* breakdown, EvaluationRecord* record) {
  const int nv = num_vertices(), nf = num_faces();
  const bool want_grad = gradient != nullptr, want_hess = hessian != nullptr;
  if (want_grad) gradient->setZero(3 * nv);
  double* values = want_hess ? hessian->valuePtr() : nullptr;
  if (want_hess) std::fill(values, values + hessian->nonZeros(), 0.0);
  const Effects& fx = model_.effects;
  const bool contact = fx.contact != ContactModel::kNone;
  EvaluationRecord& r = record ? *record : scratch_;
  r.membrane_J.assign(nf, 0.0);
  r.attachment_J.assign(fx.attachments && !model_.attachments.faces.empty() ? nf : 0, 0.0);
  r.fold_barrier_J.assign(fx.fold_barrier ? nf : 0, 0.0);
  r.contact_J.assign(contact ? nv : 0, 0.0);
  r.friction_J.assign(contact && !friction_.empty() ? nv : 0, 0.0);
  r.phi.resize(contact && want_grad ? nv : 0);
  r.phi_grad.resize(contact && want_grad ? nv : 0, 3);

  // Faces: membrane, fold barrier and attachments. One colour at a time; faces of a colour share no vertex.
  for (const std::vector<int>& color : colors_) {
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < color.size(); ++i) {
      const int f = color[i];
      FaceTerms t;
      EvaluateFace(f, x, want_grad, want_hess, &t);
      t.StoreIn(f, &r);
      if (!t.scatter) continue;
      if (want_grad)
        for (int a = 0; a < 3; ++a) gradient->segment<3>(3 * model_.faces(f, a)) += t.g.segment<3>(3 * a);
      if (want_hess)
        for (int e = face_scatter_begin_[f]; e < face_scatter_begin_[f + 1]; ++e)
          values[face_scatter_[e].value] += t.H.data()[face_scatter_[e].local];
    }
  }

  // Vertices: contact with the body field, friction.
  if (contact) {
#pragma omp parallel for schedule(static)
    for (int v = 0; v < nv; ++v) {
      VertexTerms t;
      EvaluateVertex(v, x, want_grad, want_hess, &t);
      t.StoreIn(v, &r);
      if (want_grad) gradient->segment<3>(3 * v) += t.g;
      if (want_hess)
        for (int e = vertex_scatter_begin_[v]; e < vertex_scatter_begin_[v + 1]; ++e)
          values[vertex_scatter_[e].value] += t.H.data()[vertex_scatter_[e].local];
    }
  }
  if (record) {
    r.x = x;
    r.design = model_.design;
    r.friction_version = friction_version_;
  }
  return SumEnergies(r, breakdown);
}

double GarmentSystem::EvaluateFrom(const EvaluationRecord& base, const Eigen::VectorXd* base_gradient,
                                   const Eigen::SparseMatrix<double>* base_hessian, const Positions& x,
                                   Eigen::VectorXd* gradient, Eigen::SparseMatrix<double>* hessian,
                                   EnergyBreakdown* breakdown, EvaluationRecord* record) {
  const int nv = num_vertices(), nf = num_faces();
  const bool want_grad = gradient != nullptr, want_hess = hessian != nullptr;
  const bool contact = model_.effects.contact != ContactModel::kNone;
  const bool usable = base.friction_version == friction_version_ && base.x.rows() == nv &&
                      static_cast<int>(base.membrane_J.size()) == nf && base.design.size() == model_.design.size() &&
                      (!want_grad || (base_gradient && base_gradient->size() == 3 * nv &&
                                      (!contact || base.phi.size() == nv))) &&
                      (!want_hess || (want_grad && base_hessian && base_hessian->nonZeros() == pattern_.nonZeros() &&
                                      hessian->nonZeros() == pattern_.nonZeros()));
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
    std::fill(face_mark_.begin(), face_mark_.end(), 0);
    std::fill(vertex_mark_.begin(), vertex_mark_.end(), 0);
    std::fill(entry_mark_.begin(), entry_mark_.end(), 0);
    mark_ = 0;
  }
  mark_ += 2;
  const int changed = mark_, near = mark_ + 1;  // face marks: terms changed; only recomputed for the sums
  EvaluationRecord& r = record ? *record : scratch_;
  if (&r != &base) {
    r.membrane_J = base.membrane_J;
    r.attachment_J = base.attachment_J;
    r.fold_barrier_J = base.fold_barrier_J;
    r.contact_J = base.contact_J;
    r.friction_J = base.friction_J;
    if (want_grad) {
      r.phi = base.phi;
      r.phi_grad = base.phi_grad;
    }
  }
  if (!want_grad) {
    r.phi.resize(0);
    r.phi_grad.resize(0, 3);
  }
  // The faces whose terms change: those of another design, and those around a moved vertex. (The
  // vertices' own terms do not depend on the design.)
  std::vector<int> faces;
  for (int f : redesigned) {
    face_mark_[f] = changed;
    faces.push_back(f);
  }
  for (int v : moved)
    for (int k = vertex_faces_.begin[v]; k < vertex_faces_.begin[v + 1]; ++k) {
      const int f = vertex_faces_.face[k];
      if (face_mark_[f] != changed) {
        face_mark_[f] = changed;
        faces.push_back(f);
      }
    }

  if (!want_grad && !want_hess) {
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < faces.size(); ++i) {
      FaceTerms t;
      EvaluateFace(faces[i], x, false, false, &t);
      t.StoreIn(faces[i], &r);
    }
    if (contact) {
#pragma omp parallel for schedule(static)
      for (size_t i = 0; i < moved.size(); ++i) {
        VertexTerms t;
        EvaluateVertex(moved[i], x, false, false, &t);
        t.StoreIn(moved[i], &r);
      }
    }
  } else {
    // The vertices whose gradient and Hessian block change: those of changed faces, and moved ones. Each
    // of their entries is summed again from all its terms, in Evaluate's order (faces by colour, then the
    // vertex's own terms), from zero.
    std::vector<int> vertices;
    auto add_vertex = [&](int v) {
      if (vertex_mark_[v] != changed) {
        vertex_mark_[v] = changed;
        vertices.push_back(v);
      }
    };
    for (int v : moved) add_vertex(v);
    for (int f : faces)
      for (int k = 0; k < 3; ++k) add_vertex(model_.faces(f, k));
    double* values = nullptr;
    if (want_hess) {
      values = hessian->valuePtr();
      if (hessian != base_hessian) std::copy(base_hessian->valuePtr(), base_hessian->valuePtr() + pattern_.nonZeros(), values);
      for (int f : faces)
        for (int e = face_scatter_begin_[f]; e < face_scatter_begin_[f + 1]; ++e) {
          entry_mark_[face_scatter_[e].value] = changed;
          values[face_scatter_[e].value] = 0.0;
        }
      for (int v : moved)
        for (int e = vertex_scatter_begin_[v]; e < vertex_scatter_begin_[v + 1]; ++e) {
          entry_mark_[vertex_scatter_[e].value] = changed;
          values[vertex_scatter_[e].value] = 0.0;
        }
    }
    if (gradient != base_gradient) *gradient = *base_gradient;
    for (int v : vertices) gradient->segment<3>(3 * v).setZero();
    // Every face that adds to those entries: the faces around their vertices, by colour.
    std::vector<std::vector<int>> by_color(colors_.size());
    for (int v : vertices)
      for (int k = vertex_faces_.begin[v]; k < vertex_faces_.begin[v + 1]; ++k) {
        const int f = vertex_faces_.face[k];
        if (face_mark_[f] == changed) continue;
        if (face_mark_[f] != near) {
          face_mark_[f] = near;
          by_color[face_color_[f]].push_back(f);
        }
      }
    for (int f : faces) by_color[face_color_[f]].push_back(f);
    for (const std::vector<int>& color : by_color) {
#pragma omp parallel for schedule(static)
      for (size_t i = 0; i < color.size(); ++i) {
        const int f = color[i];
        FaceTerms t;
        EvaluateFace(f, x, true, want_hess, &t);
        if (face_mark_[f] == changed) t.StoreIn(f, &r);
        if (!t.scatter) continue;
        for (int a = 0; a < 3; ++a) {
          const int v = model_.faces(f, a);
          if (vertex_mark_[v] == changed) gradient->segment<3>(3 * v) += t.g.segment<3>(3 * a);
        }
        if (want_hess)
          for (int e = face_scatter_begin_[f]; e < face_scatter_begin_[f + 1]; ++e)
            if (entry_mark_[face_scatter_[e].value] == changed) values[face_scatter_[e].value] += t.H.data()[face_scatter_[e].local];
      }
    }
    if (contact) {
#pragma omp parallel for schedule(static)
      for (size_t i = 0; i < vertices.size(); ++i) {
        const int v = vertices[i];
        VertexTerms t;
        EvaluateVertex(v, x, true, want_hess, &t);
        t.StoreIn(v, &r);
        gradient->segment<3>(3 * v) += t.g;
        if (want_hess)
          for (int e = vertex_scatter_begin_[v]; e < vertex_scatter_begin_[v + 1]; ++e)
            if (entry_mark_[vertex_scatter_[e].value] == changed) values[vertex_scatter_[e].value] += t.H.data()[vertex_scatter_[e].local];
      }
    }
  }
  if (record) {
    r.x = x;
    r.design = model_.design;
    r.friction_version = friction_version_;
  }
  return SumEnergies(r, breakdown);
}

void GarmentSystem::FaceDensities(const Positions& x, Eigen::VectorXd* density, std::vector<MembraneRegime>* regime) const {
  const int nf = num_faces();
  if (density) density->resize(nf);
  if (regime) regime->resize(nf);
  for (int f = 0; f < nf; ++f) {
    const int m = model_.design[f];
    const ElementEvaluation ev = EvaluateMembraneElement(elements_[f], x.row(model_.faces(f, 0)), x.row(model_.faces(f, 1)),
                                                         x.row(model_.faces(f, 2)), lame_[m], thickness_[m],
                                                         model_.effects.relaxation, nullptr, nullptr, true);
    if (density) (*density)[f] = ev.density_Pa;
    if (regime) (*regime)[f] = ev.regime;
  }
}

Eigen::VectorXd GarmentSystem::VertexPhi(const Positions& x, Positions* grad) {
  Eigen::VectorXd phi = Eigen::VectorXd::Constant(num_vertices(), std::numeric_limits<double>::quiet_NaN());
  if (grad) grad->setZero(num_vertices(), 3);
  if (!model_.body) return phi;
  if (caches_.empty()) caches_.resize(num_vertices());
#pragma omp parallel for schedule(static)
  for (int v = 0; v < num_vertices(); ++v) {
    const FieldSample s = model_.body->Evaluate(x.row(v).transpose(), &caches_[v], grad != nullptr, false);
    if (s.supported) phi[v] = s.phi_m;
    if (s.supported && grad) grad->row(v) = s.grad.transpose();
  }
  return phi;
}

int GarmentSystem::ProjectCrossingsOntoBody(const Eigen::VectorXd& phi_from, const Positions& grad_from, const Positions& x_from, Positions* trial) {
  if (model_.effects.contact != ContactModel::kUnilateral || !model_.body) return 0;
  if (caches_.empty()) caches_.resize(num_vertices());
  int moved = 0;
#pragma omp parallel for schedule(static) reduction(+ : moved)
  for (int v = 0; v < num_vertices(); ++v) {
    if (std::isnan(phi_from[v])) continue;
    if (free_index_[3 * v] < 0 || free_index_[3 * v + 1] < 0 || free_index_[3 * v + 2] < 0) continue;
    double target = -kProjectionDepth_m, tol = 0.5 * kProjectionDepth_m;
    bool both_ways = false;
    if (phi_from[v] < 0) {
      // In contact: the step is linear, the skin curved. Sliding along it leaves the vertex micrometres
      // deeper (concave skin) or shallower (convex) than the model predicted, and the penalty then answers
      // with a force no Hessian foresaw: the next step undoes it, and the next. Follow the skin instead.
      const double lin = phi_from[v] + grad_from.row(v).dot(trial->row(v) - x_from.row(v));
      if (lin < target) {
        target = lin;
        tol = 1e-3 * -lin + 0.5 * kProjectionDepth_m;
        both_ways = true;
      }
    }
    Eigen::Vector3d y = trial->row(v).transpose();
    FieldSample s = model_.body->Evaluate(y, &caches_[v], true, false);
    if (!s.supported || std::abs(s.phi_m - target) <= tol || (s.phi_m > target && !both_ways)) continue;
    for (int k = 0; k < 4 && s.supported && std::abs(s.phi_m - target) > tol; ++k) {
      const double g2 = s.grad.squaredNorm();
      if (!(g2 > 1e-12)) break;
      y -= ((s.phi_m - target) / g2) * s.grad;
      s = model_.body->Evaluate(y, &caches_[v], true, false);
    }
    if (!y.allFinite()) continue;
    trial->row(v) = y.transpose();
    ++moved;
  }
  return moved;
}

Eigen::Vector3d GarmentSystem::ClampReaction(int clamp, const Eigen::VectorXd& gradient) const {
  Eigen::Vector3d r = Eigen::Vector3d::Zero();
  for (int v : model_.clamps[clamp].vertices) r += gradient.segment<3>(3 * v);
  return r;
}

void GarmentSystem::LagFriction(const Positions& x) {
  if (!(model_.effects.friction > 0) || model_.effects.contact == ContactModel::kNone) return;
  const int nv = num_vertices();
  const Positions& anchor = model_.friction_anchor;
  std::vector<FrictionVertex> lagged(nv);
  for (int v = 0; v < nv; ++v) {
    Eigen::Vector3d g;
    EvaluateContactVertex(*model_.body, x.row(v).transpose(), &caches_[v], model_.effects.contact, model_.contact_stiffness_N_per_m, &g,
                          nullptr, false);
    // The penalty's force is along the field gradient, the body's normal there.
    lagged[v] = ::kgd::LagFriction(anchor.row(v).transpose(), g, g.norm(), model_.effects.friction);
  }
  friction_ = std::move(lagged);
  ++friction_version_;
}

}  // namespace kgd
