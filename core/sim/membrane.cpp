#include "core/sim/membrane.h"

#include <algorithm>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "core/sim/energy_terms.h"
#include "core/sim/garment_model.h"

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

// Eigensystem of the symmetric 2 x 2 matrix [a b; b d]: eigenvalues ascending, unit eigenvectors in the
// columns of `vectors` (when given). In closed form: Eigen's generic direct solver for 2 x 2 (scaling,
// careful root extraction) was a seventh of a Hessian assembly and a fifth of an energy evaluation.
// The root with cancellation is recovered from the determinant, so both eigenvalues keep their
// relative accuracy, which the projection's sign test relies on.
struct SymmetricEigen2 {
  Eigen::Vector2d values;
  Eigen::Matrix2d vectors;
};
SymmetricEigen2 EigenOfSymmetric2(double a, double b, double d, bool want_vectors) {
  const double mean = 0.5 * (a + d), half_diff = 0.5 * (a - d);
  const double r = std::sqrt(half_diff * half_diff + b * b);
  SymmetricEigen2 e;
  const double det = a * d - b * b;
  if (mean >= 0) {
    const double hi = mean + r;
    e.values << (hi != 0 ? det / hi : 0.0), hi;
  } else {
    const double lo = mean - r;
    e.values << lo, det / lo;
  }
  if (!want_vectors) return e;
  // Eigenvector of the larger eigenvalue from whichever row of (A - hi I) is better conditioned.
  Eigen::Vector2d v = half_diff >= 0 ? Eigen::Vector2d(half_diff + r, b) : Eigen::Vector2d(b, r - half_diff);
  const double norm = v.norm();
  v = norm > 0 ? Eigen::Vector2d(v / norm) : Eigen::Vector2d(1.0, 0.0);
  e.vectors.col(1) = v;
  e.vectors.col(0) = Eigen::Vector2d(-v.y(), v.x());
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
  // In y = ln r the condition h(y) = mu (e^2y - 1) + lambda (y + ln s2) = 0 is convex and increasing.
  // Halley's iteration from the root of the linearized condition, y = -lambda ln s2 / (2 mu + lambda):
  // each iteration costs an exp, and this root was a sixth of an energy evaluation when Newton from
  // y = 0 took five to seven of them. Halley's error after a step of size d is O(d^3) (here h''/h' <= 2),
  // so a step below 1e-6 leaves the root exact to round-off; r = e^y then follows from the last e^2y
  // by a series instead of another exp. Where the Halley denominator is not positive (far from the
  // root) the step is Newton's, which converges from anywhere on a convex increasing function.
  const double mu = lame.mu_Pa, la = lame.lambda_Pa, ls2 = std::log(s2);
  double y = -la * ls2 / (2.0 * mu + la);
  for (int it = 0; it < 100; ++it) {
    const double e2y = std::exp(2.0 * y);
    const double h = mu * (e2y - 1.0) + la * (y + ls2);
    const double dh = 2.0 * mu * e2y + la;
    const double ddh = 4.0 * mu * e2y;
    const double denominator = 2.0 * dh * dh - h * ddh;
    const double step = denominator > 0 ? 2.0 * h * dh / denominator : h / dh;
    y -= step;
    if (std::abs(step) < 1e-6) return std::sqrt(e2y) * (1.0 - step + 0.5 * step * step - step * step * step / 6.0);
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
  const SymmetricEigen2 eig = EigenOfSymmetric2(C(0, 0), C(0, 1), C(1, 1), grad || hess);
  const Eigen::Vector2d& c = eig.values;  // ascending
  const Eigen::Matrix2d& V = eig.vectors;
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
  const SymmetricEigen2 eigA = EigenOfSymmetric2(w.W11, w.W12, w.W22, true);
  for (int j = 0; j < 2; ++j) {
    const Eigen::Vector2d a = eigA.vectors.col(j);
    add_mode(eigA.values[j], u1, V1, a[0], u2, V2, a[1]);
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

// ---------------------------------------------------------------------------------------------------
// The membrane as an energy term of the garment system (energy_term.h): per face, the material of the
// face's design.

namespace {

class MembraneFaceTerm final : public EnergyTerm {
 public:
  explicit MembraneFaceTerm(const TermContext& context) : model_(context.model) {
    const GarmentModel& m = context.model;
    elements_.resize(m.faces.rows());
    for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
      elements_[f] = MakeMembraneElement(m.rest.row(m.faces(f, 0)), m.rest.row(m.faces(f, 1)), m.rest.row(m.faces(f, 2)));
    const Material mats[2] = {m.cloth, m.reinforced};
    for (int k = 0; k < 2; ++k) {
      lame_[k] = LameParameters(mats[k], m.lame);
      thickness_[k] = mats[k].thickness_m;
    }
  }
  Stencil stencil() const override { return Stencil::kFace; }
  ElementEnergy Evaluate(int f, const int* v, const Positions& x, double* g, double* H) override {
    const Eigen::Vector3d x0 = x.row(v[0]), x1 = x.row(v[1]), x2 = x.row(v[2]);
    const int m = model_.design[f];
    Vector9d ge;
    Matrix9d He;
    const ElementEvaluation ev = EvaluateMembraneElement(elements_[f], x0, x1, x2, lame_[m], thickness_[m],
                                                         model_.effects.relaxation, g ? &ge : nullptr, H ? &He : nullptr, true);
    if (!std::isfinite(ev.energy_J)) return {ev.energy_J, false};
    if (g) std::copy_n(ge.data(), ge.size(), g);
    if (H) std::copy_n(He.data(), He.size(), H);
    return {ev.energy_J, true};
  }
  std::string NonFiniteMeaning() const override {
    return model_.effects.relaxation != Relaxation::kNone ? "" : ": inverted or degenerate, and the relaxation is off";
  }
  // The garment's strain energy: W and the regime per face.
  bool FaceDensities(const Positions& x, Eigen::VectorXd* density, std::vector<MembraneRegime>* regime) const override {
    const int nf = static_cast<int>(model_.faces.rows());
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
    return true;
  }

 private:
  const GarmentModel& model_;
  std::vector<MembraneElement> elements_;
  Lame lame_[2];
  double thickness_[2];
};

}  // namespace

std::unique_ptr<EnergyTerm> MakeMembraneTerm(const TermContext& context) {
  return context.model.effects.membrane ? std::make_unique<MembraneFaceTerm>(context) : nullptr;
}

}  // namespace kgd
