#include "core/sim/membrane.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>

namespace kgd {
namespace {

// Plain neo-Hookean in principal stretches; precondition s1, s2 > 0.
StretchEnergy NeoHookean(double s1, double s2, const Lame& lame) {
  const double mu = lame.mu_Pa, la = lame.lambda_Pa;
  const double L = std::log(s1 * s2);
  StretchEnergy e;
  e.W = 0.5 * mu * (s1 * s1 + s2 * s2 - 2.0) - mu * L + 0.5 * la * L * L;
  e.W1 = mu * s1 + (la * L - mu) / s1;
  e.W2 = mu * s2 + (la * L - mu) / s2;
  e.W11 = mu + (mu + la - la * L) / (s1 * s1);
  e.W22 = mu + (mu + la - la * L) / (s2 * s2);
  e.W12 = la / (s1 * s2);
  e.regime = MembraneRegime::kTaut;
  return e;
}

}  // namespace

Lame LameParameters(const Material& m, LameConversion conversion) {
  const double E = m.youngs_modulus_Pa, nu = m.poisson_ratio;
  Lame l;
  l.mu_Pa = E / (2.0 * (1.0 + nu));
  l.lambda_Pa = conversion == LameConversion::kSolid3D ? E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
                                                       : E * nu / (1.0 - nu * nu);
  return l;
}

double FreeContractionStretch(double s2, const Lame& lame) {
  // In y = ln r the condition mu (r^2 - 1) + lambda ln(r s2) = 0 is convex and increasing, so Newton
  // from the side where it is non-negative (y = 0 for s2 >= 1) converges monotonically.
  const double mu = lame.mu_Pa, la = lame.lambda_Pa, ls2 = std::log(s2);
  double y = s2 >= 1.0 ? 0.0 : -ls2;  // for s2 < 1, y = -ln s2 > 0 gives h >= 0 too
  for (int it = 0; it < 100; ++it) {
    const double e2y = std::exp(2.0 * y);
    const double h = mu * (e2y - 1.0) + la * (y + ls2);
    const double dh = 2.0 * mu * e2y + la;
    const double step = h / dh;
    y -= step;
    if (std::abs(step) < 1e-15) break;
  }
  return std::exp(y);
}

StretchEnergy EnergyOfStretches(double s1, double s2, const Lame& lame, Relaxation relaxation) {
  StretchEnergy e;
  switch (relaxation) {
    case Relaxation::kNone:
      if (!(s1 > 0.0)) {
        e.W = std::numeric_limits<double>::infinity();
        return e;
      }
      return NeoHookean(s1, s2, lame);
    case Relaxation::kExact: {
      if (s2 <= 1.0) {
        e.regime = MembraneRegime::kSlack;
        return e;
      }
      const double r = FreeContractionStretch(s2, lame);
      if (s1 >= r) return NeoHookean(s1, s2, lame);
      // Wrinkled: W_u(s2) = W(r(s2), s2). Since W1(r, s2) = 0, W_u' = W2 and, with r' = -W12 / W11,
      // W_u'' = W22 - W12^2 / W11.
      const StretchEnergy b = NeoHookean(r, s2, lame);
      e.W = b.W;
      e.W2 = b.W2;
      e.W22 = b.W22 - b.W12 * b.W12 / b.W11;
      e.regime = MembraneRegime::kWrinkled;
      return e;
    }
    case Relaxation::kAuthors: {
      if (s2 < 1.0) {
        e.regime = MembraneRegime::kSlack;
        return e;
      }
      const double q = 1.0 / std::sqrt(s2);
      if (s1 >= q) return NeoHookean(s1, s2, lame);
      // W_a(s2) = W(q(s2), s2) with q = s2^-1/2: chain rule.
      const double dq = -0.5 * q / s2, ddq = 0.75 * q / (s2 * s2);
      const StretchEnergy b = NeoHookean(q, s2, lame);
      e.W = b.W;
      e.W2 = b.W1 * dq + b.W2;
      e.W22 = b.W11 * dq * dq + 2.0 * b.W12 * dq + b.W22 + b.W1 * ddq;
      e.regime = MembraneRegime::kWrinkled;
      return e;
    }
  }
  return e;
}

MembraneElement MakeMembraneElement(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2) {
  const Eigen::Vector3d e1 = x1 - x0, e2 = x2 - x0;
  const Eigen::Vector3d b0 = e1.normalized();
  const Eigen::Vector3d b1 = (e1.cross(e2)).cross(e1).normalized();  // in-plane, perpendicular to e1, towards x2
  Eigen::Matrix2d dm;
  dm << e1.norm(), e2.dot(b0), 0.0, e2.dot(b1);
  MembraneElement el;
  el.dm_inv = dm.inverse();
  el.rest_area_m2 = 0.5 * dm.determinant();
  return el;
}

Eigen::Matrix<double, 3, 2> DeformationGradient(const MembraneElement& element, const Eigen::Vector3d& x0,
                                                const Eigen::Vector3d& x1, const Eigen::Vector3d& x2) {
  Eigen::Matrix<double, 3, 2> ds;
  ds.col(0) = x1 - x0;
  ds.col(1) = x2 - x0;
  return ds * element.dm_inv;
}

ElementEvaluation EvaluateMembraneElement(const MembraneElement& element, const Eigen::Vector3d& x0,
                                          const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, const Lame& lame,
                                          double thickness_m, Relaxation relaxation, Vector9d* grad, Matrix9d* hess,
                                          bool project_hessian) {
  const Eigen::Matrix<double, 3, 2> F = DeformationGradient(element, x0, x1, x2);
  const Eigen::Matrix2d C = F.transpose() * F;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig;
  eig.computeDirect(C);
  const Eigen::Vector2d c = eig.eigenvalues();  // ascending
  const Eigen::Matrix2d V = eig.eigenvectors();
  // The small singular value from the eigenvalue loses accuracy by cancellation when a triangle nearly
  // collapses; J = |f1 x f2| (the area ratio) is exact, so s1 = J / s2.
  const double s2 = std::sqrt(std::max(c[1], 0.0));
  const double J = F.col(0).cross(F.col(1)).norm();
  const double s1 = s2 > 0 ? std::min(J / s2, s2) : 0.0;

  const StretchEnergy w = EnergyOfStretches(s1, s2, lame, relaxation);
  const double scale = thickness_m * element.rest_area_m2;
  ElementEvaluation out;
  out.density_Pa = w.W;
  out.energy_J = scale * w.W;
  out.regime = w.regime;
  if (!std::isfinite(w.W)) return out;
  if (!grad && !hess) return out;

  // Shape-function gradients in the rest frame: F = sum_a x_a g_a^T.
  Eigen::Vector2d g[3];
  g[1] = element.dm_inv.row(0).transpose();
  g[2] = element.dm_inv.row(1).transpose();
  g[0] = -(g[1] + g[2]);

  if (w.regime == MembraneRegime::kSlack) {
    if (grad) grad->setZero();
    if (hess) hess->setZero();
    return out;
  }

  // Left singular vectors u_i = F v_i / s_i. Where s1 vanishes (a triangle collapsed to a segment,
  // possible only in the wrinkled regime where W does not depend on s1), any unit u1 normal to u2 is valid.
  const Eigen::Vector2d V1 = V.col(0), V2 = V.col(1);
  Eigen::Vector3d u2 = F * V2;
  u2 /= s2;
  Eigen::Vector3d u1;
  if (s1 > 1e-10 * s2) {
    u1 = F * V1 / s1;
  } else {
    const Eigen::Vector3d axis = std::abs(u2.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    u1 = (axis - axis.dot(u2) * u2).normalized();
  }
  const Eigen::Vector3d n = u1.cross(u2);

  if (grad) {
    const Eigen::Matrix<double, 3, 2> P = w.W1 * u1 * V1.transpose() + w.W2 * u2 * V2.transpose();
    for (int a = 0; a < 3; ++a) grad->segment<3>(3 * a) = scale * P * g[a];
  }
  if (!hess) return out;

  // Each mode is a rank-one 3x2 matrix sum Q = sum_j alpha_j p_j q_j^T; its nine-vector has blocks Q g_a.
  hess->setZero();
  auto add_mode = [&](double lambda, const Eigen::Vector3d& pa, const Eigen::Vector2d& qa, double ca,
                      const Eigen::Vector3d& pb, const Eigen::Vector2d& qb, double cb) {
    if (project_hessian && lambda <= 0.0) return;
    Vector9d m;
    for (int a = 0; a < 3; ++a) m.segment<3>(3 * a) = ca * pa * qa.dot(g[a]) + cb * pb * qb.dot(g[a]);
    hess->noalias() += (scale * lambda) * m * m.transpose();
  };
  const Eigen::Vector3d zero3 = Eigen::Vector3d::Zero();
  const Eigen::Vector2d zero2 = Eigen::Vector2d::Zero();

  // Stretch modes: the 2x2 Hessian in (s1, s2) along u1 v1^T and u2 v2^T.
  Eigen::Matrix2d A;
  A << w.W11, w.W12, w.W12, w.W22;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigA;
  eigA.computeDirect(A);
  for (int j = 0; j < 2; ++j) {
    const Eigen::Vector2d a = eigA.eigenvectors().col(j);
    add_mode(eigA.eigenvalues()[j], u1, V1, a[0], u2, V2, a[1]);
  }
  const double inv_sqrt2 = 1.0 / std::sqrt(2.0);
  // Twist (in-plane rotation-like) and flip (in-plane shear-like) modes.
  const double twist = (s1 + s2) > 0 ? (w.W1 + w.W2) / (s1 + s2) : 0.0;
  double flip;
  if (w.regime == MembraneRegime::kTaut) {
    // (W1 - W2)/(s1 - s2) in closed form, exact also at s1 = s2.
    const double L = std::log(s1 * s2);
    flip = lame.mu_Pa + (lame.mu_Pa - lame.lambda_Pa * L) / (s1 * s2);
  } else {
    flip = (w.W1 - w.W2) / (s1 - s2);  // wrinkled: s1 < r(s2) <= 1 < s2, so the denominator is non-zero
  }
  add_mode(twist, u1, V2, inv_sqrt2, u2, V1, -inv_sqrt2);
  add_mode(flip, u1, V2, inv_sqrt2, u2, V1, inv_sqrt2);
  // Out-of-plane modes n v_i^T: C changes at second order only, so the curvature is W_i / s_i.
  const double out1 = s1 > 0 ? w.W1 / s1 : 0.0;
  const double out2 = s2 > 0 ? w.W2 / s2 : 0.0;
  add_mode(out1, n, V1, 1.0, zero3, zero2, 0.0);
  add_mode(out2, n, V2, 1.0, zero3, zero2, 0.0);
  return out;
}

}  // namespace kgd
