#include "core/sim/fold_barrier.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <random>
#include "core/sim/finite_difference_check.h"

namespace kgd {
namespace {

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
    auto term = [&](bool project) -> testing::TermFunction {
      return [&, project](const Eigen::VectorXd& v, Eigen::VectorXd* g, Eigen::MatrixXd* h) {
        Vector9d g9;
        Matrix9d h9;
        const double E = EvaluateFoldBarrier(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), n, area, 1.0, g ? &g9 : nullptr,
                                             h ? &h9 : nullptr, project);
        if (g) *g = g9;
        if (h) *h = h9;
        return E;
      };
    };
    const double E = term(false)(q, nullptr, nullptr);
    if (!(E > 0) || !std::isfinite(E)) continue;
    ++active;
    SCOPED_TRACE("trial " + std::to_string(trial));
    EXPECT_TRUE(testing::MatchesFiniteDifferences(term(false), q, {.step = 1e-9, .tolerance = 1e-4, .gradient_floor = 1e-4, .hessian_floor = 1e-2}));
    Eigen::MatrixXd P;
    term(true)(q, nullptr, &P);
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

}  // namespace
}  // namespace kgd
