#include "core/sim/membrane.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>
#include "core/testing/finite_difference_check.h"

namespace kgd {
namespace {

struct Triangle {
  Eigen::Vector3d x[3];
};

// A rest triangle and a deformed one with prescribed principal stretches (s1 along the first rest edge
// direction rotated by `angle`), then rigidly rotated in 3D and slightly perturbed.
Triangle Deformed(const MembraneElement& el, const Eigen::Vector3d rest[3], double s1, double s2, double angle,
                  std::mt19937& rng) {
  Eigen::Matrix2d V;
  V << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  const Eigen::Matrix2d S = Eigen::Vector2d(s1, s2).asDiagonal();
  Eigen::Matrix<double, 3, 2> U;
  std::normal_distribution<double> n(0, 1);
  Eigen::Matrix3d R = Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
  U = R.leftCols<2>();
  const Eigen::Matrix<double, 3, 2> F = U * S * V.transpose();
  // Positions with F = Ds Dm^-1: Ds = F Dm.
  const Eigen::Matrix2d Dm = el.dm_inv.inverse();
  const Eigen::Matrix<double, 3, 2> Ds = F * Dm;
  Triangle t;
  t.x[0] = Eigen::Vector3d(0.01, -0.02, 0.03);
  t.x[1] = t.x[0] + Ds.col(0);
  t.x[2] = t.x[0] + Ds.col(1);
  return t;
}

Vector9d Flatten(const Triangle& t) {
  Vector9d q;
  for (int a = 0; a < 3; ++a) q.segment<3>(3 * a) = t.x[a];
  return q;
}

class MembraneFD : public ::testing::TestWithParam<std::tuple<Relaxation, LameConversion>> {};

// Central differences of the energy (gradient) and of the analytic gradient (Hessian) in every regime.
TEST_P(MembraneFD, GradientAndHessianMatchFiniteDifferences) {
  const auto [relax, conv] = GetParam();
  const Lame lame = LameParameters(ReinforcedMaterial(), conv);
  const double thick = 0.35e-3;
  const Eigen::Vector3d rest[3] = {{0, 0, 0}, {0.005, 0.0005, 0.0002}, {0.0015, 0.0045, -0.0003}};
  const MembraneElement el = MakeMembraneElement(rest[0], rest[1], rest[2]);
  std::mt19937 rng(7);
  struct Case { double s1, s2; MembraneRegime expect; };
  std::vector<Case> cases;
  if (relax == Relaxation::kNone) {
    cases = {{1.1, 1.3, MembraneRegime::kTaut}, {0.7, 1.2, MembraneRegime::kTaut}, {0.8, 0.9, MembraneRegime::kTaut},
             {1.05, 1.05 + 1e-9, MembraneRegime::kTaut}};
  } else {
    const double r = relax == Relaxation::kExact ? FreeContractionStretch(1.3, lame) : 1.0 / std::sqrt(1.3);
    cases = {{1.1, 1.3, MembraneRegime::kTaut},      {r + 0.02, 1.3, MembraneRegime::kTaut},
             {r - 0.05, 1.3, MembraneRegime::kWrinkled}, {0.5, 1.15, MembraneRegime::kWrinkled},
             {0.05, 1.2, MembraneRegime::kWrinkled}, {0.7, 0.9, MembraneRegime::kSlack},
             {0.95, 0.98, MembraneRegime::kSlack}};
  }
  for (const Case& c : cases) {
    for (double angle : {0.0, 0.7}) {
      SCOPED_TRACE("s1=" + std::to_string(c.s1) + " s2=" + std::to_string(c.s2) + " angle=" + std::to_string(angle));
      const Triangle t = Deformed(el, rest, c.s1, c.s2, angle, rng);
      EXPECT_EQ(EvaluateMembraneElement(el, t.x[0], t.x[1], t.x[2], lame, thick, relax, nullptr, nullptr, false).regime, c.expect);
      auto term = [&](bool project) -> testing::TermFunction {
        return [&, project](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
          Vector9d g9;
          Matrix9d H9;
          const double E = EvaluateMembraneElement(el, q.segment<3>(0), q.segment<3>(3), q.segment<3>(6), lame, thick, relax,
                                                   g ? &g9 : nullptr, H ? &H9 : nullptr, project)
                               .energy_J;
          if (g) *g = g9;
          if (H) *H = H9;
          return E;
        };
      };
      const Eigen::VectorXd q = Flatten(t);
      // Steps relative to the element size; scale floors for the slack regime, where both vanish.
      EXPECT_TRUE(testing::MatchesFiniteDifferences(term(false), q,
                                                    {.step = 1e-7 * 0.005,
                                                     .tolerance = 1e-5,
                                                     .gradient_floor = 1e-3 * lame.mu_Pa * thick * 0.005,
                                                     .hessian_floor = 1e-3 * lame.mu_Pa * thick}));
      // The projected Hessian is PSD and equals the exact one where that is already PSD.
      EXPECT_TRUE(testing::ProjectionIsPsd(term(false), term(true), q));
    }
  }
}

std::string VariantName(const ::testing::TestParamInfo<MembraneFD::ParamType>& info) {
  const Relaxation r = std::get<0>(info.param);
  const LameConversion c = std::get<1>(info.param);
  return std::string(r == Relaxation::kExact ? "Exact" : r == Relaxation::kAuthors ? "Authors" : "None") +
         (c == LameConversion::kSolid3D ? "_Solid3D" : "_PlaneStress");
}

INSTANTIATE_TEST_SUITE_P(AllVariants, MembraneFD,
                         ::testing::Combine(::testing::Values(Relaxation::kExact, Relaxation::kAuthors, Relaxation::kNone),
                                            ::testing::Values(LameConversion::kSolid3D, LameConversion::kPlaneStress)),
                         VariantName);

TEST(Membrane, RestStateHasZeroEnergyAndForce) {
  const Eigen::Vector3d x0(0, 0, 0), x1(0.004, 0.001, 0), x2(0.001, 0.003, 0.001);
  const MembraneElement el = MakeMembraneElement(x0, x1, x2);
  for (Relaxation r : {Relaxation::kExact, Relaxation::kAuthors, Relaxation::kNone}) {
    Vector9d g;
    const auto ev = EvaluateMembraneElement(el, x0, x1, x2, LameParameters(ClothMaterial(), LameConversion::kSolid3D),
                                            0.27e-3, r, &g, nullptr, false);
    EXPECT_NEAR(ev.energy_J, 0.0, 1e-18);
    EXPECT_LT(g.norm(), 1e-12);
  }
  EXPECT_NEAR(el.rest_area_m2, 0.5 * (x1 - x0).cross(x2 - x0).norm(), 1e-18);
}

TEST(Membrane, FreeContractionStretchSolvesTheLateralEquilibrium) {
  for (LameConversion conv : {LameConversion::kSolid3D, LameConversion::kPlaneStress}) {
    const Lame l = LameParameters(ClothMaterial(), conv);
    for (double s2 : {1.0, 1.05, 1.1, 1.3, 2.0}) {
      const double r = FreeContractionStretch(s2, l);
      const StretchEnergy e = EnergyOfStretches(r, s2, l, Relaxation::kNone);
      EXPECT_NEAR(e.W1, 0.0, 1e-9 * l.mu_Pa) << s2;
      EXPECT_LE(r, 1.0);
    }
    // Small-strain limit: r ~ 1 - nu_eff * eps with nu_eff = lambda / (lambda + 2 mu).
    const double eps = 1e-5, nu_eff = l.lambda_Pa / (l.lambda_Pa + 2 * l.mu_Pa);
    EXPECT_NEAR((1.0 - FreeContractionStretch(1.0 + eps, l)) / eps, nu_eff, 1e-3);
  }
  // The authors' Lame choice gives the documented in-plane Poisson ratio 0.4925 at nu = 0.33.
  const Lame a = LameParameters({1e6, 0.33, 1e-3}, LameConversion::kSolid3D);
  EXPECT_NEAR(a.lambda_Pa / (a.lambda_Pa + 2 * a.mu_Pa), 0.4925, 1e-4);
}

TEST(Membrane, ExactRelaxationIsContinuouslyDifferentiableAcrossRegimes) {
  const Lame l = LameParameters(ClothMaterial(), LameConversion::kSolid3D);
  const double s2 = 1.2, r = FreeContractionStretch(s2, l);
  const StretchEnergy below = EnergyOfStretches(r - 1e-9, s2, l, Relaxation::kExact);
  const StretchEnergy above = EnergyOfStretches(r + 1e-9, s2, l, Relaxation::kExact);
  EXPECT_EQ(below.regime, MembraneRegime::kWrinkled);
  EXPECT_EQ(above.regime, MembraneRegime::kTaut);
  EXPECT_NEAR(below.W, above.W, 1e-6);
  EXPECT_NEAR(below.W1, above.W1, 1e-3);
  EXPECT_NEAR(below.W2, above.W2, 1e-3);
  // Into slackness: W and dW/ds2 vanish as s2 -> 1.
  const StretchEnergy nearly = EnergyOfStretches(0.9, 1.0 + 1e-9, l, Relaxation::kExact);
  EXPECT_NEAR(nearly.W, 0.0, 1e-6);
  EXPECT_NEAR(nearly.W2, 0.0, 1e-2);
  // The exact relaxed energy is the infimum over the compressed stretch: never above plain neo-Hookean.
  for (double s1 : {0.3, 0.6, 0.9, 1.0, 1.1})
    EXPECT_LE(EnergyOfStretches(s1, s2, l, Relaxation::kExact).W, EnergyOfStretches(s1, s2, l, Relaxation::kNone).W + 1e-9);
}

TEST(Membrane, AuthorsVariantHasItsDocumentedGradientJump) {
  const Lame l = LameParameters(ClothMaterial(), LameConversion::kSolid3D);
  const double s2 = 1.2, q = 1.0 / std::sqrt(s2);
  const StretchEnergy below = EnergyOfStretches(q - 1e-9, s2, l, Relaxation::kAuthors);
  const StretchEnergy above = EnergyOfStretches(q + 1e-9, s2, l, Relaxation::kAuthors);
  EXPECT_NEAR(below.W, above.W, 1e-5);               // continuous
  EXPECT_GT(std::abs(above.W1 - below.W1), 1e3);     // but dW/ds1 jumps (Pa)
}

TEST(Membrane, NoRelaxationRejectsCollapsedTriangles) {
  const Eigen::Vector3d x0(0, 0, 0), x1(0.004, 0, 0), x2(0, 0.003, 0);
  const MembraneElement el = MakeMembraneElement(x0, x1, x2);
  const auto ev = EvaluateMembraneElement(el, x0, x1, Eigen::Vector3d(0.002, 0, 0),
                                          LameParameters(ClothMaterial(), LameConversion::kSolid3D), 1e-3,
                                          Relaxation::kNone, nullptr, nullptr, false);
  EXPECT_TRUE(std::isinf(ev.energy_J));
}

}  // namespace
}  // namespace kgd
