// A design job prepared, interrupted and resumed through the one path that `kgd design` and kgd-worker
// share: the header describes the scene's garment and the spec's settings, a resumed job continues bit
// for bit, and a scene that no longer gives the stored garment is refused with the difference named.
#include "job/design_job.h"
#include "core/beso/design_constraints.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/scene_file.h"
#include "proto/job_spec.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

namespace kgd {
namespace {

v1::OptimizerSettings QuickPullTest() {
  v1::OptimizerSettings o;
  o.set_budget(0.6);
  o.set_evolutionary_ratio(0.05);
  o.set_admission_ratio(0.05);
  o.set_max_iterations(6);
  return o;
}

TEST(DesignJob, NewJobDescribesTheScenesGarmentAndTheSpecsSettings) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  v1::OptimizerSettings o = QuickPullTest();
  o.set_grad_tol(3e-8);
  const Eigen::VectorXd area = FaceAreas(scene->garment.vertices, scene->garment.faces);
  Result<DesignJob> job = NewDesignJob(*scene, o, "pull_test", "a=1 b=2");
  ASSERT_TRUE(job.ok()) << job.message();
  EXPECT_EQ(job->header.scene, "pull_test");
  EXPECT_EQ(job->header.body, "a=1 b=2");
  EXPECT_EQ(job->settings().budget, 0.6);
  EXPECT_EQ(job->settings().max_iterations, 6);
  EXPECT_EQ(job->scene.solver.grad_tol, 3e-8);
  EXPECT_EQ(job->header.garment.faces.rows(), scene->garment.faces.rows());
  EXPECT_DOUBLE_EQ(job->header.rest_area_m2.sum(), area.sum());
  EXPECT_TRUE(job->history.empty());

  o.set_budget(1.5);
  Result<DesignJob> bad = NewDesignJob(*scene, o, "pull_test", "");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("budget"), std::string::npos) << bad.message();
}

TEST(DesignJob, AResumedJobContinuesBitForBit) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  Result<DesignJob> whole = NewDesignJob(*scene, QuickPullTest(), "pull_test", "");
  ASSERT_TRUE(whole.ok());
  const Result<std::vector<BesoIteration>> uninterrupted = RunDesignJob(*whole, {});
  ASSERT_TRUE(uninterrupted.ok()) << uninterrupted.message();
  ASSERT_EQ(uninterrupted->size(), 7u);

  // Stopped after iteration 3, then resumed from the header and the stored history (metrics of 0..3,
  // arrays of 3), as a design file or the server's checkpoint gives them.
  Result<std::vector<BesoIteration>> first = RunDesignJob(*whole, [](const BesoIteration& it) { return it.iteration < 3; });
  ASSERT_TRUE(first.ok());
  ASSERT_EQ(first->size(), 4u);
  std::vector<BesoIteration> history = *first;
  for (size_t k = 0; k + 1 < history.size(); ++k) {
    history[k].design.clear();
    history[k].positions.resize(0, 3);
    history[k].energy_density_Pa.resize(0);
    history[k].sensitivity.resize(0);
  }
  Result<DesignJob> resumed = ResumeDesignJob(*scene, whole->header, history, "test.h5");
  ASSERT_TRUE(resumed.ok()) << resumed.message();
  const Result<std::vector<BesoIteration>> rest = RunDesignJob(*resumed, {});
  ASSERT_TRUE(rest.ok()) << rest.message();
  ASSERT_EQ(rest->size(), 3u);
  for (size_t k = 0; k < rest->size(); ++k) {
    const BesoIteration& a = (*rest)[k];
    const BesoIteration& b = (*uninterrupted)[4 + k];
    EXPECT_EQ(a.iteration, b.iteration);
    EXPECT_EQ(a.design, b.design) << "iteration " << a.iteration;
    EXPECT_EQ(a.energy_J, b.energy_J) << "iteration " << a.iteration;
    EXPECT_TRUE(a.positions == b.positions) << "iteration " << a.iteration;
  }
}

TEST(DesignJob, ResumeRefusesASceneThatNoLongerGivesTheStoredGarment) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  Result<DesignJob> job = NewDesignJob(*scene, QuickPullTest(), "pull_test", "");
  ASSERT_TRUE(job.ok());
  SceneSpec moved = *scene;
  moved.garment.vertices(7, 0) += 1e-6;
  Result<DesignJob> r = ResumeDesignJob(moved, job->header, {}, "job.h5");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("job.h5: the scene 'pull_test' no longer gives the garment stored in the file (rest vertex 7 moved)"),
            std::string::npos)
      << r.message();
  // A larger iteration limit is taken; a bad one is named.
  Result<DesignJob> longer = ResumeDesignJob(*scene, job->header, {}, "job.h5", 40);
  ASSERT_TRUE(longer.ok());
  EXPECT_EQ(longer->settings().max_iterations, 40);
}

TEST(DesignJob, IterationsLeftCountsDownToTheBudgetAndTheWindow) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  v1::OptimizerSettings o = QuickPullTest();
  o.set_max_iterations(1000);
  Result<DesignJob> job = NewDesignJob(*scene, o, "pull_test", "");
  ASSERT_TRUE(job.ok());
  const double area = job->header.rest_area_m2.sum();
  BesoIteration at_budget;
  at_budget.iteration = 50;
  at_budget.target_area_m2 = 0.6 * area;
  EXPECT_EQ(IterationsLeft(*job, at_budget), job->settings().converge_window);
  // From full area at ER 5 %: ceil(log 0.6 / log 0.95) = 10 steps, then the window.
  BesoIteration full;
  full.target_area_m2 = area;
  full.reinforced_energy_J = 1e-3;
  EXPECT_EQ(IterationsLeft(*job, full), 10 + job->settings().converge_window);
  // A motion with nothing to resist ends the job at iteration 0.
  BesoIteration motionless = full;
  motionless.reinforced_energy_J = 0;
  EXPECT_EQ(IterationsLeft(*job, motionless), 0);
  BesoIteration late;
  late.iteration = 995;
  late.target_area_m2 = area;
  EXPECT_EQ(IterationsLeft(*job, late), 5);
}

}  // namespace
}  // namespace kgd

namespace kgd {
namespace {

// Runs a short design job and returns it with its first and last iterations (arrays on both).
struct ShortRun {
  DesignJob job;
  BesoIteration first, last;
};
ShortRun RunShort(SceneSpec scene, int iterations) {
  v1::OptimizerSettings o;
  o.set_max_iterations(iterations);
  Result<DesignJob> job = NewDesignJob(std::move(scene), o, "test", "");
  EXPECT_TRUE(job.ok()) << job.message();
  ShortRun r{*job, {}, {}};
  Result<std::vector<BesoIteration>> run = RunDesignJob(*job, {});
  EXPECT_TRUE(run.ok()) << run.message();
  r.first = run->front();
  r.last = run->back();
  return r;
}

TEST(DesignJob, TheEvaluationFollowsTheFinalDesignThroughTheMotionAndBesideTheBaselines) {
  Result<SceneSpec> scene = BuiltinScene("arm_flexion");
  ASSERT_TRUE(scene.ok()) << scene.message();
  const ShortRun r = RunShort(*scene, 3);
  Result<DesignEvaluation> e = EvaluateDesign(r.job, r.first, r.last);
  ASSERT_TRUE(e.ok()) << e.message();
  EXPECT_EQ(e->iteration, 3);
  EXPECT_EQ(e->note, "");
  ASSERT_EQ(e->frames.size(), 8u);
  const int nv = static_cast<int>(r.job.header.garment.vertices.rows()), nf = static_cast<int>(r.job.header.garment.faces.rows());
  double previous = 0;
  for (size_t k = 0; k < e->frames.size(); ++k) {
    const EvaluatedFrame& f = e->frames[k];
    EXPECT_EQ(f.garment.rows(), nv);
    EXPECT_EQ(f.energy_density_Pa.size(), nf);
    EXPECT_EQ(f.status, "converged") << "frame " << k + 1;
    EXPECT_TRUE(f.body == r.job.scene.motion->frames[k]) << "frame " << k + 1 << " carries its body";
    EXPECT_GT(f.energy_J, previous) << "a flexing elbow stores more in every frame";
    previous = f.energy_J;
  }
  // The last frame is the deformed pose the loop simulated, reached through the motion instead of from
  // the garment put on in that pose: the frictionless sleeve may settle a few mm further along the limb
  // (sliding costs almost nothing), at the same energy to 1e-4.
  EXPECT_NEAR(e->frames.back().energy_J, r.last.energy_J, 1e-4 * r.last.energy_J);

  ASSERT_EQ(e->baselines.size(), 2u);
  EXPECT_EQ(e->baselines[0].name, "line");
  EXPECT_EQ(e->baselines[1].name, "x");
  for (const EvaluatedBaseline& b : e->baselines) {
    EXPECT_EQ(static_cast<int>(b.design.size()), nf);
    EXPECT_EQ(b.positions.rows(), nv);
    EXPECT_NEAR(b.area_fraction, r.last.area_fraction, 0.01) << b.name << ": the baselines have the design's area";
    EXPECT_DOUBLE_EQ(b.density_ratio, b.reinforced_density_J_per_m2 / r.first.reinforced_density_J_per_m2);
    EXPECT_EQ(b.status, "converged");
  }

  // A resumed job holds iteration 0's metrics only: its energies are simulated again, to the same bands.
  // (The motion's frames, followed above and not needed for the bands, are left out of this evaluation.)
  BesoIteration metrics_only = MetricsOnly(r.first);
  DesignJob without_frames = r.job;
  without_frames.scene.motion->frames.clear();
  Result<DesignEvaluation> resumed = EvaluateDesign(without_frames, metrics_only, r.last);
  ASSERT_TRUE(resumed.ok()) << resumed.message();
  EXPECT_TRUE(resumed->frames.empty());
  ASSERT_EQ(resumed->baselines.size(), 2u);
  EXPECT_EQ(resumed->baselines[0].design, e->baselines[0].design);
  EXPECT_EQ(resumed->baselines[1].design, e->baselines[1].design);
}

TEST(DesignJob, AFlatSceneIsEvaluatedWithoutFramesAndSaysSo) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  const ShortRun r = RunShort(*scene, 2);
  Result<DesignEvaluation> e = EvaluateDesign(r.job, r.first, r.last);
  ASSERT_TRUE(e.ok()) << e.message();
  EXPECT_TRUE(e->frames.empty());
  EXPECT_NE(e->note.find("no motion frames"), std::string::npos) << e->note;
  Result<DesignEvaluation> wrong = EvaluateDesign(r.job, r.last, r.last);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.message().find("not 0"), std::string::npos) << wrong.message();
}

// A scene file's design constraints travel with a job: a symmetric sheet with a kept-out and a
// kept-in face, exported, sent as a job spec and run, gives designs symmetric face for face with the
// kept-out pair cloth and the kept-in pair reinforced in every iteration; a scene whose garment is not
// symmetric about its plane is refused at load, naming faces; the job's `symmetric` field asks for
// the sagittal plane x = 0 on a scene that names none.
TEST(DesignJob, DesignConstraintsTravelWithTheJobAndHoldInEveryIteration) {
  SceneSpec scene = *PullTestScene("all_cloth");
  // Diagonals mirrored about x = 5 cm ("/" left, "\" right): symmetric face for face.
  const int columns = 41;
  for (Eigen::Index f = 0; f + 1 < scene.garment.faces.rows(); f += 2) {
    const int a = scene.garment.faces.row(f).minCoeff(), b = a + 1, c = a + columns, d = c + 1;
    if (scene.garment.vertices(a, 0) + 1e-12 < 0.05) continue;
    scene.garment.faces.row(f) << a, c, b;
    scene.garment.faces.row(f + 1) << b, c, d;
  }
  scene.symmetry = SymmetryPlane{Eigen::Vector3d(0.05, 0, 0), Eigen::Vector3d::UnitX(), 0};
  scene.keep_out_faces = {2 * (40 * 28 + 18)};  // a face near the centre of the sheet
  scene.keep_in_faces = {2 * (40 * 20 + 3)};
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "kgd_design_job_constraints";
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(ExportScene(scene, dir.string()).ok());
  Result<v1::SceneFiles> files = ReadSceneFiles((dir / "scene.json").string());
  ASSERT_TRUE(files.ok()) << files.message();
  v1::JobSpec spec;
  *spec.mutable_scene_files() = *files;
  *spec.mutable_optimizer() = QuickPullTest();
  spec.mutable_optimizer()->set_max_iterations(4);
  Result<SceneSpec> loaded = SceneOfJob(spec);
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  EXPECT_EQ(loaded->keep_out_faces, scene.keep_out_faces);
  EXPECT_EQ(loaded->keep_in_faces, scene.keep_in_faces);
  ASSERT_TRUE(loaded->symmetry.has_value());
  EXPECT_TRUE(loaded->symmetry->point_m == scene.symmetry->point_m);
  Result<MirrorPairing> pairing = PairMirrorFaces(loaded->garment, *loaded->symmetry);
  ASSERT_TRUE(pairing.ok()) << pairing.message();
  Result<DesignJob> job = NewDesignJob(*loaded, spec.optimizer(), "sheet", "");
  ASSERT_TRUE(job.ok()) << job.message();
  Result<std::vector<BesoIteration>> run = RunDesignJob(*job, {});
  ASSERT_TRUE(run.ok()) << run.message();
  ASSERT_EQ(run->size(), 5u);
  for (const BesoIteration& it : *run) {
    SCOPED_TRACE("iteration " + std::to_string(it.iteration));
    for (int f : scene.keep_out_faces) {
      EXPECT_EQ(it.design[f], kCloth);
      EXPECT_EQ(it.design[pairing->mirror[f]], kCloth);
    }
    for (int f : scene.keep_in_faces) {
      EXPECT_EQ(it.design[f], kReinforced);
      EXPECT_EQ(it.design[pairing->mirror[f]], kReinforced);
    }
    for (size_t f = 0; f < it.design.size(); ++f) ASSERT_EQ(it.design[f], it.design[pairing->mirror[f]]) << "face " << f;
  }
  EXPECT_LT(run->back().area_fraction, 0.9);

  // The scene file's plane moved 1 cm off the centre: refused when the scene is loaded, faces named.
  nlohmann::json doc = nlohmann::json::parse(SceneJson(spec.scene_files().scene()));
  doc["garment"]["symmetry"]["point_m"] = {0.06, 0, 0};
  Result<v1::Scene> off = ParseSceneJson(doc.dump(), "scene.json");
  ASSERT_TRUE(off.ok()) << off.message();
  v1::JobSpec off_spec = spec;
  *off_spec.mutable_scene_files()->mutable_scene() = *off;
  Result<SceneSpec> refused = SceneOfJob(off_spec);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("garment.symmetry: the garment is not symmetric"), std::string::npos) << refused.message();
  EXPECT_NE(refused.message().find("faces 0, 1, "), std::string::npos) << refused.message();

  // Without the scene's plane, the job's `symmetric` field asks for the sagittal plane, x = 0.
  doc["garment"].erase("symmetry");
  Result<v1::Scene> plain = ParseSceneJson(doc.dump(), "scene.json");
  ASSERT_TRUE(plain.ok());
  *off_spec.mutable_scene_files()->mutable_scene() = *plain;
  off_spec.mutable_optimizer()->set_symmetric(true);
  Result<SceneSpec> unnamed = SceneOfJob(off_spec);
  ASSERT_TRUE(unnamed.ok()) << unnamed.message();
  Result<DesignJob> sagittal = NewDesignJob(*unnamed, off_spec.optimizer(), "sheet", "");
  ASSERT_TRUE(sagittal.ok()) << sagittal.message();
  EXPECT_TRUE(sagittal->settings().symmetric);
  Result<std::vector<BesoIteration>> none = RunDesignJob(*sagittal, {});
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.message().find("through [0, 0, 0] with normal [1, 0, 0]"), std::string::npos) << none.message();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace kgd
