// Finite-difference checks of an energy term's derivatives, for tests: the one helper every term's test
// uses (membrane, fold barrier, attachment, contact, friction, and the assembled system). A term is
// given as a function of its stencil's coordinates q (3 per vertex): its energy and, on request, its
// analytic gradient and Hessian.
//
// MatchesFiniteDifferences compares the gradient with central differences of the energy and the
// Hessian with central differences of the analytic gradient, both relative to the larger of their own
// norm and a floor, and checks the Hessian's symmetry. ProjectionIsPsd checks a clamping projection
// against the exact Hessian: PSD, adding stiffness only, and only in as many directions as the exact
// one has negative eigenvalues (so unchanged where the exact one is PSD, rigid-motion zero modes
// included); ProjectionIsEigenvalueClamp demands the eigenvalue clamp of the exact Hessian itself.
// FiniteDifferenceHessian gives the exact Hessian of a term whose analytic one is the one under test.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <functional>
#include <sstream>

namespace kgd::testing {

// energy(q), with `g` (size of q) and `H` (square) filled when non-null.
using TermFunction = std::function<double(const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H)>;

struct FiniteDifferenceOptions {
  double step = 1e-7;          // h of the central differences, in the units of q (m)
  double tolerance = 1e-5;     // allowed error relative to the scale
  double gradient_floor = 0;   // the gradient's scale is max(|g|, gradient_floor) (N)
  double hessian_floor = 0;    // the Hessian's scale is max(|H|, hessian_floor) (N/m)
  bool check_hessian = true;
};

inline ::testing::AssertionResult MatchesFiniteDifferences(const TermFunction& f, const Eigen::VectorXd& q,
                                                           const FiniteDifferenceOptions& o = {}) {
  const Eigen::Index n = q.size();
  Eigen::VectorXd g(n);
  Eigen::MatrixXd H(n, n);
  const double E = f(q, &g, o.check_hessian ? &H : nullptr);
  if (!std::isfinite(E)) return ::testing::AssertionFailure() << "energy is not finite at q: " << E;
  Eigen::VectorXd g_fd = g;
  Eigen::MatrixXd H_fd = o.check_hessian ? H : Eigen::MatrixXd();
  for (Eigen::Index i = 0; i < n; ++i) {
    Eigen::VectorXd qp = q, qm = q;
    qp[i] += o.step;
    qm[i] -= o.step;
    Eigen::VectorXd gp(n), gm(n);  // sized: a term may write into them
    const double Ep = f(qp, o.check_hessian ? &gp : nullptr, nullptr);
    const double Em = f(qm, o.check_hessian ? &gm : nullptr, nullptr);
    g_fd[i] = (Ep - Em) / (2 * o.step);
    if (o.check_hessian) H_fd.col(i) = (gp - gm) / (2 * o.step);
  }
  const double g_scale = std::max(g.norm(), o.gradient_floor);
  if ((g - g_fd).norm() > o.tolerance * g_scale)
    return ::testing::AssertionFailure() << "gradient off by " << (g - g_fd).norm() << " (scale " << g_scale << ")\n  analytic "
                                         << g.transpose() << "\n  central  " << g_fd.transpose();
  if (!o.check_hessian) return ::testing::AssertionSuccess();
  const double H_scale = std::max(H.norm(), o.hessian_floor);
  if ((H - H_fd).norm() > o.tolerance * H_scale)
    return ::testing::AssertionFailure() << "Hessian off by " << (H - H_fd).norm() << " (scale " << H_scale << ")\nanalytic\n"
                                         << H << "\ncentral differences of the gradient\n" << H_fd;
  if ((H - H.transpose()).norm() > 1e-12 * std::max(H_scale, 1e-300))
    return ::testing::AssertionFailure() << "Hessian not symmetric: |H - H^T| = " << (H - H.transpose()).norm();
  return ::testing::AssertionSuccess();
}

// The exact Hessian of `f` at q by central differences of its analytic gradient (step h), symmetrized:
// the reference for a term whose only Hessian is the one under test.
inline Eigen::MatrixXd FiniteDifferenceHessian(const TermFunction& f, const Eigen::VectorXd& q, double h) {
  const Eigen::Index n = q.size();
  Eigen::MatrixXd H(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    Eigen::VectorXd qp = q, qm = q, gp(n), gm(n);
    qp[i] += h;
    qm[i] -= h;
    f(qp, &gp, nullptr);
    f(qm, &gm, nullptr);
    H.col(i) = (gp - gm) / (2 * h);
  }
  return 0.5 * (H + H.transpose());
}

// `f` with its Hessian replaced by central differences of its gradient (step h).
inline TermFunction WithFiniteDifferenceHessian(TermFunction f, double h) {
  return [f, h](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
    if (H) *H = FiniteDifferenceHessian(f, q, h);
    return f(q, g, nullptr);
  };
}

// The projection of a clamping kind: P = projected Hessian, H = exact one, both at q. Demands
//   P is PSD,  P - H is PSD (the projection only adds stiffness),  rank(P - H) <= number of negative
//   eigenvalues of H (it changes H only in as many directions as H curves down).
// So P = H whenever H is PSD (zero modes included), a zero projection fails wherever H has a positive
// eigenvalue, a multiple of the identity or a clamp of the positive eigenvalues fails. It admits the
// eigenvalue clamp of H and a clamp of a matrix A that H is a congruence J^T A J of, J onto (the
// membrane clamps d2W/dF2 on the deformation gradient's modes; inertia is preserved by congruence).
// Eigenvalues count as non-zero beyond `tolerance` times the larger of |H| and |P|.
inline ::testing::AssertionResult ProjectionIsPsd(const TermFunction& exact, const TermFunction& projected, const Eigen::VectorXd& q,
                                                  double tolerance = 1e-9) {
  const Eigen::Index n = q.size();
  Eigen::MatrixXd H(n, n), P(n, n);
  exact(q, nullptr, &H);
  projected(q, nullptr, &P);
  const double scale = std::max({H.norm(), P.norm(), 1e-300}), tol = tolerance * scale;
  const Eigen::VectorXd lp = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P, Eigen::EigenvaluesOnly).eigenvalues();
  const Eigen::VectorXd lh = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(H, Eigen::EigenvaluesOnly).eigenvalues();
  const Eigen::VectorXd ld = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P - H, Eigen::EigenvaluesOnly).eigenvalues();
  if (lp.minCoeff() < -tol)
    return ::testing::AssertionFailure() << "projected Hessian has eigenvalue " << lp.minCoeff() << " (scale " << scale << ")";
  if (ld.minCoeff() < -tol)
    return ::testing::AssertionFailure() << "projection removes stiffness: P - H has eigenvalue " << ld.minCoeff() << " (scale " << scale
                                         << ")\n  eigenvalues of H " << lh.transpose() << "\n  eigenvalues of P " << lp.transpose();
  const long negative = (lh.array() < -tol).count(), changed = (ld.array() > tol).count();
  if (changed > negative)
    return ::testing::AssertionFailure() << "projection changes H in " << changed << " directions, H has " << negative
                                         << " negative eigenvalues (scale " << scale << ")\n  eigenvalues of H " << lh.transpose()
                                         << "\n  eigenvalues of P - H " << ld.transpose();
  return ::testing::AssertionSuccess();
}

// The strict form for a projection that clamps the eigenvalues of H itself: P = V max(Lambda, 0) V^T
// with H = V Lambda V^T, to `tolerance` times |H|.
inline ::testing::AssertionResult ProjectionIsEigenvalueClamp(const TermFunction& exact, const TermFunction& projected,
                                                              const Eigen::VectorXd& q, double tolerance = 1e-9) {
  const Eigen::Index n = q.size();
  Eigen::MatrixXd H(n, n), P(n, n);
  exact(q, nullptr, &H);
  projected(q, nullptr, &P);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
  const Eigen::MatrixXd clamped = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
  const double scale = std::max(H.norm(), 1e-300);
  if ((P - clamped).norm() > tolerance * scale)
    return ::testing::AssertionFailure() << "projection differs from the eigenvalue clamp of H by " << (P - clamped).norm() << " (scale "
                                         << scale << ")\n  eigenvalues of H " << eig.eigenvalues().transpose();
  return ::testing::AssertionSuccess();
}

}  // namespace kgd::testing
