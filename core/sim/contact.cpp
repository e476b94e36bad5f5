#include "core/sim/contact.h"

#include <algorithm>
#include <Eigen/Eigenvalues>
#include "core/sim/energy_terms.h"
#include "core/sim/garment_system.h"
#include <limits>

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
    : c_(context), phi_(context.model.rest.rows(), 0.0), phi_grad_(context.model.rest.rows(), Eigen::Vector3d::Zero()) {}

ElementEnergy ContactTerm::Evaluate(int v, const int*, const Positions& x, double* g, double* H) {
  Eigen::Vector3d gc;
  Eigen::Matrix3d Hc;
  const ContactEvaluation ce = EvaluateContactVertex(*c_.model.body, x.row(v).transpose(), &c_.caches[v], c_.model.effects.contact,
                                                     c_.model.contact_stiffness_N_per_m, g ? &gc : nullptr, H ? &Hc : nullptr, true);
  phi_[v] = ce.supported ? ce.phi_m : std::numeric_limits<double>::quiet_NaN();
  phi_grad_[v] = ce.phi_grad;
  if (g) std::copy_n(gc.data(), gc.size(), g);
  if (H) std::copy_n(Hc.data(), Hc.size(), H);
  return {ce.energy_J, true};
}

std::unique_ptr<EnergyTerm> MakeContactTerm(const TermContext& context) {
  return context.model.effects.contact != ContactModel::kNone ? std::make_unique<ContactTerm>(context) : nullptr;
}
}  // namespace kgd
