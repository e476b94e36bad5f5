// Real bodies through the import path (issue: bodies, garments and scenes, acceptance 2): every motion
// and garment region of ../shared/bodies/makehuman (MakeHuman meshes, CC0), written as a scene file that
// names the files as a user would, loaded, and simulated fully reinforced over all frames. Skips with a
// message when the folder is absent (a user's clone does not have it).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "core/mesh/mesh_io.h"
#include "core/scene/scene.h"
#include "core/scene/simulate.h"
#include "core/scene/scene_file.h"

namespace kgd {
namespace {

namespace fs = std::filesystem;

constexpr double kPenetrationTolerance_m = 0.5e-3;  // as for the built-in scenes (docs/VALIDATION.md)

struct Motion {
  const char* name;
  const char* region;
  int frames;
  bool own_rest;
  int subdivisions;  // the paper subdivides twice; the shirt once here to keep the suite short
};

const Motion kMotions[] = {
    {"arm_flexion", "sleeve_arm", 8, false, 2},  {"arm_extension", "sleeve_arm", 4, true, 2},
    {"knee_flexion", "sleeve_knee", 8, false, 2}, {"knee_extension", "sleeve_knee", 4, true, 2},
    {"slouch", "shirt", 8, false, 1},            {"crouch", "shorts", 4, false, 2},
    {"lunge", "shorts", 4, false, 2},
};

void PrintTo(const Motion& m, std::ostream* os) { *os << m.name; }

fs::path BodiesDir() { return fs::path(KGD_SOURCE_DIR) / ".." / "shared" / "bodies" / "makehuman"; }

class MakeHumanImport : public ::testing::TestWithParam<Motion> {};

TEST_P(MakeHumanImport, FullyReinforcedFramesConverge) {
  const Motion& m = GetParam();
  const fs::path bodies = BodiesDir();
  if (!fs::exists(bodies / "rest.obj")) GTEST_SKIP() << "no real bodies at " << bodies.string() << " (../shared/bodies is not part of a clone)";
  const fs::path motion = bodies / m.name;
  nlohmann::json scene;
  scene["name"] = std::string("makehuman_") + m.name;
  scene["body"]["rest"] = (m.own_rest ? motion / "rest.obj" : bodies / "rest.obj").string();
  scene["body"]["deformed"] = (motion / "pose.obj").string();
  for (int k = 1; k <= m.frames; ++k) {
    char file[32];
    std::snprintf(file, sizeof file, "frame_%02d.obj", k);
    scene["body"]["frames"].push_back((motion / "frames" / file).string());
  }
  scene["garment"]["region"] = (bodies / "regions" / (std::string(m.region) + ".faces.txt")).string();
  scene["garment"]["subdivisions"] = m.subdivisions;
  scene["garment"]["design"] = "all_reinforced";
  scene["attachments"]["body_faces"] = (bodies / "regions" / (std::string(m.region) + ".attach.txt")).string();
  scene["effects"] = {{"contact", "unilateral"}, {"attachments", true}};
  const fs::path dir = fs::temp_directory_path() / "kgd_makehuman_import" / m.name;
  fs::create_directories(dir);
  std::ofstream(dir / "scene.json") << scene.dump(2);

  Result<SceneSpec> s = LoadScene((dir / "scene.json").string());
  ASSERT_TRUE(s.ok()) << s.message();
  std::printf("%s (%s): %ld garment vertices, %ld faces\n", m.name, m.region, (long)s->garment.vertices.rows(), (long)s->garment.faces.rows());
  // MakeHuman's linear-blend skinning collapses the flexed hips: the crouch loses 10.3 % of the body's
  // volume and the lunge 7.0 %, beyond the threshold at which `kgd simulate` notes it; the other
  // motions change it by 2.6 % (knee flexion) or less.
  const std::optional<BodyVolumeChange> volume = MotionVolumeChange(*s->motion);
  ASSERT_TRUE(volume.has_value());
  std::printf("  body volume %.5f m^3 at rest, %+.1f %%\n", volume->rest_m3, 100 * volume->Relative());
  const bool hips = std::string(m.name) == "crouch" || std::string(m.name) == "lunge";
  EXPECT_EQ(std::abs(volume->Relative()) > kBodyVolumeNoticeFraction, hips) << m.name << ": " << volume->Relative();
  const Result<std::vector<SimulationResult>> frames = SimulateFrames(*s, [&](int k, const SimulationResult& r) {
    std::printf("  frame %d: %s, %d iterations, %.2f s, E %.6g J, min phi %.3f mm, inverted %d\n", k + 1, ToString(r.solve.status),
                r.solve.iterations, r.solve.seconds, r.solve.energy_J, 1e3 * r.min_phi_m, r.inverted_faces);
    std::fflush(stdout);
  });
  ASSERT_TRUE(frames.ok()) << frames.message();
  ASSERT_EQ(static_cast<int>(frames->size()), m.frames);
  for (size_t k = 0; k < frames->size(); ++k) {
    const SimulationResult& r = (*frames)[k];
    EXPECT_TRUE(r.solve.converged()) << m.name << " frame " << k + 1 << ": " << r.solve.message;
    EXPECT_GE(r.min_phi_m, -kPenetrationTolerance_m) << m.name << " frame " << k + 1;
    // No triangle folds over (the fold barrier; docs/VALIDATION.md, "Folds").
    EXPECT_EQ(r.inverted_faces, 0) << m.name << " frame " << k + 1;
  }
}

// Every garment region on the real body in a scene whose body does not move (deformed pose = rest
// pose), or moves rigidly (rotated and shifted), at 0, 1 and 2 subdivisions, all cloth and fully
// reinforced: the garment stores no energy and stays where it starts (issue: a garment at rest stores
// nothing).
TEST(MakeHumanAtRest, EveryRegionStoresNothing) {
  const fs::path bodies = BodiesDir();
  if (!fs::exists(bodies / "rest.obj")) GTEST_SKIP() << "no real bodies at " << bodies.string() << " (../shared/bodies is not part of a clone)";
  const fs::path dir = fs::temp_directory_path() / "kgd_makehuman_at_rest";
  fs::create_directories(dir);
  Result<TriMesh> rest = ReadMesh((bodies / "rest.obj").string());
  ASSERT_TRUE(rest.ok()) << rest.message();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.52, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Positions moved = (rest->vertices * R.transpose()).rowwise() + Eigen::RowVector3d(0.2, -0.1, 0.05);
  ASSERT_TRUE(WriteObj((dir / "moved.obj").string(), moved, rest->faces).ok());
  for (const char* region : {"sleeve_arm", "sleeve_knee", "shirt", "shorts"})
    for (const int subdivisions : {0, 1, 2})
      for (const bool rigid : {false, true}) {
        const std::string pose = rigid ? (dir / "moved.obj").string() : (bodies / "rest.obj").string();
        nlohmann::json scene;
        scene["body"] = {{"rest", (bodies / "rest.obj").string()}, {"deformed", pose}, {"frames", {pose}}};
        scene["garment"] = {{"region", (bodies / "regions" / (std::string(region) + ".faces.txt")).string()}, {"subdivisions", subdivisions}};
        scene["attachments"]["body_faces"] = (bodies / "regions" / (std::string(region) + ".attach.txt")).string();
        scene["effects"] = {{"contact", "unilateral"}, {"attachments", true}};
        std::ofstream(dir / "scene.json") << scene.dump(2);
        Result<SceneSpec> s = LoadScene((dir / "scene.json").string());
        ASSERT_TRUE(s.ok()) << s.message();
        for (const uint8_t material : {kCloth, kReinforced}) {
          SCOPED_TRACE(std::string(region) + ", " + std::to_string(subdivisions) + " subdivisions, " + (rigid ? "moved rigidly" : "at rest") +
                       (material == kCloth ? ", all cloth" : ", all reinforced"));
          s->design.assign(s->garment.faces.rows(), material);
          Result<SimulationResult> r = SimulateScene(*s);
          ASSERT_TRUE(r.ok()) << r.message();
          EXPECT_TRUE(r->solve.converged()) << r->solve.message;
          EXPECT_LE(std::abs(r->solve.energy_J), 1e-9);
          EXPECT_LE((r->positions - s->initial).rowwise().norm().maxCoeff(), 1e-9);
        }
      }
}

INSTANTIATE_TEST_SUITE_P(Motions, MakeHumanImport, ::testing::ValuesIn(kMotions), [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace kgd
