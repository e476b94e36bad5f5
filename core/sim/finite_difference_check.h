// Finite-difference checks of an energy term's derivatives, for tests: the one helper every term's test
// uses (membrane, fold barrier, attachment, contact, friction, and the assembled system). A term is
// given as a function of its stencil's coordinates q (3 per vertex): its energy and, on request, its
// analytic gradient and Hessian.
//
// MatchesFiniteDifferences compares the gradient with central differences of the energy and the
// Hessian with central differences of the analytic gradient, both relative to the larger of their own
// norm and a floor, and checks the Hessian's symmetry. ProjectionIsPsd checks that a PSD-projected
// Hessian has no negative eigenvalue and equals the exact one where that one is already PSD.
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
  int stride = 1;              // differentiate along every stride-th coordinate only (large systems)
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
  for (Eigen::Index i = 0; i < n; i += std::max(1, o.stride)) {
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

inline ::testing::AssertionResult ProjectionIsPsd(const TermFunction& exact, const TermFunction& projected, const Eigen::VectorXd& q,
                                                  double tolerance = 1e-9) {
  const Eigen::Index n = q.size();
  Eigen::MatrixXd H(n, n), P(n, n);
  exact(q, nullptr, &H);
  projected(q, nullptr, &P);
  const double scale = std::max(H.norm(), 1e-300);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_p(P), eig_h(H);
  if (eig_p.eigenvalues().minCoeff() < -tolerance * scale)
    return ::testing::AssertionFailure() << "projected Hessian has eigenvalue " << eig_p.eigenvalues().minCoeff() << " (scale " << scale << ")";
  if (eig_h.eigenvalues().minCoeff() > tolerance * scale && (P - H).norm() > tolerance * scale)
    return ::testing::AssertionFailure() << "projection changed a Hessian that was already PSD by " << (P - H).norm();
  return ::testing::AssertionSuccess();
}

}  // namespace kgd::testing
