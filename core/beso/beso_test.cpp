// Every BESO step against small hand-computed cases.
#include "core/beso/beso.h"

#include <gtest/gtest.h>

#include <limits>

#include "core/sim/garment_system.h"

namespace kgd {
namespace {

using D = std::vector<uint8_t>;

TEST(Beso, SensitivitiesUseTheTwoMaterialFormula) {
  // The paper's materials: 1/2 (1 - 0.5/5.7) = 0.456140 for reinforced; for cloth
  // 1/2 0.001^0.6 (5.2e6) / (0.001^1.6 5.7e6 + (1 - 0.001^1.6) 0.5e6) = 0.0824009 (the reference notes
  // give these without the 1/2: 0.9123 and 0.16480).
  const Eigen::VectorXd w = Eigen::VectorXd::Constant(2, 1000.0);
  const Eigen::VectorXd s = Sensitivities(w, D{kReinforced, kCloth}, 5.7e6, 0.5e6, 0.001, 1.6);
  EXPECT_NEAR(s[0], 456.140, 1e-3);
  EXPECT_NEAR(s[1], 82.4009, 1e-3);
  // d_min -> 0 is hard-kill: cloth has no sensitivity.
  EXPECT_NEAR(Sensitivities(w, D{kCloth, kCloth}, 5.7e6, 0.5e6, 1e-12, 1.6)[0], 0.0, 1e-3);
}

TEST(Beso, FilterAveragesThroughTheNodesByArea) {
  Faces f(2, 3);
  f << 0, 1, 2, 2, 1, 3;  // two triangles sharing edge 1-2
  const Eigen::Vector2d area(1.0, 3.0), value(1.0, 0.0);
  // Shared nodes: (1*1 + 3*0) / 4 = 0.25; node 0: 1; node 3: 0.
  const Eigen::VectorXd out = FilterSensitivities(value, f, 4, area);
  EXPECT_NEAR(out[0], (1.0 + 0.25 + 0.25) / 3.0, 1e-15);
  EXPECT_NEAR(out[1], (0.0 + 0.25 + 0.25) / 3.0, 1e-15);
  // A constant field stays constant.
  const Eigen::VectorXd c = FilterSensitivities(Eigen::Vector2d(2.0, 2.0), f, 4, area);
  EXPECT_NEAR(c[0], 2.0, 1e-15);
  EXPECT_NEAR(c[1], 2.0, 1e-15);
}

TEST(Beso, AveragingHalvesWithThePreviousIteration) {
  Eigen::VectorXd now(3), before(3);
  now << 2.0, 4.0, 0.0;
  before << 0.0, 2.0, 6.0;
  const Eigen::VectorXd avg = AverageSensitivities(now, before);
  EXPECT_DOUBLE_EQ(avg[0], 1.0);
  EXPECT_DOUBLE_EQ(avg[1], 3.0);
  EXPECT_DOUBLE_EQ(avg[2], 3.0);
  // First update: nothing to average with.
  EXPECT_TRUE(AverageSensitivities(now, Eigen::VectorXd()) == now);
}

TEST(Beso, TargetAreaFollowsTheEvolutionaryRatio) {
  EXPECT_DOUBLE_EQ(NextTargetArea(1.0, 0.15, 0.015), 0.985);
  EXPECT_DOUBLE_EQ(NextTargetArea(0.152, 0.15, 0.015), 0.15);  // never past the final target
  EXPECT_DOUBLE_EQ(NextTargetArea(0.15, 0.15, 0.015), 0.15);
  EXPECT_DOUBLE_EQ(NextTargetArea(0.1, 0.15, 0.015), 0.1015);  // below it: grows back
  // 0.985^k reaches 15 % after 126 steps, as the reference notes count.
  double a = 1.0;
  int k = 0;
  while (a > 0.15) a = NextTargetArea(a, 0.15, 0.015), ++k;
  EXPECT_EQ(k, 126);
}

TEST(Beso, UpdateKeepsTheBestRankedElementsAtTheTargetArea) {
  const Eigen::VectorXd s = (Eigen::VectorXd(5) << 5, 4, 3, 2, 1).finished();
  const Eigen::VectorXd area = Eigen::VectorXd::Ones(5);
  const D full(5, kReinforced);
  EXPECT_EQ(UpdateDesign(s, area, full, 3.0, 10.0), (D{1, 1, 1, 0, 0}));
  EXPECT_EQ(UpdateDesign(s, area, full, 3.4, 10.0), (D{1, 1, 1, 0, 0}));  // within half an element
  EXPECT_EQ(UpdateDesign(s, area, full, 3.6, 10.0), (D{1, 1, 1, 1, 0}));
  // Unequal areas: rank order, not area order.
  const Eigen::VectorXd big = (Eigen::VectorXd(5) << 2, 1, 1, 1, 1).finished();
  EXPECT_EQ(UpdateDesign(s, big, full, 3.0, 10.0), (D{1, 1, 0, 0, 0}));
  // Ties break by index.
  EXPECT_EQ(UpdateDesign(Eigen::VectorXd::Ones(5), area, full, 2.0, 10.0), (D{1, 1, 0, 0, 0}));
}

TEST(Beso, AdmissionLimitBindsAndTheRemovalThresholdAdapts) {
  const Eigen::VectorXd s = (Eigen::VectorXd(5) << 5, 4, 3, 2, 1).finished();
  const Eigen::VectorXd area = Eigen::VectorXd::Ones(5);
  const D design{kCloth, kCloth, kReinforced, kReinforced, kReinforced};
  // Without the limit elements 0 and 1 would be admitted; with AR_max = 1 element only 0 is, and the
  // best of the reinforced ones fill the target.
  EXPECT_EQ(UpdateDesign(s, area, design, 3.0, 10.0), (D{1, 1, 1, 0, 0}));
  EXPECT_EQ(UpdateDesign(s, area, design, 3.0, 1.0), (D{1, 0, 1, 1, 0}));
}

TEST(Beso, LockedElementsStayAndCount) {
  const Eigen::VectorXd s = (Eigen::VectorXd(5) << 5, 4, 3, 2, 1).finished();
  const Eigen::VectorXd area = Eigen::VectorXd::Ones(5);
  const D locked{0, 0, 0, 0, 1};
  EXPECT_EQ(UpdateDesign(s, area, D(5, kReinforced), 3.0, 10.0, &locked), (D{1, 1, 0, 0, 1}));
}

TEST(Beso, ConvergenceNeedsTheTargetAndAFlatObjective) {
  const std::vector<double> e = {1.0, 1.5, 1.6, 1.6001, 1.6002};
  EXPECT_TRUE(BesoConverged(e, true, 1e-3, 2));
  EXPECT_FALSE(BesoConverged(e, true, 1e-3, 3));   // 1.5 -> 1.6 is not flat
  EXPECT_FALSE(BesoConverged(e, false, 1e-3, 2));  // target not reached
  EXPECT_FALSE(BesoConverged({1.0}, true, 1e-3, 2));
}

TEST(Beso, BadSettingsAreNamed) {
  BesoSettings s;
  EXPECT_TRUE(ValidateBesoSettings(s).ok());
  s.budget = 0;
  EXPECT_NE(ValidateBesoSettings(s).message().find("budget"), std::string::npos);
  s = {};
  s.budget = 1.2;
  EXPECT_FALSE(ValidateBesoSettings(s).ok());
  s = {};
  s.evolutionary_ratio = 0;
  EXPECT_NE(ValidateBesoSettings(s).message().find("ER"), std::string::npos);
  s = {};
  s.admission_ratio = -0.1;
  EXPECT_NE(ValidateBesoSettings(s).message().find("AR_max"), std::string::npos);
  s = {};
  s.penalty = 0.9;
  EXPECT_NE(ValidateBesoSettings(s).message().find("penalty (p)"), std::string::npos);
  // Non-finite values (a job submitted through the service can carry any double) and the value as given.
  s = {};
  s.penalty = std::numeric_limits<double>::infinity();
  EXPECT_NE(ValidateBesoSettings(s).message().find("penalty (p) = inf must be finite and >= 1"), std::string::npos)
      << ValidateBesoSettings(s).message();
  s = {};
  s.tau = std::numeric_limits<double>::infinity();
  EXPECT_NE(ValidateBesoSettings(s).message().find("tau = inf"), std::string::npos);
  s = {};
  s.budget = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(ValidateBesoSettings(s).message().find("budget = nan"), std::string::npos);
  s = {};
  s.budget = 1e308;
  EXPECT_NE(ValidateBesoSettings(s).message().find("budget = 1e+308 must be in (0, 1]"), std::string::npos)
      << ValidateBesoSettings(s).message();
}

}  // namespace
}  // namespace kgd
