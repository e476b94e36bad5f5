// The design engine on a real scene, within the suite's time: the first 40 BESO iterations of the
// built-in knee flexion (2,674-vertex sleeve). Every solve converges from the previous design's
// equilibrium, every design meets its target area on the ER schedule, the reinforced energy density
// climbs, and the design at 40 iterations stores more energy in its reinforcement than a Line and an
// X of the same area. (The whole runs to the budget, on all seven scenes and on the MakeHuman bodies,
// are `make acceptance` and scripts/design_study.sh; docs/RESULTS.md.)
#include <gtest/gtest.h>

#include <cstdio>

#include "core/beso/baselines.h"
#include "core/beso/design_loop.h"
#include "core/scene/scene.h"
#include "core/scene/builtin_scenes.h"

namespace kgd {
namespace {

TEST(BesoScene, KneeFlexionFirstFortyIterations) {
  Result<SceneSpec> scene = BuiltinScene("knee_flexion");
  ASSERT_TRUE(scene.ok()) << scene.message();
  BesoSettings settings;  // the paper's
  settings.budget = scene->budget;
  settings.max_iterations = 40;
  const Eigen::VectorXd area = FaceAreas(scene->garment.vertices, scene->garment.faces);
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, settings);
  ASSERT_TRUE(run.ok()) << run.message();
  ASSERT_EQ(run->size(), 41u);
  double target = area.sum();
  for (const BesoIteration& it : *run) {
    if (it.iteration > 0) target *= 1 - settings.evolutionary_ratio;
    EXPECT_NEAR(it.target_area_m2, target, 1e-12 * target) << "iteration " << it.iteration;
    EXPECT_LE(std::abs(it.area_fraction * area.sum() - it.target_area_m2), 0.5 * area.maxCoeff() + 1e-15) << "iteration " << it.iteration;
    EXPECT_EQ(it.status, SolveStatus::kConverged) << "iteration " << it.iteration;
    EXPECT_EQ(it.cold_restart, 0) << "iteration " << it.iteration;
  }
  // Less material, more energy per unit of it; the total energy falls as the garment softens.
  for (size_t k = 10; k < run->size(); k += 10) {
    EXPECT_GT((*run)[k].density_ratio, (*run)[k - 10].density_ratio + 0.05) << "iteration " << k;
    EXPECT_LT((*run)[k].energy_J, (*run)[k - 10].energy_J) << "iteration " << k;
  }
  const BesoIteration& last = run->back();
  std::printf("knee flexion, 40 iterations: area %.4f, density ratio %.4f\n", last.area_fraction, last.density_ratio);
  // 1.734 frictionless on the body of 2026-11-22 (1.576 with friction mu = 0.1, 1.349 before the crease
  // pinch; the full run reaches 3.2x at 10 %, docs/RESULTS.md): a floor well above the 1.0 of a design
  // that concentrates nothing, below the measured value.
  EXPECT_GT(last.density_ratio, 1.3);

  const Result<BaselineComparison> cmp = CompareWithBaselines(*scene, last.design, run->front().energy_density_Pa.cwiseProduct(area));
  ASSERT_TRUE(cmp.ok()) << cmp.message();
  std::printf("reinforced energy: optimized %.5g J, line %.5g J, x %.5g J\n", cmp->optimized_result.reinforced_energy_J,
              cmp->line_result.reinforced_energy_J, cmp->x_result.reinforced_energy_J);
  EXPECT_NEAR(cmp->line_result.reinforced_area_m2, cmp->area_m2, 0.02 * cmp->area_m2);
  EXPECT_NEAR(cmp->x_result.reinforced_area_m2, cmp->area_m2, 0.02 * cmp->area_m2);
  EXPECT_GT(cmp->optimized_result.reinforced_energy_J, cmp->line_result.reinforced_energy_J);
  EXPECT_GT(cmp->optimized_result.reinforced_energy_J, cmp->x_result.reinforced_energy_J);
}

}  // namespace
}  // namespace kgd
