// Job specs validate with messages naming the field, give the same settings as the defaults, carry a
// scene file and its meshes whole, and iterations survive the trip through their messages bit for bit.
#include "proto/job_spec.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "proto/records.h"
#include "core/scene/scene_file.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/paper_scenes.h"
#include "core/testing/bodies_test_scene.h"
#include "core/testing/motion_test_scene.h"
#include "core/scene/scene_keys.h"
#include <google/protobuf/struct.pb.h>

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
  // A measurement outside the parametric body's range, refused naming it, the value and the range.
  s = Builtin("knee_flexion");
  s.add_body("height_m=5");
  EXPECT_EQ(message(s), "spec.body: body measurement height_m = 5 is outside [1.2, 2.2]");
  s = Builtin("knee_flexion");
  s.add_body("height_m=1.8");
  EXPECT_TRUE(ValidateJobSpec(s).ok()) << message(s);
  s = v1::JobSpec();
  s.mutable_scene_files();
  EXPECT_NE(message(s).find("spec.scene_files.scene: missing"), std::string::npos) << message(s);
  s.mutable_scene_files()->mutable_scene()->mutable_body()->add_frames("frames/f1.obj");
  EXPECT_NE(message(s).find("spec.scene_files.scene.body.frames: 'frames/f1.obj' is not among the files sent"),
            std::string::npos) << message(s);
  (*s.mutable_scene_files()->mutable_files())["frames/f1.obj"] = "v 0 0 0\n";
  // A scene without a garment, and a garment mesh that is a photo, are refused before any file is parsed.
  EXPECT_EQ(message(s), "spec.scene_files.scene: garment: missing (give garment.rest, or garment.region with body.rest and body.deformed)");
  s.mutable_scene_files()->mutable_scene()->mutable_garment()->set_rest("g.obj");
  (*s.mutable_scene_files()->mutable_files())["g.obj"] = std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16);
  EXPECT_EQ(message(s), "spec.scene_files.scene.garment.rest: g.obj is not an OBJ or PLY mesh (line 1: \"\\x89PNG\" is not text)");
  (*s.mutable_scene_files()->mutable_files())["g.obj"] = "# a garment\nv 0 0 0\n";
  EXPECT_TRUE(ValidateJobSpec(s).ok()) << message(s);
  s.mutable_scene_files()->mutable_scene()->mutable_garment()->mutable_seams()->set_string_value("seams.txt");
  EXPECT_NE(message(s).find("spec.scene_files.scene.garment.seams: 'seams.txt' is not among the files sent"), std::string::npos)
      << message(s);
  (*s.mutable_scene_files()->mutable_files())["seams.txt"] = "0 1\n";
  EXPECT_TRUE(ValidateJobSpec(s).ok()) << message(s);
  v1::SceneMotion* reach = s.mutable_scene_files()->mutable_scene()->add_motions();
  reach->set_deformed("reach.obj");
  EXPECT_NE(message(s).find("spec.scene_files.scene.motions.deformed: 'reach.obj' is not among the files sent"), std::string::npos)
      << message(s);
  (*s.mutable_scene_files()->mutable_files())["reach.obj"] = "v 0 0 0\n";
  reach->add_frames("reach_1.obj");
  EXPECT_NE(message(s).find("spec.scene_files.scene.motions.frames: 'reach_1.obj' is not among the files sent"), std::string::npos)
      << message(s);
  (*s.mutable_scene_files()->mutable_files())["reach_1.obj"] = "v 0 0 0\n";
  EXPECT_TRUE(ValidateJobSpec(s).ok()) << message(s);
  v1::SceneRangeBody* small = s.mutable_scene_files()->mutable_scene()->add_bodies();
  small->set_rest("s/rest.obj");
  EXPECT_NE(message(s).find("spec.scene_files.scene.bodies.rest: 's/rest.obj' is not among the files sent"), std::string::npos)
      << message(s);
  (*s.mutable_scene_files()->mutable_files())["s/rest.obj"] = "v 0 0 0\n";
  small->set_deformed("s/deformed.obj");
  EXPECT_NE(message(s).find("spec.scene_files.scene.bodies.deformed: 's/deformed.obj' is not among the files sent"), std::string::npos)
      << message(s);
  (*s.mutable_scene_files()->mutable_files())["s/deformed.obj"] = "v 0 0 0\n";
  small->add_frames("s/f1.obj");
  EXPECT_NE(message(s).find("spec.scene_files.scene.bodies.frames: 's/f1.obj' is not among the files sent"), std::string::npos)
      << message(s);
  (*s.mutable_scene_files()->mutable_files())["s/f1.obj"] = "v 0 0 0\n";
  EXPECT_TRUE(ValidateJobSpec(s).ok()) << message(s);
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

// The accuracy preset sets the solver tolerance; an explicit grad_tol wins; an unknown preset is refused
// naming it.
TEST(JobSpec, TheQualityPresetSetsTheToleranceUnlessGradTolIsGiven) {
  v1::OptimizerSettings o;
  SolverSettings solver;
  solver.grad_tol = 3e-4;  // the scene's own
  ApplySolverOverrides(o, &solver);
  EXPECT_EQ(solver.grad_tol, 3e-4);
  o.set_quality("precise");
  ASSERT_TRUE(SettingsOfJob(o, 1.0).ok());
  ApplySolverOverrides(o, &solver);
  EXPECT_EQ(solver.grad_tol, 1e-6);
  o.set_quality("draft");
  ApplySolverOverrides(o, &solver);
  EXPECT_EQ(solver.grad_tol, 1e-3);
  o.set_grad_tol(2e-5);
  ApplySolverOverrides(o, &solver);
  EXPECT_EQ(solver.grad_tol, 2e-5);
  o.set_quality("ultra");
  Result<BesoSettings> bad = SettingsOfJob(o, 1.0);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("quality: 'ultra'"), std::string::npos) << bad.message();
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

  // A bundle whose mesh does not parse names the file and line as the scene names them.
  ASSERT_EQ(spec.scene_files().files().count("garment_rest.obj"), 1u);
  (*spec.mutable_scene_files()->mutable_files())["garment_rest.obj"] = "v 0 0 0\nv 1 2 zero\n";
  Result<SceneSpec> broken = SceneOfJob(spec);
  ASSERT_FALSE(broken.ok());
  EXPECT_EQ(broken.message().rfind("spec.scene_files: garment_rest.obj:2: vertex 1: expected three numbers", 0), 0u) << broken.message();
}

// Scene files are the JSON form of kgd.v1.Scene: exported scenes of every kind (a garment of its own
// with clamps, one on a body with contact and attachments, one cut from a body motion with frames)
// and the shipped examples parse into the message, and the message's JSON loads as the same scene.
TEST(SceneSchema, SceneFilesAreTheJsonFormOfTheSceneMessage) {
  const std::filesystem::path tmp = std::filesystem::temp_directory_path() / "kgd_scene_schema_test";
  auto same = [](const SceneSpec& a, const SceneSpec& b) {
    EXPECT_EQ(a.name, b.name);
    EXPECT_TRUE(a.garment.vertices == b.garment.vertices);
    EXPECT_TRUE(a.garment.faces == b.garment.faces);
    EXPECT_TRUE(a.initial == b.initial);
    EXPECT_EQ(a.design, b.design);
    EXPECT_EQ(a.budget, b.budget);
    EXPECT_EQ(a.cloth.youngs_modulus_Pa, b.cloth.youngs_modulus_Pa);
    EXPECT_EQ(a.reinforced.thickness_m, b.reinforced.thickness_m);
    EXPECT_EQ(a.effects.contact, b.effects.contact);
    EXPECT_EQ(a.effects.relaxation, b.effects.relaxation);
    EXPECT_EQ(a.effects.friction, b.effects.friction);
    EXPECT_EQ(a.effects.clamps, b.effects.clamps);
    EXPECT_EQ(a.attachment_faces, b.attachment_faces);
    EXPECT_EQ(a.attachment_stiffness_N_per_m, b.attachment_stiffness_N_per_m);
    EXPECT_EQ(a.contact_stiffness_N_per_m, b.contact_stiffness_N_per_m);
    ASSERT_EQ(a.clamps.size(), b.clamps.size());
    for (size_t i = 0; i < a.clamps.size(); ++i) {
      EXPECT_EQ(a.clamps[i].vertices, b.clamps[i].vertices);
      EXPECT_TRUE(a.clamps[i].displacement_m == b.clamps[i].displacement_m);
    }
    EXPECT_EQ(a.solver.grad_tol, b.solver.grad_tol);
    EXPECT_EQ(a.solver.max_iterations, b.solver.max_iterations);
    EXPECT_EQ(a.body.has_value(), b.body.has_value());
    if (a.body && b.body) {
      EXPECT_TRUE(a.body->vertices == b.body->vertices);
    }
    EXPECT_EQ(a.motion.has_value(), b.motion.has_value());
    if (a.motion && b.motion) {
      EXPECT_EQ(a.motion->frames.size(), b.motion->frames.size());
    }
    ASSERT_EQ(a.motions.size(), b.motions.size());
    for (size_t m = 0; m < a.motions.size(); ++m) {
      EXPECT_EQ(a.motions[m].name, b.motions[m].name);
      EXPECT_EQ(a.motions[m].role, b.motions[m].role);
      EXPECT_EQ(a.motions[m].weight, b.motions[m].weight);
      EXPECT_TRUE(a.motions[m].pose.deformed == b.motions[m].pose.deformed) << a.motions[m].name;
      EXPECT_EQ(a.motions[m].pose.frames.size(), b.motions[m].pose.frames.size()) << a.motions[m].name;
    }
    EXPECT_EQ(a.body_objective, b.body_objective);
    ASSERT_EQ(a.bodies.size(), b.bodies.size());
    for (size_t k = 0; k < a.bodies.size(); ++k) {
      EXPECT_EQ(a.bodies[k].name, b.bodies[k].name);
      EXPECT_EQ(a.bodies[k].weight, b.bodies[k].weight);
      EXPECT_TRUE(a.bodies[k].pose.rest == b.bodies[k].pose.rest) << a.bodies[k].name;
      EXPECT_TRUE(a.bodies[k].pose.deformed == b.bodies[k].pose.deformed) << a.bodies[k].name;
    }
  };
  auto round_trip = [&](const std::string& scene_path) {
    SCOPED_TRACE(scene_path);
    Result<SceneSpec> direct = LoadScene(scene_path);
    ASSERT_TRUE(direct.ok()) << direct.message();
    Result<v1::SceneFiles> files = ReadSceneFiles(scene_path);  // parses the file into kgd.v1.Scene
    ASSERT_TRUE(files.ok()) << files.message();
    v1::JobSpec spec;
    *spec.mutable_scene_files() = *files;
    ASSERT_TRUE(ValidateJobSpec(spec).ok()) << ValidateJobSpec(spec).message();
    Result<SceneSpec> via_message = SceneOfJob(spec);  // loads SceneJson(message)
    ASSERT_TRUE(via_message.ok()) << via_message.message();
    same(*direct, *via_message);
  };
  // three_motion_sleeve: motions with roles, each with its poses, travel to the worker; sleeve_for_bodies:
  // bodies with their poses and the objective. knee_flexion: the paper scene on the parametric body with
  // its motion cut to a quarter of the bend in two frames (posing the body through the whole bend
  // took most of this test's time; the files only carry the poses).
  auto quarter_knee_flexion = []() -> Result<SceneSpec> {
    Result<const ParametricBody*> body = DefaultParametricBody();
    if (!body.ok()) return body.status();
    for (PaperMotion m : PaperMotions())
      if (m.name == "knee_flexion") {
        const JointAngles body_rest = RestAngles();
        for (auto& [joint, angle] : m.pose) {
          const double from = m.rest.count(joint) ? m.rest.at(joint) : body_rest.count(joint) ? body_rest.at(joint) : 0.0;
          angle = from + 0.25 * (angle - from);
        }
        m.frames = 2;
        return PaperScene(**body, m);
      }
    return Status::Error("no knee_flexion");
  };
  for (const char* name : {"pull_test_x", "sleeve_on_limb", "knee_flexion", "three_motion_sleeve", "sleeve_for_bodies"}) {
    std::filesystem::remove_all(tmp);
    Result<SceneSpec> scene = std::string(name) == "three_motion_sleeve" ? ThreeMotionSleeve()
                              : std::string(name) == "sleeve_for_bodies"
                                  ? SleeveForBodies({{"M", 0.04, 1.0}, {"S", 0.036, 1.0}, {"L", 0.044, 0.5}}, BodyObjective::kWorst)
                              : std::string(name) == "knee_flexion" ? quarter_knee_flexion()
                                                                    : BuiltinScene(name);
    ASSERT_TRUE(scene.ok()) << scene.message();
    if (scene->motion) scene->motion->frames.resize(std::min<size_t>(scene->motion->frames.size(), 2));
    for (SceneMotion& m : scene->motions) m.pose.frames.resize(std::min<size_t>(m.pose.frames.size(), 2));
    ASSERT_TRUE(ExportScene(*scene, tmp.string()).ok());
    round_trip((tmp / "scene.json").string());
    if (!scene->bodies.empty()) {
      Result<v1::SceneFiles> files = ReadSceneFiles((tmp / "scene.json").string());
      ASSERT_TRUE(files.ok()) << files.message();
      ASSERT_EQ(files->scene().bodies_size(), 3);
      EXPECT_EQ(files->scene().body_objective(), "worst");
      EXPECT_EQ(files->scene().bodies(2).weight(), 0.5);
      EXPECT_TRUE(files->files().count(files->scene().bodies(1).rest())) << "the bodies' meshes travel with the scene";
    }
    if (!scene->motions.empty()) {
      Result<v1::SceneFiles> files = ReadSceneFiles((tmp / "scene.json").string());
      ASSERT_TRUE(files.ok()) << files.message();
      EXPECT_EQ(files->scene().motions_size(), 3);
      v1::JobSpec spec;
      *spec.mutable_scene_files() = *files;
      Result<SceneSpec> worker = SceneOfJob(spec);
      ASSERT_TRUE(worker.ok()) << worker.message();
      ASSERT_EQ(worker->motions.size(), scene->motions.size());
      for (size_t m = 0; m < scene->motions.size(); ++m) {
        EXPECT_EQ(worker->motions[m].name, scene->motions[m].name);
        EXPECT_EQ(worker->motions[m].weight, scene->motions[m].weight);
        EXPECT_TRUE(worker->motions[m].pose.deformed == scene->motions[m].pose.deformed) << scene->motions[m].name;
      }
    }
  }
  std::filesystem::remove_all(tmp);
  for (const auto& entry : std::filesystem::recursive_directory_iterator(std::string(KGD_SOURCE_DIR) + "/examples"))
    if (entry.path().extension() == ".json") round_trip(entry.path().string());
}

// Every key the loader knows is a field of the message (inline index lists included), and a key the
// schema does not know is refused by both, by name.
TEST(SceneSchema, TheSchemaAndTheLoaderKnowTheSameKeys) {
  const char* own = R"({"name": "n", "description": "d", "budget": 0.2,
    "garment": {"rest": "g.obj", "initial": "i.obj", "design": {"reinforced_faces": [0, 1]}},
    "materials": {"lame": "plane_stress", "cloth": {"youngs_modulus_Pa": 5e5, "poisson_ratio": 0.3, "thickness_m": 3e-4},
                  "reinforced": {"youngs_modulus_Pa": 5e6, "poisson_ratio": 0.3, "thickness_m": 3e-4}},
    "effects": {"membrane": true, "relaxation": "authors", "fold_barrier": false, "contact": "unilateral",
                "friction": 0.1, "attachments": true, "clamps": true},
    "body": {"mesh": "b.obj", "support_scale": 2.5}, "contact": {"stiffness_N_per_m": 4000},
    "attachments": {"faces": "a.txt", "stiffness_N_per_m": 3000},
    "clamps": [{"name": "c", "vertices": {"box_min": [0, 0, 0], "box_max": [1, 1, 1]}, "axes": "z", "displacement_m": [0, 0, 0.01]},
               {"vertices": [3, 4]}],
    "solver": {"method": "lbfgs", "grad_tol": 1e-6, "max_iterations": 50, "reuse_factorization": false, "lbfgs_history": 10,
               "project_contact_crossings": false}})";
  const char* cut = R"({"garment": {"region": [0, 1, 2], "subdivisions": 1, "design": "all_cloth"},
    "body": {"rest": "r.obj", "deformed": "d.obj", "frames": ["f1.obj", "f2.obj"]},
    "motions": [{"name": "flex", "role": "resist", "weight": 1}, {"name": "reach", "role": "allow", "weight": 0,
                 "deformed": "m1/d.obj", "frames": ["m1/f1.obj"]}],
    "bodies": [{"name": "M", "weight": 1}, {"name": "S", "weight": 0.5, "rest": "b1/r.obj", "deformed": "b1/d.obj",
                "frames": ["b1/f1.obj"]}], "body_objective": "worst",
    "attachments": {"body_faces": "ab.txt"}})";
  for (const char* text : {own, cut}) {
    Result<v1::Scene> scene = ParseSceneJson(text, "scene.json");
    ASSERT_TRUE(scene.ok()) << scene.message();
    // Printed back, it holds the same JSON (every set field kept, also those equal to proto defaults).
    EXPECT_EQ(nlohmann::json::parse(SceneJson(*scene)), nlohmann::json::parse(text));
  }
  Result<v1::Scene> unknown = ParseSceneJson(R"({"garment": {"rest": "g.obj", "colour": "red"}})", "scene.json");
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.message().find("scene.json"), std::string::npos) << unknown.message();
  EXPECT_NE(unknown.message().find("colour"), std::string::npos) << unknown.message();
  Result<v1::Scene> wrong_type = ParseSceneJson(R"({"budget": "most"})", "scene.json");
  ASSERT_FALSE(wrong_type.ok());
  EXPECT_NE(wrong_type.message().find("budget"), std::string::npos) << wrong_type.message();
}

// KGD_SCENE_KEYS and the kgd.v1.Scene message hold the same keys: each message reached from Scene is
// a section of the list with exactly its field names, and the list's other sections are the object
// forms of google.protobuf.Value fields (a design, a clamp's box).
TEST(SceneSchema, TheKeyListIsTheMessage) {
  std::set<std::string> reached;
  std::vector<const google::protobuf::Descriptor*> todo = {v1::Scene::descriptor()};
  while (!todo.empty()) {
    const google::protobuf::Descriptor* d = todo.back();
    todo.pop_back();
    if (!reached.insert(d->name()).second) continue;
    std::vector<std::string> fields;
    for (int i = 0; i < d->field_count(); ++i) {
      const google::protobuf::FieldDescriptor* f = d->field(i);
      fields.push_back(f->name());
      if (f->message_type() && f->message_type() != google::protobuf::Value::descriptor()) todo.push_back(f->message_type());
    }
    std::vector<std::string> listed = SceneKeysOf(d->name());
    std::sort(fields.begin(), fields.end());
    std::sort(listed.begin(), listed.end());
    EXPECT_EQ(listed, fields) << "section " << d->name() << ": KGD_SCENE_KEYS and kgd.v1." << d->name() << " differ";
  }
  std::set<std::string> sections;
  for (const SceneKey& k : SceneKeys()) sections.insert(k.section);
  for (const std::string& s : sections) {
    if (reached.count(s)) continue;
    EXPECT_TRUE(s == "SceneDesign" || s == "SceneClampBox") << s << " is not a message of kgd.v1.Scene";
  }
  EXPECT_EQ(sections.size(), reached.size() + 2);
}

// The schema carries every BESO setting; a setting added to the lists without its field fails here.
TEST(JobSpec, EverySettingHasItsFieldInTheSchema) {
  const Status st = CheckSettingsFields();
  EXPECT_TRUE(st.ok()) << st.message();
  // Each value and switch set in a spec arrives in the settings.
  v1::OptimizerSettings o;
  o.set_tau(2e-3);
  o.set_converge_window(7);
  o.set_no_temporal_averaging(true);
  o.set_keep_attachments(true);
  Result<BesoSettings> s = SettingsOfJob(o, 0.3);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->tau, 2e-3);
  EXPECT_EQ(s->converge_window, 7);
  EXPECT_EQ(s->budget, 0.3);
  EXPECT_FALSE(s->temporal_averaging);
  EXPECT_TRUE(s->keep_attachments);
  EXPECT_FALSE(s->average_with_raw);
}

// The schema carries every figure of the metric list under its name and type; a metric added to the
// list without its proto field fails here.
TEST(Records, EveryMetricHasItsFieldInTheSchema) {
  const Status st = CheckMetricFields();
  EXPECT_TRUE(st.ok()) << st.message();
  // Every IterationMetrics field is a listed metric, the iteration, the status, the motions, or the
  // report time (the service's own).
  const google::protobuf::Descriptor* d = v1::IterationMetrics::descriptor();
  std::set<std::string> listed = {"iteration", "solve_status", "report_time_s", "motions"};
#define KGD_LIST_METRIC(type, name, what) listed.insert(#name);
  KGD_BESO_METRICS(KGD_LIST_METRIC)
#undef KGD_LIST_METRIC
  for (int i = 0; i < d->field_count(); ++i) EXPECT_TRUE(listed.count(d->field(i)->name())) << d->field(i)->name() << " is not in KGD_BESO_METRICS";
}

TEST(Records, IterationsRoundTripBitForBit) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  BesoSettings settings;
  settings.max_iterations = 2;
  Result<std::vector<BesoIteration>> run = RunBeso(*scene, settings);
  ASSERT_TRUE(run.ok());
  // A second motion, allowed (its figures made up): every motion travels.
  for (BesoIteration& it : *run) {
    ASSERT_EQ(it.motions.size(), 1u);
    MotionMetrics m = it.motions[0];
    m.name = "reach";
    m.role = MotionRole::kAllow;
    m.weight = 0.5;
    m.energy_J = 1.0 / 3.0;
    m.reinforced_energy_J = 1e-17 + it.iteration;
    m.density_ratio = 2.0 / 3.0;
    m.simulation_s = 0.125;
    m.solver_iterations = 9;
    it.motions.push_back(m);
    it.motion_positions = {it.positions * (1.0 / 3.0)};
  }
  const int faces = scene->garment.faces.rows(), vertices = scene->garment.vertices.rows();
  for (const BesoIteration& it : *run) {
    Result<BesoIteration> back = RecordFromProto(RecordToProto(it), faces, vertices);
    ASSERT_TRUE(back.ok()) << back.message();
    EXPECT_EQ(back->iteration, it.iteration);
    EXPECT_EQ(back->status, it.status);
    // Every figure of the metric list, whatever its type.
#define KGD_EXPECT_METRIC(type, name, what) EXPECT_EQ(back->name, it.name) << #name;
    KGD_BESO_METRICS(KGD_EXPECT_METRIC)
#undef KGD_EXPECT_METRIC
    EXPECT_EQ(back->motions, it.motions);
    EXPECT_EQ(back->design, it.design);
    EXPECT_TRUE(back->positions == it.positions);
    EXPECT_TRUE(back->energy_density_Pa == it.energy_density_Pa);
    EXPECT_TRUE(back->sensitivity == it.sensitivity);
    ASSERT_EQ(back->motion_positions.size(), 1u);
    EXPECT_TRUE(back->motion_positions[0] == it.motion_positions[0]);
  }
  v1::IterationRecord bad = RecordToProto(run->back());
  bad.mutable_motion_positions()->RemoveLast();
  EXPECT_NE(RecordFromProto(bad, faces, vertices).message().find("motion_positions has"), std::string::npos);
  bad = RecordToProto(run->back());
  bad.mutable_positions()->RemoveLast();
  EXPECT_FALSE(RecordFromProto(bad, faces, vertices).ok());
  bad = RecordToProto(run->back());
  bad.mutable_design()->front() = 7;
  EXPECT_FALSE(RecordFromProto(bad, faces, vertices).ok());
}

// A job's motions travel with its garment (the worker's start report, from which the service writes
// the design file's /job motions); an unknown role is refused naming the motion.
TEST(Records, TheJobsMotionsTravelWithItsGarment) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  DesignFileHeader h;
  h.garment = scene->garment;
  h.initial = scene->initial;
  h.rest_area_m2 = FaceAreas(scene->garment.vertices, scene->garment.faces);
  h.motions.resize(2);
  h.motions[0].name = "straighten";
  h.motions[1].name = "bend";
  h.motions[1].role = MotionRole::kAllow;
  h.motions[1].weight = 0.0;
  v1::Garment g = GarmentToProto(h);
  DesignFileHeader back;
  ASSERT_TRUE(GarmentFromProto(g, &back).ok());
  EXPECT_EQ(back.motions, h.motions);
  g.mutable_motions(1)->set_role("tolerate");
  const Status st = GarmentFromProto(g, &back);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("motion 'bend': role 'tolerate'"), std::string::npos) << st.message();
}

// The skin pressure of an evaluation's frames (one value per body vertex) survives its message, and
// a frame whose pressure does not match its body is refused by name.
TEST(Records, AnEvaluationsSkinPressureSurvivesItsMessage) {
  DesignEvaluation e;
  e.iteration = 3;
  for (int k = 0; k < 2; ++k) {
    EvaluatedFrame f;
    f.garment = Positions::Random(5, 3);
    f.body = Positions::Random(4, 3);
    f.energy_density_Pa = Eigen::VectorXd::Random(2);
    f.skin_pressure_Pa = Eigen::Vector4d(0, 1234.5 + k, 0, 2.5e3);
    e.frames.push_back(f);
  }
  v1::DesignEvaluation p = EvaluationToProto(e);
  Result<DesignEvaluation> back = EvaluationFromProto(p, 2, 5, 4);
  ASSERT_TRUE(back.ok()) << back.message();
  for (int k = 0; k < 2; ++k) EXPECT_TRUE(back->frames[k].skin_pressure_Pa == e.frames[k].skin_pressure_Pa) << k;
  p.mutable_frames(1)->mutable_skin_pressure_pa()->RemoveLast();
  const Result<DesignEvaluation> bad = EvaluationFromProto(p, 2, 5, 4);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("evaluation frame 2: skin_pressure_Pa has 3 values for 4 body vertices"), std::string::npos) << bad.message();
}

// A spec's motion weights: refused before any scene is built when a weight is below 0 or not finite,
// or a built-in scene lacks the name or has one motion; given to the scene's motions of those names,
// and refused when they leave the first motion at 0. Each message names the motion.
TEST(JobSpec, MotionWeightsReachTheirMotionsOrAreRefusedNamingTheMotion) {
  auto with = [](const std::string& scene, std::map<std::string, double> weights) {
    v1::JobSpec s = Builtin(scene);
    for (const auto& [name, w] : weights) (*s.mutable_optimizer()->mutable_motion_weights())[name] = w;
    return s;
  };
  auto message = [](const v1::JobSpec& s) { return ValidateJobSpec(s).message(); };
  EXPECT_TRUE(ValidateJobSpec(with("knee_brace", {{"flex", 0}, {"hyperextend", 2}})).ok());
  EXPECT_EQ(message(with("knee_brace", {{"flex", -1}})), "spec.optimizer: motion_weights: motion 'flex': weight -1 must be finite and >= 0");
  EXPECT_NE(message(with("knee_brace", {{"flex", std::nan("")}})).find("motion 'flex': weight nan"), std::string::npos);
  EXPECT_EQ(message(with("knee_brace", {{"kick", 1}})),
            "spec.optimizer: motion_weights: motion 'kick': scene 'knee_brace' has no motion of this name (its motions: 'hyperextend', 'flex')");
  EXPECT_NE(message(with("arm_flexion", {{"arm_flexion", 2}})).find("scene 'arm_flexion' has one motion"), std::string::npos);
  // A scene of several bodies weighs them by name as motions.
  EXPECT_TRUE(ValidateJobSpec(with("knee_flexion_sizes", {{"S", 2}, {"L", 0}})).ok());
  EXPECT_EQ(message(with("knee_flexion_sizes", {{"XL", 1}})),
            "spec.optimizer: motion_weights: motion 'XL': scene 'knee_flexion_sizes' has no motion of this name (its motions: 'M', 'S', 'L')");

  // A scene of two motions over one rest pose (no simulation needed to weigh them).
  SceneSpec scene;
  scene.name = "two";
  BodyMotion pose;
  pose.faces = Faces(1, 3);
  pose.faces << 0, 1, 2;
  pose.rest = Positions::Identity(3, 3);
  pose.deformed = 2 * pose.rest;
  scene.motion = pose;
  scene.garment_from_body.resize(3, 3);
  scene.garment_from_body.setIdentity();
  scene.motions = {{.name = "a", .pose = pose}, {.name = "b", .role = MotionRole::kAllow, .pose = pose}};
  ASSERT_TRUE(ValidateSceneMotions(scene).ok()) << ValidateSceneMotions(scene).message();
  auto apply = [&](std::map<std::string, double> weights) {
    SceneSpec s = scene;
    const Status st = ApplyMotionWeights(with("two", weights).optimizer(), &s);
    return std::make_pair(st, s);
  };
  const auto [ok, weighed] = apply({{"b", 0.25}});
  ASSERT_TRUE(ok.ok()) << ok.message();
  EXPECT_EQ(weighed.motions[0].weight, 1.0);
  EXPECT_EQ(weighed.motions[1].weight, 0.25);
  EXPECT_EQ(apply({{"b", -0.5}}).first.message(), "motion_weights: motion 'b': weight -0.5 must be finite and >= 0");
  EXPECT_EQ(apply({{"c", 1}}).first.message(), "motion_weights: motion 'c': scene 'two' has no motion of this name (its motions: 'a', 'b')");
  EXPECT_NE(apply({{"a", 0}}).first.message().find("motion_weights: motion 'a': the first motion is the scene's own and must be resisted with a weight > 0"),
            std::string::npos)
      << apply({{"a", 0}}).first.message();
  SceneSpec one = scene;
  one.motions.clear();
  EXPECT_NE(ApplyMotionWeights(with("two", {{"two", 1}}).optimizer(), &one).message().find("scene 'two' has one motion"), std::string::npos);
  EXPECT_TRUE(ApplyMotionWeights(v1::OptimizerSettings(), &one).ok());

  // A scene of several bodies: the weights reach the bodies; the first keeps a weight > 0.
  Result<SceneSpec> sized = SleeveForBodies({{"M", 0.05, 1}, {"L", 0.055, 1}}, BodyObjective::kWorst);
  ASSERT_TRUE(sized.ok()) << sized.message();
  ASSERT_TRUE(ApplyMotionWeights(with("sleeve_for_bodies", {{"L", 0.5}}).optimizer(), &*sized).ok());
  EXPECT_EQ(sized->bodies[0].weight, 1.0);
  EXPECT_EQ(sized->bodies[1].weight, 0.5);
  const Status first = ApplyMotionWeights(with("sleeve_for_bodies", {{"M", 0}}).optimizer(), &*sized);
  EXPECT_NE(first.message().find("motion_weights: "), std::string::npos) << first.message();
  EXPECT_NE(first.message().find("'M'"), std::string::npos) << first.message();
}

}  // namespace
}  // namespace kgd
