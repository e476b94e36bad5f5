// Friction: finite-difference checks of gradient and Hessian on both sides of the slip distance, PSD
// Hessians, and the Coulomb limit (force mu lambda once sliding, linear below).
#include "core/sim/friction.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include "core/sim/finite_difference_check.h"

namespace kgd {
namespace {

FrictionVertex Vertex() {
  return LagFriction(Eigen::Vector3d(0.01, -0.02, 0.03), Eigen::Vector3d(0.3, 0.4, 1.2), 0.8, 0.5);
}

TEST(Friction, GradientAndHessianMatchFiniteDifferences) {
  const FrictionVertex v = Vertex();
  const double eps = 1e-4;
  // Inside the slip distance, near its edge, and far beyond (tangential and normal offsets).
  for (const Eigen::Vector3d& d : {Eigen::Vector3d(3e-5, -2e-5, 1e-5), Eigen::Vector3d(7e-5, 6e-5, -4e-5),
                                   Eigen::Vector3d(2e-3, -1e-3, 5e-4)}) {
    const Eigen::Vector3d x = v.anchor + d;
    const testing::TermFunction term = [&](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
      Eigen::Vector3d g3;
      Eigen::Matrix3d H3;
      const double E = EvaluateFriction(v, q, eps, g ? &g3 : nullptr, H ? &H3 : nullptr);
      if (g) *g = g3;
      if (H) *H = H3;
      return E;
    };
    SCOPED_TRACE(d.transpose());
    EXPECT_TRUE(testing::MatchesFiniteDifferences(term, x, {.step = 1e-9, .tolerance = 1e-5, .gradient_floor = 1.0, .hessian_floor = 1.0}));
    // The Hessian is PSD by construction: its own projection.
    EXPECT_TRUE(testing::ProjectionIsPsd(term, term, x));
  }
}

TEST(Friction, CoulombLimitAndNoNormalResistance) {
  const FrictionVertex v = Vertex();
  const double eps = 1e-4, limit = 0.5 * 0.8;
  const Eigen::Vector3d t = v.tangent.col(0);
  Eigen::Vector3d g;
  // Sliding: the force is mu lambda whatever the distance.
  for (double s : {2e-4, 1e-3, 5e-2}) {
    EvaluateFriction(v, v.anchor + s * t, eps, &g, nullptr);
    EXPECT_NEAR(g.norm(), limit, 1e-12);
    EXPECT_NEAR(g.dot(t), limit, 1e-12);
  }
  // Sticking: below eps the force grows from zero.
  EvaluateFriction(v, v.anchor + 1e-6 * t, eps, &g, nullptr);
  EXPECT_NEAR(g.norm(), limit * (2e-6 / eps - 1e-12 / (eps * eps)), 1e-12);
  // Moving along the normal costs nothing (that is the contact penalty's job).
  const Eigen::Vector3d n = v.tangent.col(0).cross(v.tangent.col(1));
  EXPECT_NEAR(EvaluateFriction(v, v.anchor + 1e-3 * n, eps, &g, nullptr), limit * eps / 3, 1e-15);
  EXPECT_NEAR(g.norm(), 0.0, 1e-15);
  // No contact force, no friction.
  EXPECT_EQ(EvaluateFriction(LagFriction(v.anchor, n, 0.0, 0.5), v.anchor + 1e-3 * t, eps, &g, nullptr), 0.0);
}

}  // namespace
}  // namespace kgd
