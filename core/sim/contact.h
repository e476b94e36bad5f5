// Garment-body contact: a penalty on the body field Phi at each garment vertex (paper eq. BodyEnergy).
//   unilateral (default): E_i = k min(Phi(x_i), 0)^2   -- keeps cloth out, allows lift-off
//   bilateral:            E_i = k Phi(x_i)^2           -- glues cloth to the surface (for comparison)
// k in N/m (J/m^2). Default 5000 N/m: the authors' weight 0.005 in MPa-based code units (MJ/m^2) in SI.
// A vertex outside the field's support (farther than ~h from the body) carries no energy.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/body/body_field.h"
#include "core/sim/energy_terms.h"

namespace kgd {

enum class ContactModel { kNone, kUnilateral, kBilateral };

inline constexpr double kDefaultContactStiffness = 5000.0;  // N/m

struct ContactEvaluation {
  double energy_J = 0;
  double phi_m = 0;
  Eigen::Vector3d phi_grad = Eigen::Vector3d::Zero();  // grad Phi where supported, when a gradient was asked for
  bool supported = false;
};

// Energy of one vertex and, on request, gradient (N) and Hessian (N/m); with `project_hessian` the
// Hessian is projected to positive semi-definite.
ContactEvaluation EvaluateContactVertex(const BodyField& field, const Eigen::Vector3d& x, NeighborCache* cache,
                                        ContactModel model, double stiffness_N_per_m, Eigen::Vector3d* grad,
                                        Eigen::Matrix3d* hess, bool project_hessian);

// Contact as an energy term of the garment system (energy_term.h), per vertex. It also keeps, per
// vertex, Phi (NaN where unsupported) and grad Phi of its latest evaluation, which the system records
// for the line search's projection (GarmentSystem::ProjectCrossingsOntoBody).
class ContactTerm final : public EnergyTerm {
 public:
  explicit ContactTerm(const TermContext& context);
  Stencil stencil() const override { return Stencil::kVertex; }
  ElementEnergy Evaluate(int v, const int* stencil, const Positions& x, double* g, double* H) override;
  double last_phi(int v) const { return phi_[v]; }
  const Eigen::Vector3d& last_phi_grad(int v) const { return phi_grad_[v]; }

 private:
  TermContext c_;
  std::vector<double> phi_;
  std::vector<Eigen::Vector3d> phi_grad_;
};

}  // namespace kgd
