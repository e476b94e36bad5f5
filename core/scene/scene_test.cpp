#include "core/scene/scene.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iterator>
#include <map>

#include "core/beso/design_loop.h"
#include "core/mesh/mesh_io.h"
#include "core/testing/bodies_test_scene.h"
#include "core/testing/motion_test_scene.h"
#include "core/scene/simulate.h"
#include "core/scene/scene_file.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/paper_scenes.h"
#include "core/testing/paper_test_scene.h"

namespace kgd {
namespace {

std::string TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "kgd_scene_test" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

// The scene `base` whose body stays in its rest pose (`moved` = false) or moves rigidly: the deformed
// pose and the one frame are the rest pose rotated by 30 degrees about a skew axis and shifted 0.2 m.
Result<SceneSpec> MotionlessScene(SceneSpec s, bool moved) {
  BodyMotion& m = *s.motion;
  Positions pose = m.rest;
  if (moved) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.52, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    const Eigen::RowVector3d t(0.2, -0.1, 0.05);
    pose = (m.rest * R.transpose()).rowwise() + t;
  }
  m.deformed = pose;
  m.frames = {pose};
  if (Status st = CutGarmentFromMotion(&s); !st.ok()) return st;
  return s;
}

// A garment whose body does not move, or moves rigidly, stores no energy and stays where it starts:
// its rest shape and its start lie on the body's smooth surface alike. (The scenes are the built-in
// ones with their motion cut short to its rest pose, which is all MotionlessScene keeps of it: posing
// the body through the motion's frames was most of this test's time.)
TEST(Scene, AGarmentOnABodyAtRestStoresNothing) {
  for (const std::string name : {"arm_flexion", "knee_flexion", "slouch"}) {
    Result<SceneSpec> builtin = PaperSceneAtRest(name);
    ASSERT_TRUE(builtin.ok()) << builtin.message();
    for (const bool moved : {false, true}) {
      Result<SceneSpec> s = MotionlessScene(*builtin, moved);
      ASSERT_TRUE(s.ok()) << s.message();
      for (const uint8_t material : {kCloth, kReinforced}) {
        SCOPED_TRACE(name + (moved ? " moved rigidly" : " at rest") + (material == kCloth ? ", all cloth" : ", all reinforced"));
        s->design.assign(s->garment.faces.rows(), material);
        Result<SimulationResult> r = SimulateScene(*s);
        ASSERT_TRUE(r.ok()) << r.message();
        EXPECT_TRUE(r->solve.converged()) << r->solve.message;
        EXPECT_LE(std::abs(r->solve.energy_J), 1e-9);
        EXPECT_LE((r->positions - s->initial).rowwise().norm().maxCoeff(), 1e-9);
        EXPECT_GE(r->min_phi_m, -1e-9);
      }
    }
  }
}

TEST(Scene, ExportThenLoadReproducesTheBuiltinResult) {
  for (const std::string name : {"pull_test_x", "sleeve_on_limb"}) {
    auto builtin = BuiltinScene(name);
    ASSERT_TRUE(builtin.ok());
    builtin->solver.grad_tol = 1e-8;  // compare equilibria, not solver stopping points
    builtin->solver.project_contact_crossings = false;  // not the default: the file must carry it
    const std::string dir = TempDir(name);
    ASSERT_TRUE(ExportScene(*builtin, dir).ok());
    auto loaded = LoadScene(dir + "/scene.json");
    ASSERT_TRUE(loaded.ok()) << loaded.message();
    EXPECT_FALSE(loaded->solver.project_contact_crossings);
    EXPECT_EQ(loaded->design, builtin->design);
    EXPECT_EQ(loaded->attachment_faces, builtin->attachment_faces);
    EXPECT_EQ(loaded->clamps.size(), builtin->clamps.size());
    auto a = SimulateScene(*builtin), b = SimulateScene(*loaded);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_TRUE(a->solve.converged());
    // OBJ stores 9 significant digits, so agreement is to that precision, not bitwise.
    EXPECT_NEAR(a->solve.energy_J, b->solve.energy_J, 1e-6 * std::abs(a->solve.energy_J)) << name;
  }
}

// A scene of several motions exports with them (names, roles, weights, each motion's poses) and loads
// back as the same scene, bit for bit: the same motions over the same rest body and garment, and a
// design of a few iterations from the file equals the one from the scene it was exported from.
TEST(Scene, ASceneOfSeveralMotionsExportsAndLoadsAsItself) {
  const Result<SceneSpec> built = ThreeMotionSleeve();
  ASSERT_TRUE(built.ok()) << built.message();
  const SceneSpec& scene = *built;
  const std::string dir = TempDir("three_motions");
  const Status exported = ExportScene(scene, dir);
  ASSERT_TRUE(exported.ok()) << exported.message();
  Result<SceneSpec> loaded = LoadScene(dir + "/scene.json");
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  ASSERT_EQ(loaded->motions.size(), scene.motions.size());
  for (size_t m = 0; m < scene.motions.size(); ++m) {
    const SceneMotion &a = scene.motions[m], &b = loaded->motions[m];
    SCOPED_TRACE(a.name);
    EXPECT_EQ(b.name, a.name);
    EXPECT_EQ(b.role, a.role);
    EXPECT_EQ(b.weight, a.weight);
    EXPECT_TRUE(b.pose.faces == a.pose.faces);
    EXPECT_TRUE(b.pose.rest == a.pose.rest);
    EXPECT_TRUE(b.pose.deformed == a.pose.deformed);
    ASSERT_EQ(b.pose.frames.size(), a.pose.frames.size());
    for (size_t k = 0; k < a.pose.frames.size(); ++k) EXPECT_TRUE(b.pose.frames[k] == a.pose.frames[k]) << "frame " << k;
  }
  EXPECT_TRUE(loaded->motion->rest == scene.motion->rest);
  EXPECT_TRUE(loaded->garment.vertices == scene.garment.vertices);
  EXPECT_TRUE(loaded->garment.faces == scene.garment.faces);
  EXPECT_TRUE(loaded->initial == scene.initial);
  EXPECT_EQ(loaded->attachment_faces, scene.attachment_faces);

  BesoSettings quick;
  quick.budget = 0.5;
  quick.evolutionary_ratio = quick.admission_ratio = 0.06;
  quick.max_iterations = 4;
  const Result<std::vector<BesoIteration>> a = RunBeso(scene, quick), b = RunBeso(*loaded, quick);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(b.ok()) << b.message();
  ASSERT_EQ(a->size(), b->size());
  for (size_t k = 0; k < a->size(); ++k) {
    SCOPED_TRACE("iteration " + std::to_string(k));
    EXPECT_EQ((*b)[k].design, (*a)[k].design);
    EXPECT_TRUE((*b)[k].positions == (*a)[k].positions);
    ASSERT_EQ((*b)[k].motions.size(), 3u);
    for (size_t m = 0; m < 3; ++m) {
      EXPECT_EQ((*b)[k].motions[m].energy_J, (*a)[k].motions[m].energy_J) << m;
      EXPECT_EQ((*b)[k].motions[m].density_ratio, (*a)[k].motions[m].density_ratio) << m;
    }
  }
  EXPECT_NE(a->front().design, a->back().design) << "the design changed over the iterations";

  // A scene whose motions are refused is not exported.
  SceneSpec bad = scene;
  bad.motions[1].weight = -1;
  const Status refused = ExportScene(bad, TempDir("bad_motions"));
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("motion 'extend': weight -1"), std::string::npos) << refused.message();
}

// A scene sent with a job is loaded from memory, not from a folder: the same scene as from its folder,
// bit for bit, and a file the bundle lacks, or one that does not parse, is named as the scene names it.
TEST(Scene, ABundleInMemoryLoadsAsTheSceneFolder) {
  for (const std::string name : {"pull_test_x", "sleeve_on_limb"}) {
    auto builtin = BuiltinScene(name);
    ASSERT_TRUE(builtin.ok());
    const std::filesystem::path dir = TempDir("bundle_" + name);
    ASSERT_TRUE(ExportScene(*builtin, dir.string()).ok());
    std::vector<std::string> named;
    auto from_folder = LoadScene((dir / "scene.json").string(), &named);
    ASSERT_TRUE(from_folder.ok()) << from_folder.message();
    auto bytes = [](const std::filesystem::path& p) {
      std::ifstream in(p, std::ios::binary);
      return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    };
    const std::string json = bytes(dir / "scene.json");
    std::map<std::string, std::string> contents;
    for (const std::string& file : named) contents[file] = bytes(dir / file);
    SceneBundle bundle;
    bundle.scene_json = json;
    for (const auto& [file, content] : contents) bundle.files[file] = content;
    std::vector<std::string> named_in_bundle;
    auto from_memory = LoadScene(bundle, &named_in_bundle);
    ASSERT_TRUE(from_memory.ok()) << from_memory.message();
    EXPECT_EQ(named_in_bundle, named);
    EXPECT_EQ(from_memory->name, from_folder->name);
    EXPECT_TRUE(from_memory->garment.vertices == from_folder->garment.vertices) << name;
    EXPECT_TRUE(from_memory->garment.faces == from_folder->garment.faces) << name;
    EXPECT_TRUE(from_memory->initial == from_folder->initial) << name;
    EXPECT_EQ(from_memory->design, from_folder->design);
    EXPECT_EQ(from_memory->attachment_faces, from_folder->attachment_faces);
    ASSERT_EQ(from_memory->clamps.size(), from_folder->clamps.size());
    for (size_t c = 0; c < from_memory->clamps.size(); ++c) EXPECT_EQ(from_memory->clamps[c].vertices, from_folder->clamps[c].vertices);
    ASSERT_EQ(from_memory->body.has_value(), from_folder->body.has_value());
    if (from_memory->body) {
      EXPECT_TRUE(from_memory->body->vertices == from_folder->body->vertices) << name;
    }

    const std::string first = named.front();
    SceneBundle missing = bundle;
    missing.files.erase(first);
    auto lacking = LoadScene(missing);
    ASSERT_FALSE(lacking.ok());
    EXPECT_EQ(lacking.message(), first + ": not among the scene's files") << lacking.message();

    SceneBundle broken = bundle;
    const std::string garbage = "v 0 0 0\nv 1 0 zero\n";
    const std::string mesh = from_folder->body ? "body.obj" : "garment_rest.obj";
    broken.files[mesh] = garbage;
    auto unparsed = LoadScene(broken);
    ASSERT_FALSE(unparsed.ok());
    EXPECT_EQ(unparsed.message().rfind(mesh + ":2: vertex 1", 0), 0u) << unparsed.message();
  }
}

// A folder where a scene file or a built-in name is expected (e.g. one written by `kgd scene export`
// under the scene's own name) is a clear error, not a crash; asked for a built-in by name only, the
// folder is ignored.
TEST(Scene, AFolderIsNotASceneFile) {
  const std::filesystem::path dir = TempDir("folder_arg");
  std::filesystem::create_directories(dir / "pull_test_x");
  const std::filesystem::path cwd = std::filesystem::current_path();
  std::filesystem::current_path(dir);
  const Result<SceneSpec> as_file = LoadScene("pull_test_x");
  const Result<SceneSpec> resolved = ResolveScene("pull_test_x");
  const Result<SceneSpec> builtin = ResolveBuiltinScene("pull_test_x");
  std::filesystem::current_path(cwd);
  for (const Result<SceneSpec>* r : {&as_file, &resolved}) {
    ASSERT_FALSE(r->ok());
    EXPECT_NE(r->message().find("pull_test_x: is a folder, not a scene file"), std::string::npos) << r->message();
    EXPECT_NE(r->message().find("scene.json"), std::string::npos) << r->message();
  }
  ASSERT_TRUE(builtin.ok()) << builtin.message();
  EXPECT_GT(builtin->garment.faces.rows(), 0);
}

// A scene of several bodies (the flexing sleeve on limbs M, S and L) exports with them (names, weights,
// each body's poses, the objective) and loads back as the same scene, bit for bit: a design of two
// iterations from the file equals the one from the scene it was exported from on every body.
// (knee_flexion_sizes does the same through kgd scene export: scripts/bodies_study.sh; building its
// bodies takes too long for a unit test.)
TEST(Scene, ASceneOfSeveralBodiesExportsAndLoadsAsItself) {
  Result<SceneSpec> built = SleeveForBodies({{"M", 0.04, 1.0}, {"S", 0.036, 1.0}, {"L", 0.044, 0.5}}, BodyObjective::kWorst);
  ASSERT_TRUE(built.ok()) << built.message();
  SceneSpec& scene = *built;
  ASSERT_EQ(scene.bodies.size(), 3u);
  // Two frames a body (a design uses the deformed pose): the rest and the deformed one.
  for (SceneBody& b : scene.bodies) b.pose.frames = {b.pose.rest, b.pose.deformed};
  scene.motion->frames = scene.bodies[0].pose.frames;
  const std::string dir = TempDir("three_bodies");
  const Status exported = ExportScene(scene, dir);
  ASSERT_TRUE(exported.ok()) << exported.message();
  Result<SceneSpec> loaded = LoadScene(dir + "/scene.json");
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  EXPECT_EQ(loaded->body_objective, BodyObjective::kWorst);
  ASSERT_EQ(loaded->bodies.size(), scene.bodies.size());
  for (size_t k = 0; k < scene.bodies.size(); ++k) {
    const SceneBody &a = scene.bodies[k], &b = loaded->bodies[k];
    SCOPED_TRACE(a.name);
    EXPECT_EQ(b.name, a.name);
    EXPECT_EQ(b.weight, a.weight);
    EXPECT_TRUE(b.pose.faces == a.pose.faces);
    EXPECT_TRUE(b.pose.rest == a.pose.rest);
    EXPECT_TRUE(b.pose.deformed == a.pose.deformed);
    ASSERT_EQ(b.pose.frames.size(), 2u);
    for (size_t f = 0; f < 2; ++f) EXPECT_TRUE(b.pose.frames[f] == a.pose.frames[f]) << "frame " << f;
  }
  EXPECT_FALSE(loaded->bodies[1].pose.rest == loaded->bodies[0].pose.rest) << "S is another body than M";
  EXPECT_TRUE(loaded->motion->frames[1] == scene.motion->frames[1]);
  EXPECT_TRUE(loaded->garment.vertices == scene.garment.vertices);
  EXPECT_TRUE(loaded->garment.faces == scene.garment.faces);
  EXPECT_TRUE(loaded->initial == scene.initial);

  BesoSettings quick;
  quick.budget = 0.5;
  quick.evolutionary_ratio = quick.admission_ratio = 0.06;
  quick.max_iterations = 2;
  const Result<std::vector<BesoIteration>> a = RunBeso(scene, quick), b = RunBeso(*loaded, quick);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(b.ok()) << b.message();
  ASSERT_EQ(a->size(), 3u);
  ASSERT_EQ(b->size(), a->size());
  for (size_t k = 0; k < a->size(); ++k) {
    SCOPED_TRACE("iteration " + std::to_string(k));
    EXPECT_EQ((*b)[k].design, (*a)[k].design);
    EXPECT_TRUE((*b)[k].positions == (*a)[k].positions);
    ASSERT_EQ((*b)[k].motions.size(), 3u);
    for (size_t m = 0; m < 3; ++m) {
      EXPECT_EQ((*b)[k].motions[m].name, scene.bodies[m].name);
      EXPECT_EQ((*b)[k].motions[m].energy_J, (*a)[k].motions[m].energy_J) << m;
      EXPECT_EQ((*b)[k].motions[m].density_ratio, (*a)[k].motions[m].density_ratio) << m;
    }
  }
  EXPECT_NE(a->front().design, a->back().design) << "the design changed over the iterations";

  // A scene whose bodies are refused is not exported.
  SceneSpec bad = scene;
  bad.bodies[2].weight = -1;
  const Status refused = ExportScene(bad, TempDir("bad_bodies"));
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("body 'L': weight -1"), std::string::npos) << refused.message();
}

// A scene file's bodies: a good one loads with its bodies and objective; a body whose mesh has another
// topology than body.rest, a degenerate pose, a negative weight, a repeated name, a first body with
// poses of its own, a missing pose, an unknown objective, bodies beside motions or without a cut
// garment are refused, the message naming the file, the key and the body.
TEST(Scene, BadBodiesInASceneFileAreNamedWithTheirKeyAndBody) {
  const Result<SceneSpec> sleeve = SleeveForBodies({{"M", 0.04, 1.0}, {"S", 0.036, 1.0}, {"L", 0.044, 0.5}}, BodyObjective::kWorst);
  ASSERT_TRUE(sleeve.ok()) << sleeve.message();
  const std::string dir = TempDir("bodies_file");
  ASSERT_TRUE(ExportScene(*sleeve, dir).ok());
  const BodyMotion other = FlexingLimb(0.04, 20);
  ASSERT_TRUE(WriteObj(dir + "/other.obj", other.rest, other.faces).ok());
  const BodyMotion flat{sleeve->motion->faces, Positions::Zero(sleeve->motion->rest.rows(), 3), {}, {}};
  ASSERT_TRUE(WriteObj(dir + "/flat.obj", flat.rest, flat.faces).ok());
  nlohmann::json doc;
  {
    std::ifstream in(dir + "/scene.json");
    in >> doc;
  }
  const Result<SceneSpec> good = LoadScene(dir + "/scene.json");
  ASSERT_TRUE(good.ok()) << good.message();
  ASSERT_EQ(good->bodies.size(), 3u);
  EXPECT_EQ(good->bodies[2].name, "L");
  EXPECT_EQ(good->bodies[2].weight, 0.5);
  EXPECT_EQ(good->body_objective, BodyObjective::kWorst);
  const std::string file = dir + "/bad.json";
  auto refused = [&](const std::function<void(nlohmann::json&)>& edit, const std::string& words) {
    nlohmann::json bad = doc;
    edit(bad);
    std::ofstream(file) << bad.dump(2);
    const Result<SceneSpec> r = LoadScene(file);
    ASSERT_FALSE(r.ok()) << words;
    EXPECT_NE(r.message().find(words), std::string::npos) << r.message();
  };
  refused([](nlohmann::json& d) { d["bodies"][1]["rest"] = "other.obj"; },
          file + ": bodies[1].rest (body 'S'): " + dir + "/other.obj: has " + std::to_string(other.rest.rows()) + " vertices but " + dir +
              "/body_rest.obj has " + std::to_string(sleeve->motion->rest.rows()) + " (every body must have the topology of body.rest");
  refused([](nlohmann::json& d) { d["bodies"][2]["deformed"] = "flat.obj"; }, file + ": bodies[2].deformed (body 'L'): " + dir + "/flat.obj");
  refused([](nlohmann::json& d) { d["bodies"][1]["weight"] = -1; }, file + ": bodies[1].weight: body 'S': weight -1 must be >= 0");
  refused([](nlohmann::json& d) { d["bodies"][2]["name"] = "S"; }, file + ": bodies[2].name: body 'S': two bodies have this name (bodies[1])");
  refused([](nlohmann::json& d) { d["bodies"][0]["rest"] = "bodies/1/rest.obj"; },
          file + ": bodies[0].rest: body 'M': the first body is the scene's own: its poses are body.rest");
  refused([](nlohmann::json& d) { d["bodies"][0]["weight"] = 0; }, file + ": bodies[0].weight: body 'M': the first body is the scene's own");
  refused([](nlohmann::json& d) { d["bodies"][1].erase("deformed"); }, file + ": bodies[1].deformed: body 'S': missing");
  refused([](nlohmann::json& d) { d["bodies"][1]["size"] = "S"; }, file + ": bodies[1].size: unknown key");
  refused([](nlohmann::json& d) { d["body_objective"] = "best"; }, file + ": body_objective: the bodies' objective: 'best' is neither");
  refused([](nlohmann::json& d) { d["motions"] = {{{"name", "flex"}}}; }, file + ": bodies: not allowed with motions");
  refused([](nlohmann::json& d) { d.erase("bodies"); }, file + ": body_objective: only allowed with bodies");
}

TEST(Scene, PullTestDesignsHaveTheirPaperAreas) {
  for (const auto& [design, fraction] : std::vector<std::pair<std::string, double>>{{"line", 0.40}, {"x", 0.40}}) {
    auto s = PullTestScene(design);
    ASSERT_TRUE(s.ok());
    const Eigen::VectorXd area = FaceAreas(s->garment.vertices, s->garment.faces);
    double active = 0, reinforced = 0;
    for (Eigen::Index f = 0; f < area.size(); ++f) {
      double z = 0;
      for (int k = 0; k < 3; ++k) z += s->garment.vertices(s->garment.faces(f, k), 2) / 3;
      if (z > 0.02 && z < 0.12) {
        active += area[f];
        if (s->design[f]) reinforced += area[f];
      }
    }
    EXPECT_NEAR(active, 0.01, 1e-12);
    EXPECT_NEAR(reinforced / active, fraction, 0.01) << design;
  }
}

}  // namespace
}  // namespace kgd
