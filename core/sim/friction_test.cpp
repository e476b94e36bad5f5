// Friction: finite-difference checks of the garment system's friction term inside the slip distance,
// at its edge from both sides and far beyond, its exact (PSD) Hessian, and the Coulomb limit (force
// mu lambda once sliding, linear below).
#include "core/sim/friction.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include "core/testing/finite_difference_check.h"
#include "core/sim/garment_system.h"
#include "core/testing/term_test_support.h"

namespace kgd {
namespace {

FrictionVertex Vertex() {
  return LagFriction(Eigen::Vector3d(0.01, -0.02, 0.03), Eigen::Vector3d(0.3, 0.4, 1.2), 0.8, 0.5);
}

// The garment system's friction term (MakeFrictionTerm) on a model of one vertex with lagged data `v`.
struct SystemTerm : testing::TermContextStorage {
  std::unique_ptr<EnergyTerm> term;

  SystemTerm(const FrictionVertex& v, double eps) {
    model.effects.contact = ContactModel::kUnilateral;
    model.effects.friction = 0.5;
    model.friction_slip_m = eps;
    auto friction = std::make_unique<FrictionTerm>(Context());
    friction->SetLagged({v});
    term = std::move(friction);
  }
  // The vertex as a term on its coordinates: the energy, gradient and Hessian the system assembles.
  testing::TermFunction Vertex() {
    return [this](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
      Positions x(1, 3);
      x.row(0) = q.transpose();
      Eigen::Vector3d g3 = Eigen::Vector3d::Zero();
      Eigen::Matrix3d H3 = Eigen::Matrix3d::Zero();
      const ElementEnergy e = term->Evaluate(0, nullptr, x, g ? g3.data() : nullptr, H ? H3.data() : nullptr);
      EXPECT_TRUE(e.derivatives);
      if (g) *g = g3;
      if (H) *H = H3;
      return e.energy_J;
    };
  }
};

// Tangential displacement from the anchor of length y (m) in the direction at `angle` in the tangent
// plane, plus `normal` along the normal.
Eigen::Vector3d Offset(const FrictionVertex& v, double y, double angle, double normal) {
  const Eigen::Vector3d n = v.tangent.col(0).cross(v.tangent.col(1));
  return y * (std::cos(angle) * v.tangent.col(0) + std::sin(angle) * v.tangent.col(1)) + normal * n;
}

// The system's term against central differences: inside the slip distance, within 1e-9 of its edge on
// either side (the differences' step, 1e-9 m, straddles the edge, so a jump in the energy or its
// derivatives there shows), and far beyond; with normal offsets, which friction ignores. Its Hessian
// is the exact one (PSD by construction: no projection).
TEST(Friction, SystemTermMatchesFiniteDifferencesAcrossTheSlipEdge) {
  const FrictionVertex v = Vertex();
  const double eps = 1e-4;
  SystemTerm system(v, eps);
  ASSERT_TRUE(system.term);
  const testing::TermFunction term = system.Vertex();
  struct Point {
    double y, angle, normal;
  };
  for (const Point& p : {Point{3.6e-5, 0.4, 1e-5}, Point{eps * (1 - 1e-9), 1.1, -4e-5}, Point{eps, 2.0, 0.0},
                         Point{eps * (1 + 1e-9), -0.7, 3e-5}, Point{2.2e-3, 2.9, 5e-4}}) {
    const Eigen::Vector3d x = v.anchor + Offset(v, p.y, p.angle, p.normal);
    SCOPED_TRACE("y - eps = " + std::to_string((p.y - eps) / eps) + " eps");
    EXPECT_NEAR((v.tangent.transpose() * (x - v.anchor)).norm(), p.y, 1e-16);
    Eigen::Vector3d g_direct;
    Eigen::Matrix3d H_direct;
    EXPECT_EQ(term(x, nullptr, nullptr), EvaluateFriction(v, x, eps, &g_direct, &H_direct));
    EXPECT_TRUE(testing::MatchesFiniteDifferences(term, x, {.step = 1e-9, .tolerance = 1e-5, .gradient_floor = 1e-3, .hessian_floor = 1.0}));
    EXPECT_TRUE(testing::ProjectionIsPsd(testing::WithFiniteDifferenceHessian(term, 1e-9), term, x, 1e-5));
  }
  // At the edge the force has reached the Coulomb limit and the stiffness along the slip has gone.
  const double limit = 0.5 * 0.8;
  for (double y : {eps * (1 - 1e-9), eps, eps * (1 + 1e-9)}) {
    Eigen::VectorXd g;
    Eigen::MatrixXd H;
    const Eigen::Vector3d d = Offset(v, y, 0.3, 0.0);
    term(v.anchor + d, &g, &H);
    EXPECT_NEAR(g.norm(), limit, 1e-9 * limit);
    EXPECT_NEAR(d.normalized().dot(H * d.normalized()), 0.0, 1e-8 * limit / eps);
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
