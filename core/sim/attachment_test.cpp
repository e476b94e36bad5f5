// Attachments: the closed form of the energy, and the gradient and Hessian of the garment system's
// attachment term against central differences, at rest on the anchor and pulled off it in any direction.
#include "core/sim/attachment.h"

#include <gtest/gtest.h>

#include <random>

#include "core/testing/finite_difference_check.h"
#include "core/sim/membrane.h"
#include "core/sim/garment_system.h"
#include "core/testing/term_test_support.h"

namespace kgd {
namespace {

// Two attached faces, so the per-face stiffness is k / 2.
Attachments TwoFaces() {
  Attachments a;
  a.faces = {4, 9};
  a.anchors.resize(2, 3);
  a.anchors << 0.01, 0.02, -0.005, 0.0, -0.01, 0.03;
  a.stiffness_N_per_m = 3000;
  return a;
}

// The garment system's attachment term (MakeAttachmentTerm) on a model with ten faces, `a` attached.
struct SystemTerm : testing::TermContextStorage {
  std::unique_ptr<EnergyTerm> term;

  explicit SystemTerm(const Attachments& a) {
    model.faces.resize(10, 3);
    model.effects.attachments = true;
    model.attachments = a;
    term = MakeAttachmentTerm(Context());
  }
  // Face f as a term on its three vertices' coordinates: the energy, gradient and Hessian the system
  // assembles.
  testing::TermFunction Face(int f) {
    return [this, f](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
      Positions x(3, 3);
      for (int v = 0; v < 3; ++v) x.row(v) = q.segment<3>(3 * v).transpose();
      const int v[3] = {0, 1, 2};
      Vector9d g9 = Vector9d::Zero();
      Matrix9d H9 = Matrix9d::Zero();
      const ElementEnergy e = term->Evaluate(f, v, x, g ? g9.data() : nullptr, H ? H9.data() : nullptr);
      EXPECT_TRUE(e.derivatives) << "attached face " << f;
      if (g) *g = g9;
      if (H) *H = H9;
      return e.energy_J;
    };
  }
};

TEST(Attachment, EnergyIsThePerFaceSpringOnTheCentroid) {
  const Attachments a = TwoFaces();
  EXPECT_DOUBLE_EQ(AttachmentFaceStiffness(a), 1500.0);
  const Eigen::Vector3d anchor = a.anchors.row(1).transpose(), offset(0.002, -0.001, 0.0005);
  // A triangle whose centroid sits `offset` from the anchor: E = k_f |offset|^2.
  const Eigen::Vector3d x0 = anchor + offset + Eigen::Vector3d(0.01, 0, 0), x1 = anchor + offset + Eigen::Vector3d(-0.005, 0.008, 0),
                        x2 = anchor + offset + Eigen::Vector3d(-0.005, -0.008, 0);
  EXPECT_NEAR(EvaluateAttachmentFace(a, 1, x0, x1, x2, nullptr), 1500.0 * offset.squaredNorm(), 1e-15);
  // On the anchor: no energy, no force.
  Eigen::Matrix<double, 9, 1> g;
  EXPECT_NEAR(EvaluateAttachmentFace(a, 1, x0 - offset, x1 - offset, x2 - offset, &g), 0.0, 1e-18);
  EXPECT_LT(g.norm(), 1e-12);
  // No attached faces: no stiffness.
  EXPECT_EQ(AttachmentFaceStiffness(Attachments{}), 0.0);
}

// The system's term: its energy is EvaluateAttachmentFace's, its gradient and its (constant, PSD)
// Hessian match central differences, and it leaves the exact Hessian as it is (its own projection).
TEST(Attachment, SystemTermMatchesFiniteDifferences) {
  const Attachments a = TwoFaces();
  SystemTerm system(a);
  ASSERT_TRUE(system.term);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.01, 0.01);
  for (int i = 0; i < 2; ++i) {
    // On the anchor (the quadratic's minimum) and pulled off it by up to a centimetre.
    for (double pull : {0.0, 0.3, 1.0}) {
      Eigen::VectorXd q(9);
      for (int v = 0; v < 3; ++v)
        q.segment<3>(3 * v) = a.anchors.row(i).transpose() + Eigen::Vector3d(u(rng), u(rng), u(rng)) * (v == 0 ? 1.0 : pull);
      SCOPED_TRACE("face " + std::to_string(i) + " pull " + std::to_string(pull));
      const testing::TermFunction term = system.Face(a.faces[i]);
      EXPECT_EQ(term(q, nullptr, nullptr), EvaluateAttachmentFace(a, i, q.segment<3>(0), q.segment<3>(3), q.segment<3>(6), nullptr));
      EXPECT_TRUE(testing::MatchesFiniteDifferences(term, q, {.step = 1e-6, .tolerance = 1e-6, .gradient_floor = 1e-3, .hessian_floor = 1.0}));
      EXPECT_TRUE(testing::ProjectionIsPsd(testing::WithFiniteDifferenceHessian(term, 1e-6), term, q, 1e-6));
    }
  }
  // A face that is not attached adds nothing.
  Positions x = Positions::Zero(3, 3);
  const int v[3] = {0, 1, 2};
  const ElementEnergy free_face = system.term->Evaluate(5, v, x, nullptr, nullptr);
  EXPECT_EQ(free_face.energy_J, 0.0);
  EXPECT_FALSE(free_face.derivatives);
}

}  // namespace
}  // namespace kgd
