// The BESO loop on the pull test: every design meets its target area, every simulation converges,
// the reinforced energy density rises as material goes, and the run is deterministic.
#include "core/beso/design_loop.h"

#include <gtest/gtest.h>

namespace kgd {
namespace {

TEST(DesignLoop, PullTestDesignsMeetTheirTargetsAndConcentrateEnergy) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  BesoSettings s;
  s.budget = 0.6;
  s.evolutionary_ratio = 0.05;
  s.admission_ratio = 0.05;
  s.max_iterations = 25;
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, s);
  ASSERT_TRUE(run.ok()) << run.message();
  ASSERT_GT(run->size(), 10u);
  const Eigen::VectorXd area = FaceAreas(scene->garment.vertices, scene->garment.faces);
  const double total = area.sum(), largest = area.maxCoeff();
  EXPECT_NEAR((*run)[0].area_fraction, 1.0, 1e-12);
  EXPECT_NEAR((*run)[0].density_ratio, 1.0, 1e-12);
  for (const BesoIteration& it : *run) {
    EXPECT_EQ(it.status, SolveStatus::kConverged) << "iteration " << it.iteration;
    EXPECT_LE(std::abs(it.area_fraction * total - it.target_area_m2), 0.5 * largest + 1e-15) << "iteration " << it.iteration;
  }
  EXPECT_NEAR(run->back().area_fraction, 0.6, 0.5 * largest / total + 1e-12);
  EXPECT_GT(run->back().density_ratio, 1.1);
  // Deterministic: the same job gives the same designs.
  s.max_iterations = 8;
  const Result<std::vector<BesoIteration>> a = RunBeso(*scene, s), b = RunBeso(*scene, s);
  ASSERT_TRUE(a.ok() && b.ok());
  for (size_t k = 0; k < a->size(); ++k) EXPECT_EQ((*a)[k].design, (*b)[k].design) << "iteration " << k;
}

TEST(DesignLoop, BadSettingsAreRefused) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  BesoSettings s;
  s.budget = 1.5;
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, s);
  ASSERT_FALSE(run.ok());
  EXPECT_NE(run.message().find("budget"), std::string::npos);
}

}  // namespace
}  // namespace kgd
