#include "core/sim/contact.h"

#include <Eigen/Eigenvalues>

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

}  // namespace kgd
