#include "core/sim/contact.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "core/scene/shapes.h"
#include "core/sim/finite_difference_check.h"

namespace kgd {
namespace {

std::shared_ptr<const BodyField> Limb() {
  LimbShape s;
  s.around = 24;
  const TriMesh m = LimbRest(s);
  auto f = BodyField::Build(m.vertices, m.faces);
  EXPECT_TRUE(f.ok()) << f.message();
  return *f;
}

// Penalty gradient and exact Hessian against central differences, inside and outside the body.
TEST(Contact, GradientAndHessianMatchFiniteDifferences) {
  const auto field = Limb();
  const double k = kDefaultContactStiffness;
  for (ContactModel model : {ContactModel::kUnilateral, ContactModel::kBilateral}) {
    for (double radial : {0.037, 0.0395, 0.0415}) {  // inside (Phi < 0) and outside (Phi > 0)
      SCOPED_TRACE(std::to_string(radial));
      const Eigen::Vector3d x(radial * std::cos(0.3), 0.1, radial * std::sin(0.3));
      NeighborCache cache;
      Eigen::Vector3d g;
      Eigen::Matrix3d H;
      const ContactEvaluation ce = EvaluateContactVertex(*field, x, &cache, model, k, &g, &H, false);
      ASSERT_TRUE(ce.supported);
      if (radial < 0.039) {
        EXPECT_LT(ce.phi_m, 0);
      }
      if (radial > 0.041) {
        EXPECT_GT(ce.phi_m, 0);
      }
      const testing::TermFunction term = [&](const Eigen::VectorXd& q, Eigen::VectorXd* gq, Eigen::MatrixXd* Hq) {
        Eigen::Vector3d g3;
        Eigen::Matrix3d H3;
        const double E = EvaluateContactVertex(*field, q, &cache, model, k, gq ? &g3 : nullptr, Hq ? &H3 : nullptr, false).energy_J;
        if (gq) *gq = g3;
        if (Hq) *Hq = H3;
        return E;
      };
      EXPECT_TRUE(testing::MatchesFiniteDifferences(term, x, {.step = 1e-7, .tolerance = 1e-5, .gradient_floor = 1e-3, .hessian_floor = 1.0}));
      if (model == ContactModel::kUnilateral && ce.phi_m > 0) {
        EXPECT_EQ(ce.energy_J, 0.0);
        EXPECT_EQ(g.norm(), 0.0);
      }
    }
  }
}

TEST(Contact, ProjectedHessianIsPositiveSemiDefinite) {
  const auto field = Limb();
  NeighborCache cache;
  Eigen::Matrix3d H;
  const Eigen::Vector3d x(0.036, -0.05, 0.005);
  EvaluateContactVertex(*field, x, &cache, ContactModel::kBilateral, 5000, nullptr, &H, true);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(H);
  EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-9);
}

}  // namespace
}  // namespace kgd
