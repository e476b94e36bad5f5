// BESO acceptance (issue: the design engine, acceptance 2): arm flexion and knee flexion, on the
// built-in parametric body and on ../shared/bodies/makehuman (skipped when absent), run to the end
// with the paper's settings. At the budget the reinforced energy density is at least twice that of
// the fully reinforced garment, and the optimized design stores more energy in its reinforcement than
// a Line and an X of the same area (each simulated the same way). Every design meets its target area.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/beso/baselines.h"
#include "core/beso/design_loop.h"
#include "core/scene/paper_scenes.h"
#include "core/scene/scene.h"
#include "core/scene/scene_file.h"
#include "core/scene/builtin_scenes.h"

namespace kgd {
namespace {

namespace fs = std::filesystem;

struct Job {
  const char* name;
  const char* motion;      // built-in scene, or the makehuman motion folder
  bool makehuman;
  const char* region;      // makehuman garment region
  int subdivisions;        // makehuman: of the region
  double budget;
};

const Job kJobs[] = {
    {"builtin_arm_flexion", "arm_flexion", false, "", 0, 0.15},
    {"builtin_knee_flexion", "knee_flexion", false, "", 0, 0.10},
    {"makehuman_arm_flexion", "arm_flexion", true, "sleeve_arm", 2, 0.15},
    {"makehuman_knee_flexion", "knee_flexion", true, "sleeve_knee", 2, 0.10},
};
void PrintTo(const Job& j, std::ostream* os) { *os << j.name; }

fs::path BodiesDir() { return fs::path(KGD_SOURCE_DIR) / ".." / "shared" / "bodies" / "makehuman"; }

Result<SceneSpec> MakeHumanScene(const Job& j) {
  const fs::path bodies = BodiesDir();
  nlohmann::json scene;
  scene["name"] = std::string("makehuman_") + j.motion;
  scene["body"]["rest"] = (bodies / "rest.obj").string();
  scene["body"]["deformed"] = (bodies / j.motion / "pose.obj").string();
  scene["garment"]["region"] = (bodies / "regions" / (std::string(j.region) + ".faces.txt")).string();
  scene["garment"]["subdivisions"] = j.subdivisions;
  scene["attachments"]["body_faces"] = (bodies / "regions" / (std::string(j.region) + ".attach.txt")).string();
  scene["effects"] = {{"contact", "unilateral"}, {"friction", kPaperSceneFriction}, {"attachments", true}};
  scene["budget"] = j.budget;
  const fs::path dir = fs::temp_directory_path() / "kgd_beso_acceptance" / j.name;
  fs::create_directories(dir);
  std::ofstream(dir / "scene.json") << scene.dump(2);
  return LoadScene((dir / "scene.json").string());
}

class BesoAcceptance : public ::testing::TestWithParam<Job> {};

TEST_P(BesoAcceptance, DoublesTheDensityAndBeatsLineAndX) {
  const Job& j = GetParam();
  if (j.makehuman && !fs::exists(BodiesDir() / "rest.obj"))
    GTEST_SKIP() << "no real bodies at " << BodiesDir().string() << " (../shared/bodies is not part of a clone)";
  Result<SceneSpec> scene = j.makehuman ? MakeHumanScene(j) : BuiltinScene(j.motion);
  ASSERT_TRUE(scene.ok()) << scene.message();
  BesoSettings settings;  // the paper's
  settings.budget = j.budget;
  const Eigen::VectorXd area = FaceAreas(scene->garment.vertices, scene->garment.faces);
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, settings);
  ASSERT_TRUE(run.ok()) << run.message();
  const BesoIteration& last = run->back();
  double peak = 0;
  for (const BesoIteration& it : *run) {
    EXPECT_LE(std::abs(it.area_fraction * area.sum() - it.target_area_m2), 0.5 * area.maxCoeff() + 1e-15) << "iteration " << it.iteration;
    peak = std::max(peak, it.density_ratio);
  }
  std::printf("%s: %ld vertices, %zu iterations, area %.4f, density ratio %.4f (peak %.4f)\n", j.name,
              static_cast<long>(scene->garment.vertices.rows()), run->size(), last.area_fraction, last.density_ratio, peak);
  EXPECT_NEAR(last.area_fraction, j.budget, 0.5 * area.maxCoeff() / area.sum() + 1e-12);
  EXPECT_GE(last.density_ratio, 2.0) << "along the design loop";

  // The final design, Line and X, each put on in the deformed pose the way the fully reinforced garment
  // of iteration 0 was (with friction an equilibrium depends on its path; docs/RESULTS.md).
  const Eigen::VectorXd full_energy = run->front().energy_density_Pa.cwiseProduct(area);
  const Result<BaselineComparison> cmp = CompareWithBaselines(*scene, last.design, full_energy);
  ASSERT_TRUE(cmp.ok()) << cmp.message();
  const double put_on_ratio = cmp->optimized_result.reinforced_density_J_per_m2 / run->front().reinforced_density_J_per_m2;
  std::printf("%s: put on in the pose, density ratio %.4f; reinforced energy optimized %.5g J, line %.5g J, x %.5g J (bands at %.1f deg)\n",
              j.name, put_on_ratio, cmp->optimized_result.reinforced_energy_J, cmp->line_result.reinforced_energy_J,
              cmp->x_result.reinforced_energy_J, cmp->theta0_rad * 180 / M_PI);
  EXPECT_GE(put_on_ratio, 2.0);
  EXPECT_TRUE(cmp->optimized_result.solve.converged() && cmp->line_result.solve.converged() && cmp->x_result.solve.converged());
  EXPECT_GT(cmp->optimized_result.reinforced_energy_J, cmp->line_result.reinforced_energy_J);
  EXPECT_GT(cmp->optimized_result.reinforced_energy_J, cmp->x_result.reinforced_energy_J);
}

INSTANTIATE_TEST_SUITE_P(Jobs, BesoAcceptance, ::testing::ValuesIn(kJobs), [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace kgd
