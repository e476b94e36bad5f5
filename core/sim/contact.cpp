#include "core/sim/contact.h"

#include <algorithm>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>

#include "core/sim/energy_terms.h"

namespace kgd {

ContactEvaluation EvaluateContactVertex(const BodyField& field, const Eigen::Vector3d& x, NeighborCache* cache,
                                        ContactModel model, double k, Eigen::Vector3d* grad, Eigen::Matrix3d* hess,
                                        bool project_hessian) {
  ContactEvaluation out;
  if (grad) grad->setZero();
  if (hess) hess->setZero();
  if (model == ContactModel::kNone) return out;
  const FieldSample s = field.Evaluate(x, cache, grad || hess, hess != nullptr);
  out.supported = s.supported;
  out.phi_m = s.phi_m;
  if (!s.supported) return out;
  if (grad || hess) out.phi_grad = s.grad;
  if (model == ContactModel::kUnilateral && s.phi_m >= 0) return out;
  out.energy_J = k * s.phi_m * s.phi_m;
  if (grad) *grad = 2.0 * k * s.phi_m * s.grad;
  if (hess) {
    *hess = 2.0 * k * (s.grad * s.grad.transpose() + s.phi_m * s.hess);
    if (project_hessian) {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
      eig.computeDirect(*hess);
      const Eigen::Vector3d lam = eig.eigenvalues().cwiseMax(0.0);
      *hess = eig.eigenvectors() * lam.asDiagonal() * eig.eigenvectors().transpose();
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------------
// Contact as an energy term of the garment system (energy_term.h).

ContactTerm::ContactTerm(const TermContext& context)
    : model_(context.model),
      caches_(context.caches),
      phi_(context.model.rest.rows(), 0.0),
      phi_grad_(context.model.rest.rows(), Eigen::Vector3d::Zero()) {}

ElementEnergy ContactTerm::Evaluate(int v, const int*, const Positions& x, double* g, double* H) {
  Eigen::Vector3d gc;
  Eigen::Matrix3d Hc;
  const ContactEvaluation ce = EvaluateContactVertex(*model_.body, x.row(v).transpose(), &caches_[v], model_.effects.contact,
                                                     model_.contact_stiffness_N_per_m, g ? &gc : nullptr, H ? &Hc : nullptr, true);
  phi_[v] = ce.supported ? ce.phi_m : std::numeric_limits<double>::quiet_NaN();
  phi_grad_[v] = ce.phi_grad;
  if (g) std::copy_n(gc.data(), gc.size(), g);
  if (H) std::copy_n(Hc.data(), Hc.size(), H);
  return {ce.energy_J, true};
}

void ContactTerm::RecordElement(int v, double* out) const {
  out[0] = phi_[v];
  for (int i = 0; i < 3; ++i) out[1 + i] = phi_grad_[v][i];
}

int ContactTerm::ProjectTrial(const std::vector<double>& recorded, const Positions& x_from, const std::vector<int>& free_index,
                              Positions* trial) {
  const int nv = static_cast<int>(model_.rest.rows());
  if (model_.effects.contact != ContactModel::kUnilateral || !model_.body || recorded.size() != 4 * static_cast<size_t>(nv)) return 0;
  int moved = 0;
#pragma omp parallel for schedule(static) reduction(+ : moved)
  for (int v = 0; v < nv; ++v) {
    const double phi_from = recorded[4 * v];
    const Eigen::Vector3d grad_from(recorded[4 * v + 1], recorded[4 * v + 2], recorded[4 * v + 3]);
    if (std::isnan(phi_from)) continue;
    if (free_index[3 * v] < 0 || free_index[3 * v + 1] < 0 || free_index[3 * v + 2] < 0) continue;
    double target = -kContactProjectionDepth_m, tol = 0.5 * kContactProjectionDepth_m;
    bool both_ways = false;
    if (phi_from < 0) {
      // In contact: the step is linear, the skin curved. Sliding along it leaves the vertex micrometres
      // deeper (concave skin) or shallower (convex) than the model predicted, and the penalty then answers
      // with a force no Hessian foresaw: the next step undoes it, and the next. Follow the skin instead.
      const double lin = phi_from + grad_from.dot(trial->row(v).transpose() - x_from.row(v).transpose());
      if (lin < target) {
        target = lin;
        tol = 1e-3 * -lin + 0.5 * kContactProjectionDepth_m;
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

std::unique_ptr<EnergyTerm> MakeContactTerm(const TermContext& context) {
  return context.model.effects.contact != ContactModel::kNone ? std::make_unique<ContactTerm>(context) : nullptr;
}
}  // namespace kgd
