#include "core/sim/fold_barrier.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <random>
#include "core/testing/finite_difference_check.h"

namespace kgd {
namespace {

// One triangle's fold barrier against normal `n` as a term of its nine coordinates (the exact Hessian,
// or with `project` the projected one).
testing::TermFunction FoldBarrierOf(const Eigen::Vector3d& n, double area, bool project) {
  return [n, area, project](const Eigen::VectorXd& v, Eigen::VectorXd* g, Eigen::MatrixXd* h) {
    Vector9d g9;
    Matrix9d h9;
    const double E =
        EvaluateFoldBarrier(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), n, area, 1.0, g ? &g9 : nullptr, h ? &h9 : nullptr, project);
    if (g) *g = g9;
    if (h) *h = h9;
    return E;
  };
}

TEST(FoldBarrier, FunctionIsC2AtActivationAndInfiniteWhenFolded) {
  const double qh = kFoldBarrierActivation;
  const FoldBarrierValue at = FoldBarrierFunction(qh - 1e-9);
  EXPECT_NEAR(at.b, 0.0, 1e-15);
  EXPECT_NEAR(at.db, 0.0, 1e-8);
  EXPECT_NEAR(at.ddb, 0.0, 1e-6);
  EXPECT_EQ(FoldBarrierFunction(0.5).b, 0.0);
  EXPECT_TRUE(std::isinf(FoldBarrierFunction(0.0).b));
  EXPECT_TRUE(std::isinf(FoldBarrierFunction(-0.2).b));
  for (double q : {1e-4, 0.01, 0.05, 0.099}) {
    const FoldBarrierValue v = FoldBarrierFunction(q), p = FoldBarrierFunction(q + 1e-7), m = FoldBarrierFunction(q - 1e-7);
    EXPECT_GT(v.b, 0);
    EXPECT_LT(v.db, 0);
    EXPECT_GT(v.ddb, 0);
    EXPECT_NEAR(v.db, (p.b - m.b) / 2e-7, 1e-5 * std::abs(v.db) + 1e-9);
    EXPECT_NEAR(v.ddb, (p.db - m.db) / 2e-7, 1e-5 * std::abs(v.ddb) + 1e-7);
  }
}

// Gradient and exact Hessian against central differences, for triangles squeezed or turned into the
// barrier's active range.
TEST(FoldBarrier, GradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, 0.3, 1.0).normalized();
  const double area = 0.5e-4;  // a 1 cm right triangle
  int active = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Vector9d q;
    // A rest-sized triangle in the reference plane, squeezed along one direction or turned about an edge.
    const Eigen::Vector3d a = Eigen::Vector3d(u(rng), u(rng), u(rng)).cross(n).normalized();
    const Eigen::Vector3d b = n.cross(a);
    const double squeeze = 0.005 + 0.1 * std::abs(u(rng));
    const double turn = 1.2 + 0.35 * std::abs(u(rng));
    q.segment<3>(0) = Eigen::Vector3d(0.001 * u(rng), 0.001 * u(rng), 0.001 * u(rng));
    q.segment<3>(3) = q.segment<3>(0) + 0.01 * a;
    const Eigen::Vector3d third = trial % 2 ? Eigen::Vector3d(0.01 * squeeze * b) : Eigen::Vector3d(0.01 * (std::cos(turn) * b + std::sin(turn) * n));
    q.segment<3>(6) = q.segment<3>(0) + third;
    auto term = [&](bool project) { return FoldBarrierOf(n, area, project); };
    const double E = term(false)(q, nullptr, nullptr);
    if (!(E > 0) || !std::isfinite(E)) continue;
    ++active;
    SCOPED_TRACE("trial " + std::to_string(trial));
    EXPECT_TRUE(testing::MatchesFiniteDifferences(term(false), q, {.step = 1e-9, .tolerance = 1e-4, .gradient_floor = 1e-4, .hessian_floor = 1e-2}));
    // The projected Hessian is the Gauss-Newton part b'' grad q grad q^T (scale 1 here): with the
    // gradient g = b' grad q, it is b'' g g^T / b'^2 (PSD, rank one).
    Eigen::MatrixXd P;
    Eigen::VectorXd g;
    term(true)(q, &g, &P);
    const Eigen::Vector3d x0 = q.segment<3>(0), x1 = q.segment<3>(3), x2 = q.segment<3>(6);
    const FoldBarrierValue bq = FoldBarrierFunction((x1 - x0).cross(x2 - x0).dot(n) / (2 * area));
    const Eigen::MatrixXd gauss_newton = (bq.ddb / (bq.db * bq.db)) * g * g.transpose();
    EXPECT_LT((P - gauss_newton).norm(), 1e-9 * gauss_newton.norm());
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P).eigenvalues().minCoeff(), -1e-9 * P.norm());
  }
  EXPECT_GT(active, 15);
}

TEST(FoldBarrier, InactiveForAnUndeformedTriangle) {
  const Eigen::Vector3d n(0, 0, 1);
  Vector9d g;
  EXPECT_EQ(EvaluateFoldBarrier({0, 0, 0}, {0.01, 0, 0}, {0, 0.01, 0}, n, 0.5e-4, 1.0, &g, nullptr, true), 0.0);
  EXPECT_EQ(g.norm(), 0.0);
  EXPECT_TRUE(std::isinf(EvaluateFoldBarrier({0, 0, 0}, {0, 0.01, 0}, {0.01, 0, 0}, n, 0.5e-4, 1.0, nullptr, nullptr, true)));
}

// A 1 cm right triangle (rest area 0.5 cm^2) in the plane normal to n, its third vertex moved towards
// the first edge so that its projected area ratio is q, and rotated by `tilt` about that edge and by
// `spin` in its plane (neither changes q's formula: the tilt is compensated).
Vector9d TriangleWithAreaRatio(double q, double spin, double tilt, const Eigen::Vector3d& n) {
  const Eigen::Vector3d a0 = n.unitOrthogonal(), b0 = n.cross(a0);
  const Eigen::Vector3d a = std::cos(spin) * a0 + std::sin(spin) * b0, b = n.cross(a);
  Vector9d x;
  x.segment<3>(0) = Eigen::Vector3d(0.003, -0.002, 0.001);
  x.segment<3>(3) = x.segment<3>(0) + 0.01 * a;
  // Height h along b tilted by `tilt` towards n: the projected height h cos(tilt) = 0.01 q.
  x.segment<3>(6) = x.segment<3>(0) + 0.004 * a + (0.01 * q / std::cos(tilt)) * (std::cos(tilt) * b + std::sin(tilt) * n);
  return x;
}

// Where the barrier is off (q >= q^: undeformed, stretched, tilted less than the activation angle) the
// energy, gradient and Hessian, exact and projected, are exactly zero, as central differences say; across the activation boundary (q^ within 1e-9 either side, the differences'
// step straddling it) energy, gradient and Hessian go to zero continuously; just inside it the
// derivatives match central differences tightly.
TEST(FoldBarrier, ZeroWhereInactiveAndContinuousAcrossActivation) {
  const Eigen::Vector3d n = Eigen::Vector3d(-0.3, 0.1, 1.0).normalized();
  const double area = 0.5e-4, qh = kFoldBarrierActivation;
  auto term = [&](bool project) { return FoldBarrierOf(n, area, project); };
  auto ratio = [&](const Vector9d& x) {
    return (x.segment<3>(3) - x.segment<3>(0)).cross(x.segment<3>(6) - x.segment<3>(0)).dot(n) / (2 * area);
  };
  // Off: from just past q^ to stretched, in the plane and tilted (by up to 80 degrees, q held).
  for (double q : {qh * (1 + 1e-5), 0.15, 0.5, 1.0, 1.6}) {
    for (auto [spin, tilt] : {std::pair{0.0, 0.0}, {0.9, 0.6}, {2.5, 1.4}}) {
      const Vector9d x = TriangleWithAreaRatio(q, spin, tilt, n);
      SCOPED_TRACE(::testing::Message() << "q " << q << " tilt " << tilt);
      ASSERT_NEAR(ratio(x), q, 1e-9);
      for (bool project : {false, true}) {
        Eigen::VectorXd g;
        Eigen::MatrixXd H;
        EXPECT_EQ(term(project)(x, &g, &H), 0.0);
        EXPECT_EQ(g.norm(), 0.0);
        EXPECT_EQ(H.norm(), 0.0);
      }
      EXPECT_TRUE(testing::MatchesFiniteDifferences(term(false), x, {.step = 1e-9, .tolerance = 1e-5, .gradient_floor = 1e-6, .hessian_floor = 1e-3}));
    }
  }
  // The scale of the barrier's derivatives 1 % inside the boundary: the floors across it.
  Eigen::VectorXd g_in;
  Eigen::MatrixXd H_in;
  term(false)(TriangleWithAreaRatio(0.99 * qh, 0.9, 0.6, n), &g_in, &H_in);
  ASSERT_GT(g_in.norm(), 0);
  for (double q : {qh * (1 - 1e-9), qh, qh * (1 + 1e-9)}) {
    const Vector9d x = TriangleWithAreaRatio(q, 0.9, 0.6, n);
    SCOPED_TRACE(::testing::Message() << "q - q^ = " << q - qh);
    Eigen::VectorXd g;
    Eigen::MatrixXd H;
    EXPECT_LT(term(false)(x, &g, &H), 1e-20);
    EXPECT_LT(g.norm(), 1e-12 * g_in.norm());
    EXPECT_LT(H.norm(), 1e-6 * H_in.norm());
    EXPECT_TRUE(testing::MatchesFiniteDifferences(term(false), x, {.step = 1e-9, .tolerance = 1e-4, .gradient_floor = g_in.norm(), .hessian_floor = H_in.norm()}));
  }
  // Just inside (1e-3 of q^): active, every derivative matching central differences to its own scale.
  const Vector9d x = TriangleWithAreaRatio(qh * (1 - 1e-3), 0.9, 0.6, n);
  EXPECT_GT(term(false)(x, nullptr, nullptr), 0.0);
  EXPECT_TRUE(testing::MatchesFiniteDifferences(term(false), x, {.step = 1e-9, .tolerance = 1e-5}));
}

// Deep in the barrier (|b'| >= kFoldBarrierExactHessianSlope, q below 1e-4) the projected Hessian is the
// exact one with its negative eigenvalues clamped: the moves that leave q unchanged to first order and
// lower it to second order (turning or collapsing the triangle) cost energy in Newton's model, as they
// do in the energy. Above it, the projected Hessian is the Gauss-Newton part, rank one, blind to them.
TEST(FoldBarrier, DeepInTheBarrierTheProjectedHessianSeesTheTurnsThatLowerQ) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.1, -0.2, 1.0).normalized();
  const double area = 0.5e-4;
  std::mt19937 rng(11);
  std::normal_distribution<double> normal;
  for (double q : {1e-3, 1e-5, 1e-8}) {
    SCOPED_TRACE(::testing::Message() << "q " << q);
    const Vector9d x = TriangleWithAreaRatio(q, 0.7, 1.2, n);
    const bool deep = std::abs(FoldBarrierFunction(q).db) >= kFoldBarrierExactHessianSlope;
    EXPECT_EQ(deep, q < 1e-4);
    Eigen::VectorXd g;
    Eigen::MatrixXd H, P;
    FoldBarrierOf(n, area, false)(x, &g, &H);
    FoldBarrierOf(n, area, true)(x, nullptr, &P);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> exact(H), projected(P), added(P - H);
    EXPECT_GE(projected.eigenvalues().minCoeff(), -1e-9 * P.norm());
    if (!deep) {
      // The Gauss-Newton part b'' grad q grad q^T = b'' g g^T / b'^2.
      const FoldBarrierValue b = FoldBarrierFunction(q);
      EXPECT_LT((P - (b.ddb / (b.db * b.db)) * g * g.transpose()).norm(), 1e-9 * P.norm());
      continue;
    }
    const Eigen::MatrixXd clamped = exact.eigenvectors() * exact.eigenvalues().cwiseMax(0.0).asDiagonal() * exact.eigenvectors().transpose();
    EXPECT_LT((P - clamped).norm(), 1e-9 * P.norm());
    EXPECT_GE(added.eigenvalues().minCoeff(), -1e-9 * P.norm()) << "the projection only adds stiffness";
    // Random moves with grad q . d = 0 along which the energy curves upwards (q falls to second order).
    const Eigen::VectorXd grad_q = g.normalized();
    int turns = 0;
    for (int k = 0; k < 50; ++k) {
      Eigen::VectorXd d(9);
      for (int i = 0; i < 9; ++i) d[i] = normal(rng);
      d -= grad_q.dot(d) * grad_q;
      const double curvature = d.dot(H * d);
      if (!(curvature > 0)) continue;
      ++turns;
      EXPECT_GE(d.dot(P * d), curvature * (1 - 1e-6));
    }
    EXPECT_GT(turns, 5);
  }
}

}  // namespace
}  // namespace kgd
