// The shared finite-difference check catches what it is for: a wrong gradient, a wrong or asymmetric
// Hessian, and a projection that is not PSD or that changes an already PSD Hessian.
#include "core/sim/finite_difference_check.h"

#include <gtest/gtest.h>

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

TEST(FiniteDifferenceCheck, ProjectionMustBePsdAndLeavePsdHessiansAlone) {
  Eigen::MatrixXd indefinite(2, 2), psd(2, 2), changed(2, 2);
  indefinite << 1, 0, 0, -1;
  psd << 1, 0, 0, 0;
  changed << 2, 0, 0, 1;
  const Eigen::VectorXd b = Eigen::Vector2d::Zero(), q = Eigen::Vector2d(1, 1);
  // An indefinite Hessian clamped to PSD passes; left indefinite it fails.
  EXPECT_TRUE(testing::ProjectionIsPsd(Quadratic(indefinite, b), Quadratic(psd, b), q));
  EXPECT_FALSE(testing::ProjectionIsPsd(Quadratic(indefinite, b), Quadratic(indefinite, b), q));
  // A PSD Hessian must come back unchanged.
  Eigen::MatrixXd spd(2, 2);
  spd << 1, 0, 0, 1;
  EXPECT_TRUE(testing::ProjectionIsPsd(Quadratic(spd, b), Quadratic(spd, b), q));
  EXPECT_FALSE(testing::ProjectionIsPsd(Quadratic(spd, b), Quadratic(changed, b), q));
}

}  // namespace
}  // namespace kgd
