// The shared finite-difference check catches what it is for: a wrong gradient, a wrong or asymmetric
// Hessian, and a projection that is not PSD, removes stiffness, changes a PSD Hessian (one with zero
// modes, as every element's has) or changes more than the negative curvature.
#include "core/testing/finite_difference_check.h"

#include <gtest/gtest.h>

#include <Eigen/QR>

namespace kgd {
namespace {

// E = 1/2 q^T A q + b^T q with symmetric A: gradient A q + b, Hessian A. `wrong` spoils one of them.
testing::TermFunction Quadratic(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, int wrong = 0) {
  return [A, b, wrong](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
    if (g) {
      *g = A * q + b;
      if (wrong == 1) (*g)[1] *= 1.01;
    }
    if (H) {
      *H = A;
      if (wrong == 2) (*H)(0, 0) *= 1.01;
      if (wrong == 3) (*H)(0, 1) += 1e-3;
    }
    return 0.5 * q.dot(A * q) + b.dot(q);
  };
}

TEST(FiniteDifferenceCheck, PassesTheTrueDerivativesAndCatchesWrongOnes) {
  Eigen::MatrixXd A(3, 3);
  A << 4, 1, 0, 1, 3, -1, 0, -1, 2;
  const Eigen::VectorXd b = Eigen::Vector3d(0.5, -1, 2), q = Eigen::Vector3d(0.3, -0.2, 0.7);
  const testing::FiniteDifferenceOptions o{.step = 1e-6, .tolerance = 1e-6};
  EXPECT_TRUE(testing::MatchesFiniteDifferences(Quadratic(A, b), q, o));
  EXPECT_FALSE(testing::MatchesFiniteDifferences(Quadratic(A, b, 1), q, o));
  EXPECT_FALSE(testing::MatchesFiniteDifferences(Quadratic(A, b, 2), q, o));
  EXPECT_FALSE(testing::MatchesFiniteDifferences(Quadratic(A, b, 3), q, o));
}

// A rotation of R^3, so that no test matrix is diagonal in the coordinates.
Eigen::Matrix3d Rotation() {
  Eigen::Matrix3d R = Eigen::Matrix3d::Zero();
  Eigen::HouseholderQR<Eigen::Matrix3d> qr((Eigen::Matrix3d() << 2, 1, 0.5, -1, 3, 0.2, 0.3, -0.4, 1.5).finished());
  R = qr.householderQ();
  return R;
}
Eigen::MatrixXd Rotated(const Eigen::Vector3d& eigenvalues) {
  const Eigen::Matrix3d R = Rotation();
  return R * eigenvalues.asDiagonal() * R.transpose();
}

TEST(FiniteDifferenceCheck, ProjectionMustClampAnIndefiniteHessianAndNothingElse) {
  const Eigen::VectorXd b = Eigen::Vector3d::Zero(), q = Eigen::Vector3d(1, 1, 1);
  // Indefinite with a zero mode (like an element's rigid motions).
  const Eigen::MatrixXd H = Rotated({4, 0, -1});
  const auto exact = Quadratic(H, b);
  // The eigenvalue clamp passes both checks.
  EXPECT_TRUE(testing::ProjectionIsPsd(exact, Quadratic(Rotated({4, 0, 0}), b), q));
  EXPECT_TRUE(testing::ProjectionIsEigenvalueClamp(exact, Quadratic(Rotated({4, 0, 0}), b), q));
  // A clamp of A where H = J^T A J (the membrane's clamp on deformation-gradient modes) passes the
  // clamping check, not the strict one.
  Eigen::Matrix3d J;
  J << 1, 0.4, 0, 0, 1, -0.7, 0.2, 0, 1.3;
  const Eigen::MatrixXd HJ = J.transpose() * Eigen::Vector3d(2, -1, 1).asDiagonal() * J;
  const Eigen::MatrixXd PJ = J.transpose() * Eigen::Vector3d(2, 0, 1).asDiagonal() * J;
  EXPECT_TRUE(testing::ProjectionIsPsd(Quadratic(HJ, b), Quadratic(PJ, b), q));
  EXPECT_FALSE(testing::ProjectionIsEigenvalueClamp(Quadratic(HJ, b), Quadratic(PJ, b), q));
  // Rejected: left indefinite, zero, the identity, a multiple of the clamp, the positive part clamped
  // instead of the negative one, a clamp that also stiffens the zero mode.
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(3, 3), identity = Eigen::MatrixXd::Identity(3, 3);
  for (const Eigen::MatrixXd& P : {H, zero, identity, Eigen::MatrixXd(10 * identity), Eigen::MatrixXd(2 * Rotated({4, 0, 0})),
                                   Rotated({0, 0, -1}), Rotated({4, 1, 0})}) {
    SCOPED_TRACE(::testing::Message() << "projection\n" << P);
    EXPECT_FALSE(testing::ProjectionIsPsd(exact, Quadratic(P, b), q));
    EXPECT_FALSE(testing::ProjectionIsEigenvalueClamp(exact, Quadratic(P, b), q));
  }
}

TEST(FiniteDifferenceCheck, ProjectionMustLeaveAPsdHessianWithZeroModesAlone) {
  const Eigen::VectorXd b = Eigen::Vector3d::Zero(), q = Eigen::Vector3d(1, -1, 2);
  const Eigen::MatrixXd H = Rotated({3, 1, 0});  // PSD, singular
  EXPECT_TRUE(testing::ProjectionIsPsd(Quadratic(H, b), Quadratic(H, b), q));
  EXPECT_TRUE(testing::ProjectionIsEigenvalueClamp(Quadratic(H, b), Quadratic(H, b), q));
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(3, 3), identity = Eigen::MatrixXd::Identity(3, 3);
  for (const Eigen::MatrixXd& P : {zero, identity, Eigen::MatrixXd(0.5 * H), Eigen::MatrixXd(2 * H), Rotated({3, 1, 1e-3})}) {
    SCOPED_TRACE(::testing::Message() << "projection\n" << P);
    EXPECT_FALSE(testing::ProjectionIsPsd(Quadratic(H, b), Quadratic(P, b), q));
    EXPECT_FALSE(testing::ProjectionIsEigenvalueClamp(Quadratic(H, b), Quadratic(P, b), q));
  }
}

// The Hessian by central differences of the gradient is the exact one (a quadratic: to rounding).
TEST(FiniteDifferenceCheck, FiniteDifferenceHessianIsTheExactOne) {
  const Eigen::MatrixXd H = Rotated({4, 0, -1});
  const Eigen::VectorXd b = Eigen::Vector3d(0.5, -1, 2), q = Eigen::Vector3d(0.3, -0.2, 0.7);
  EXPECT_LT((testing::FiniteDifferenceHessian(Quadratic(H, b), q, 1e-4) - H).norm(), 1e-9);
  Eigen::MatrixXd Hq;
  testing::WithFiniteDifferenceHessian(Quadratic(H, b, 2), 1e-4)(q, nullptr, &Hq);
  EXPECT_LT((Hq - H).norm(), 1e-9);  // the analytic Hessian (wrong here) is not used
}

}  // namespace
}  // namespace kgd
