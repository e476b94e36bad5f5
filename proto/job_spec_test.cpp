// Job specs validate with messages naming the field, give the same settings as the defaults, carry a
// scene file and its meshes whole, and iterations survive the trip through their messages bit for bit.
#include "proto/job_spec.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "proto/records.h"

namespace kgd {
namespace {

v1::JobSpec Builtin(const std::string& name) {
  v1::JobSpec spec;
  spec.set_builtin_scene(name);
  return spec;
}

TEST(JobSpec, RejectsBadSpecsNamingTheField) {
  auto message = [](const v1::JobSpec& s) { return ValidateJobSpec(s).message(); };
  EXPECT_NE(message(v1::JobSpec()).find("spec.scene"), std::string::npos);
  EXPECT_NE(message(Builtin("elbow")).find("spec.builtin_scene: 'elbow'"), std::string::npos);
  v1::JobSpec s = Builtin("arm_flexion");
  s.mutable_optimizer()->set_budget(1.5);
  EXPECT_NE(message(s).find("spec.optimizer: BESO setting budget"), std::string::npos) << message(s);
  s = Builtin("arm_flexion");
  s.mutable_optimizer()->set_evolutionary_ratio(0);
  EXPECT_NE(message(s).find("evolutionary_ratio"), std::string::npos);
  s = Builtin("arm_flexion");
  s.mutable_optimizer()->set_penalty(0.5);
  EXPECT_NE(message(s).find("penalty"), std::string::npos);
  s = Builtin("arm_flexion");
  s.add_body("height_m=tall");
  EXPECT_NE(message(s).find("spec.body"), std::string::npos);
  s = v1::JobSpec();
  s.mutable_scene_files()->set_scene_json("{\"name\": ");
  EXPECT_NE(message(s).find("spec.scene_files.scene_json"), std::string::npos);
  s.mutable_scene_files()->set_scene_json("{}");
  (*s.mutable_scene_files()->mutable_files())["../etc/passwd"] = "x";
  EXPECT_NE(message(s).find("leaves the scene's folder"), std::string::npos);
  EXPECT_TRUE(ValidateJobSpec(Builtin("sleeve_on_limb")).ok());
}

TEST(JobSpec, UnsetSettingsAreTheDefaultsAndTheSceneBudgetApplies) {
  const BesoSettings defaults;
  Result<BesoSettings> s = SettingsOfJob(v1::OptimizerSettings(), 1.0);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->budget, defaults.budget);
  EXPECT_EQ(s->evolutionary_ratio, defaults.evolutionary_ratio);
  EXPECT_EQ(s->max_iterations, defaults.max_iterations);
  EXPECT_TRUE(s->temporal_averaging);
  EXPECT_EQ(SettingsOfJob(v1::OptimizerSettings(), 0.2)->budget, 0.2);
  v1::OptimizerSettings o;
  o.set_budget(0.3);
  o.set_max_iterations(7);
  o.set_no_temporal_averaging(true);
  EXPECT_EQ(SettingsOfJob(o, 0.2)->budget, 0.3);
  EXPECT_EQ(SettingsOfJob(o, 0.2)->max_iterations, 7);
  EXPECT_FALSE(SettingsOfJob(o, 0.2)->temporal_averaging);
}

TEST(JobSpec, ASceneFileTravelsWithItsMeshes) {
  const std::string dir = (std::filesystem::temp_directory_path() / "kgd_job_spec_test_scene").string();
  std::filesystem::remove_all(dir);
  Result<SceneSpec> original = PullTestScene("line");
  ASSERT_TRUE(original.ok());
  ASSERT_TRUE(ExportScene(*original, dir).ok());
  Result<v1::SceneFiles> files = ReadSceneFiles(dir + "/scene.json");
  ASSERT_TRUE(files.ok()) << files.message();
  EXPECT_GE(files->files_size(), 2);  // the garment mesh and the reinforced faces at least
  v1::JobSpec spec;
  *spec.mutable_scene_files() = *files;
  std::filesystem::remove_all(dir);  // the spec is self-contained
  Result<SceneSpec> scene = SceneOfJob(spec);
  ASSERT_TRUE(scene.ok()) << scene.message();
  EXPECT_TRUE(scene->garment.vertices == original->garment.vertices);
  EXPECT_TRUE(scene->garment.faces == original->garment.faces);
  EXPECT_EQ(scene->design, original->design);
  EXPECT_EQ(JobSceneName(spec), original->name);

  // A bundle missing a mesh names the file, not the temporary folder.
  const std::string first = spec.scene_files().files().begin()->first;
  spec.mutable_scene_files()->mutable_files()->erase(first);
  Result<SceneSpec> broken = SceneOfJob(spec);
  ASSERT_FALSE(broken.ok());
  EXPECT_EQ(broken.message().find("kgd_scene_"), std::string::npos) << broken.message();
  EXPECT_NE(broken.message().find("spec.scene_files"), std::string::npos);
}

TEST(Records, IterationsRoundTripBitForBit) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  BesoSettings settings;
  settings.max_iterations = 2;
  Result<std::vector<BesoIteration>> run = RunBeso(*scene, settings);
  ASSERT_TRUE(run.ok());
  const int faces = scene->garment.faces.rows(), vertices = scene->garment.vertices.rows();
  for (const BesoIteration& it : *run) {
    Result<BesoIteration> back = RecordFromProto(RecordToProto(it), faces, vertices);
    ASSERT_TRUE(back.ok()) << back.message();
    EXPECT_EQ(back->energy_J, it.energy_J);
    EXPECT_EQ(back->density_ratio, it.density_ratio);
    EXPECT_EQ(back->status, it.status);
    EXPECT_EQ(back->design, it.design);
    EXPECT_TRUE(back->positions == it.positions);
    EXPECT_TRUE(back->energy_density_Pa == it.energy_density_Pa);
    EXPECT_TRUE(back->sensitivity == it.sensitivity);
  }
  v1::IterationRecord bad = RecordToProto(run->back());
  bad.mutable_positions()->RemoveLast();
  EXPECT_FALSE(RecordFromProto(bad, faces, vertices).ok());
  bad = RecordToProto(run->back());
  bad.mutable_design()->front() = 7;
  EXPECT_FALSE(RecordFromProto(bad, faces, vertices).ok());
}

}  // namespace
}  // namespace kgd
