#include "core/sim/friction.h"

#include <algorithm>
#include <Eigen/Geometry>
#include <cmath>
#include "core/sim/contact.h"
#include "core/sim/energy_terms.h"

namespace kgd {

double EvaluateFriction(const FrictionVertex& v, const Eigen::Vector3d& x, double eps, Eigen::Vector3d* grad, Eigen::Matrix3d* hess) {
  if (grad) grad->setZero();
  if (hess) hess->setZero();
  if (v.mu_lambda_N <= 0) return 0;
  const Eigen::Vector2d u = v.tangent.transpose() * (x - v.anchor);
  const double y = u.norm();
  double f0, f1_over_y, f1_prime;
  if (y < eps) {
    f0 = -y * y * y / (3 * eps * eps) + y * y / eps + eps / 3;
    f1_over_y = 2 / eps - y / (eps * eps);
    f1_prime = 2 / eps - 2 * y / (eps * eps);
  } else {
    f0 = y;
    f1_over_y = 1 / y;
    f1_prime = 0;
  }
  const double c = v.mu_lambda_N;
  if (grad) *grad = c * f1_over_y * (v.tangent * u);
  if (hess) {
    // d2 f0(|u|)/du2 = f1' uhat uhat^T + (f1 / y) (I - uhat uhat^T): both coefficients >= 0.
    Eigen::Matrix2d h = f1_over_y * Eigen::Matrix2d::Identity();
    if (y > 0) {
      const Eigen::Vector2d uh = u / y;
      h += (f1_prime - f1_over_y) * uh * uh.transpose();
    }
    *hess = c * v.tangent * h * v.tangent.transpose();
  }
  return c * f0;
}

FrictionVertex LagFriction(const Eigen::Vector3d& anchor, const Eigen::Vector3d& normal, double normal_force_N, double mu) {
  FrictionVertex v;
  v.anchor = anchor;
  const double n = normal.norm();
  if (!(n > 0) || !(normal_force_N > 0) || !(mu > 0)) return v;
  const Eigen::Vector3d nn = normal / n;
  const Eigen::Vector3d t1 = nn.unitOrthogonal();
  v.tangent.col(0) = t1;
  v.tangent.col(1) = nn.cross(t1);
  v.mu_lambda_N = mu * normal_force_N;
  return v;
}

// ---------------------------------------------------------------------------------------------------
// Friction as an energy term of the garment system (energy_term.h).

FrictionTerm::FrictionTerm(const TermContext& context)
    : model_(context.model),
      caches_(context.caches),
      anchor_(context.model.friction_anchor.rows() == context.model.rest.rows() ? context.model.friction_anchor : context.initial) {}

ElementEnergy FrictionTerm::Evaluate(int v, const int*, const Positions& x, double* g, double* H) {
  if (lagged_.empty() || !(lagged_[v].mu_lambda_N > 0)) return {0.0, false};
  Eigen::Vector3d gf;
  Eigen::Matrix3d Hf;
  const double e = EvaluateFriction(lagged_[v], x.row(v).transpose(), model_.friction_slip_m, g ? &gf : nullptr, H ? &Hf : nullptr);
  if (g) std::copy_n(gf.data(), gf.size(), g);
  if (H) std::copy_n(Hf.data(), Hf.size(), H);
  return {e, true};
}

void FrictionTerm::Lag(const Positions& x) {
  const int nv = static_cast<int>(x.rows());
  std::vector<FrictionVertex> lagged(nv);
  for (int v = 0; v < nv; ++v) {
    Eigen::Vector3d g;
    EvaluateContactVertex(*model_.body, x.row(v).transpose(), &caches_[v], model_.effects.contact, model_.contact_stiffness_N_per_m, &g,
                          nullptr, false);
    // The penalty's force is along the field gradient, the body's normal there.
    lagged[v] = LagFriction(anchor_.row(v).transpose(), g, g.norm(), model_.effects.friction);
  }
  lagged_ = std::move(lagged);
}

std::unique_ptr<EnergyTerm> MakeFrictionTerm(const TermContext& context) {
  const Effects& fx = context.model.effects;
  return fx.friction > 0 && fx.contact != ContactModel::kNone ? std::make_unique<FrictionTerm>(context) : nullptr;
}
}  // namespace kgd
