// Accuracy presets and the job cost model.
#include "core/beso/quality.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/sim/simulator.h"

namespace kgd {
namespace {

TEST(Quality, PresetsAreOrderedFromFastToAccurateAndNamed) {
  const std::vector<QualityPreset>& p = QualityPresets();
  ASSERT_EQ(p.size(), 3u);
  EXPECT_STREQ(p[0].name, "draft");
  EXPECT_STREQ(p[1].name, "standard");
  EXPECT_STREQ(p[2].name, "precise");
  EXPECT_GT(p[0].grad_tol, p[1].grad_tol);
  EXPECT_GT(p[1].grad_tol, p[2].grad_tol);
  EXPECT_EQ(PresetOf(Quality::kStandard).grad_tol, SolverSettings().grad_tol);  // standard is the default
  EXPECT_EQ(*QualityFromName("precise"), Quality::kPrecise);
  Result<Quality> bad = QualityFromName("ultra");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("'ultra' is not a preset (one of: draft, standard, precise)"), std::string::npos) << bad.message();
}

// Iterations: the target area shrinks by ER per iteration to the budget, then the window (and two for
// the last update and the objective's settling); time grows with the garment and the preset.
TEST(Quality, PredictedJobsGrowWithGarmentPresetAndBudget) {
  BesoSettings s;
  s.budget = 0.15;
  const JobCostPrediction arm = PredictJobCost({.garment_faces = 13936, .frames = 4}, s);
  EXPECT_EQ(arm.iterations, static_cast<int>(std::ceil(std::log(0.15) / std::log(1 - 0.015))) + 5 + 2);
  EXPECT_NEAR(arm.total_s(), arm.setup_s + arm.iteration0_s + arm.iterations * arm.per_iteration_s, 1e-12);
  const JobCostPrediction knee = PredictJobCost({.garment_faces = 5200, .frames = 4}, s);
  EXPECT_LT(knee.total_s(), arm.total_s());
  double last = 0;
  for (Quality q : {Quality::kDraft, Quality::kStandard, Quality::kPrecise}) {
    const double t = PredictJobCost({.garment_faces = 13936, .frames = 4, .quality = q}, s).total_s();
    EXPECT_GT(t, last);
    last = t;
  }
  s.budget = 0.5;
  EXPECT_LT(PredictJobCost({.garment_faces = 13936, .frames = 4}, s).iterations, arm.iterations);
  s.max_iterations = 10;
  EXPECT_EQ(PredictJobCost({.garment_faces = 13936, .frames = 4}, s).iterations, 10);
}

// While the target shrinks the re-solves stop at resolve_tolerance_factor x the tolerance: a job at the
// default factor is predicted faster per iteration than one at 1, a larger factor no slower.
TEST(Quality, TheResolvesToleranceFactorShortensThePredictedIterations) {
  BesoSettings s;
  const double at_default = PredictJobCost({.garment_faces = 13936, .frames = 4}, s).per_iteration_s;
  s.resolve_tolerance_factor = 1;
  const double at_one = PredictJobCost({.garment_faces = 13936, .frames = 4}, s).per_iteration_s;
  s.resolve_tolerance_factor = 5;
  const double at_five = PredictJobCost({.garment_faces = 13936, .frames = 4}, s).per_iteration_s;
  s.resolve_tolerance_factor = 1000;
  const double at_thousand = PredictJobCost({.garment_faces = 13936, .frames = 4}, s).per_iteration_s;
  EXPECT_LT(at_default, 0.8 * at_one);
  EXPECT_LT(at_five, at_one);
  EXPECT_GT(at_five, at_default);
  EXPECT_EQ(at_thousand, at_default);
}

TEST(Quality, AJobOfSeveralMotionsOrBodiesCostsTheirNumberTimesOnesSolves) {
  BesoSettings s;
  const JobCostPrediction one = PredictJobCost({.garment_faces = 5200, .frames = 4}, s);
  const JobCostPrediction three = PredictJobCost({.garment_faces = 5200, .frames = 12, .simulations = 3}, s);
  EXPECT_EQ(three.iterations, one.iterations);
  EXPECT_NEAR(three.iteration0_s, 3 * one.iteration0_s, 1e-12);
  EXPECT_NEAR(three.per_iteration_s, 3 * one.per_iteration_s, 1e-12);
  EXPECT_GT(three.setup_s, one.setup_s);
  // No simulation is no job of zero cost: at least one garment is solved.
  EXPECT_NEAR(PredictJobCost({.garment_faces = 5200, .frames = 4, .simulations = 0}, s).per_iteration_s, one.per_iteration_s, 1e-12);
}

TEST(Quality, TheMachineFactorIsAGeometricMeanOfItsJobsWeightedByTheirSizeAndRecency) {
  MachineFactor f;
  f = LearnMachineFactor(f, 10, 20);
  EXPECT_EQ(f.jobs, 1);
  EXPECT_DOUBLE_EQ(f.factor, 2.0);
  // Ratios 2 (weight 0.9 x 10 s) and 0.5 (10 s): 2^(9/19) 0.5^(10/19) = 2^(-1/19).
  f = LearnMachineFactor(f, 10, 5);
  EXPECT_EQ(f.jobs, 2);
  EXPECT_NEAR(f.factor, std::pow(2.0, -1.0 / 19), 1e-12);
  // After many jobs at 1.6x the factor is 1.6x, whatever came before.
  for (int k = 0; k < 300; ++k) f = LearnMachineFactor(f, 10, 16);
  EXPECT_NEAR(f.factor, 1.6, 1e-9);
  // A tiny job barely moves it.
  EXPECT_NEAR(LearnMachineFactor(f, 0.01, 0.001).factor, 1.6, 0.01);
  // Nonsense leaves it alone; a suspended laptop counts as 20x at most.
  const MachineFactor same = LearnMachineFactor(f, 0, 5);
  EXPECT_EQ(same.jobs, f.jobs);
  EXPECT_EQ(same.factor, f.factor);
  EXPECT_DOUBLE_EQ(LearnMachineFactor({}, 1, 1e6).factor, 20.0);
}

}  // namespace
}  // namespace kgd
