// Attachments: the closed form of the energy, the gradient and the constant Hessian the system
// assembles, against central differences, at rest on the anchor and pulled off it in any direction.
#include "core/sim/attachment.h"

#include <gtest/gtest.h>

#include <random>

#include "core/sim/finite_difference_check.h"

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

// The attachment of face i as a term on its 9 coordinates, with the Hessian the garment system adds:
// (2 k_f / 9) on the diagonal of every 3x3 block.
testing::TermFunction Term(const Attachments& a, int i) {
  return [&a, i](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
    Eigen::Matrix<double, 9, 1> g9;
    const double E = EvaluateAttachmentFace(a, i, q.segment<3>(0), q.segment<3>(3), q.segment<3>(6), g ? &g9 : nullptr);
    if (g) *g = g9;
    if (H) {
      H->setZero(9, 9);
      const double c = 2.0 * AttachmentFaceStiffness(a) / 9.0;
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) H->block<3, 3>(3 * r, 3 * s).diagonal().array() += c;
    }
    return E;
  };
}

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

TEST(Attachment, GradientAndHessianMatchFiniteDifferences) {
  const Attachments a = TwoFaces();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.01, 0.01);
  for (int i = 0; i < 2; ++i) {
    // On the anchor (the quadratic's minimum) and pulled off it by up to a centimetre.
    for (double pull : {0.0, 0.3, 1.0}) {
      Eigen::VectorXd q(9);
      for (int v = 0; v < 3; ++v)
        q.segment<3>(3 * v) = a.anchors.row(i).transpose() + Eigen::Vector3d(u(rng), u(rng), u(rng)) * (v == 0 ? 1.0 : pull);
      SCOPED_TRACE("face " + std::to_string(i) + " pull " + std::to_string(pull));
      EXPECT_TRUE(testing::MatchesFiniteDifferences(Term(a, i), q, {.step = 1e-6, .tolerance = 1e-6, .gradient_floor = 1e-3, .hessian_floor = 1.0}));
      EXPECT_TRUE(testing::ProjectionIsPsd(Term(a, i), Term(a, i), q));
    }
  }
}

}  // namespace
}  // namespace kgd
