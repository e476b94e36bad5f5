// Friction between garment and skin: an extension of the paper's model, whose contact is frictionless.
// Without it a garment whose reinforcement has been thinned can slide over the joint (a sleeve slips
// 4-7 cm around the bent elbow; docs/RESULTS.md), which a sleeve on skin does not do.
//
// Model: smoothed Coulomb friction as a lagged potential (IPC, Li et al. 2020), for one quasi-static
// step from the garment on the body (the paper's initialization) to equilibrium. Per garment vertex v,
//   D_v(x) = mu lambda_v f0(|T_v^T (x_v - a_v)|)
// with a_v the vertex on the body in the simulated pose (where it was put on), T_v an orthonormal
// basis (3x2) of the body's tangent plane and lambda_v the contact normal force (N), both lagged: taken
// at a given state (the last equilibrium) and held fixed during a solve. f0 is |y| with the kink
// smoothed within the slip distance eps: f0(y) = -y^3/(3 eps^2) + y^2/eps + eps/3 for y < eps. So a
// vertex resists tangential displacement from where it was put on with a force of at most mu lambda_v,
// reached after sliding eps. The Hessian is positive semi-definite by construction.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/sim/energy_terms.h"
#include "core/sim/garment_model.h"

namespace kgd {

struct FrictionVertex {
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();         // a_v (m)
  Eigen::Matrix<double, 3, 2> tangent = Eigen::Matrix<double, 3, 2>::Zero();  // T_v
  double mu_lambda_N = 0;                                     // mu times the lagged normal force (N)
};

// D_v at x (J) and, on request, its gradient (N) and Hessian (N/m, PSD).
double EvaluateFriction(const FrictionVertex& v, const Eigen::Vector3d& x, double slip_m, Eigen::Vector3d* grad,
                        Eigen::Matrix3d* hess);

// The lagged data of a vertex at `x`: the normal force of the contact penalty there (lambda = |dE_c/dx|,
// N), the field gradient (the body's normal direction) and the anchor.
FrictionVertex LagFriction(const Eigen::Vector3d& anchor, const Eigen::Vector3d& normal, double normal_force_N, double mu);

// Friction as an energy term of the garment system (energy_term.h), per vertex, from the lagged data
// (none before the first Lag: the term is zero). Lag(x) takes each vertex's contact normal force and
// tangent plane at x; the anchors are model.friction_anchor, or the positions the system starts from.
class FrictionTerm final : public EnergyTerm {
 public:
  explicit FrictionTerm(const TermContext& context);
  Stencil stencil() const override { return Stencil::kVertex; }
  ElementEnergy Evaluate(int v, const int* stencil, const Positions& x, double* g, double* H) override;
  bool lagged() const override { return true; }
  void Lag(const Positions& x) override;
  // Sets the lagged data directly (one per vertex), as Lag would.
  void SetLagged(std::vector<FrictionVertex> lagged) { lagged_ = std::move(lagged); }

 private:
  const GarmentModel& model_;
  std::vector<NeighborCache>& caches_;
  Positions anchor_;
  std::vector<FrictionVertex> lagged_;  // per vertex (empty: not lagged yet)
};

}  // namespace kgd
