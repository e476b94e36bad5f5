// The built-in scenes' posed bodies (server/scene_body.h) with a stand-in builder (a real built-in
// scene takes a job's set-up time): each pose's OBJ is that pose, unknown scenes and poses are named,
// concurrent requests build once, a few bodies are kept, and a failed build is not kept.
#include "server/scene_body.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "core/mesh/mesh_io.h"

namespace kgd::server {
namespace {

// A tetrahedron moved 1 cm along x per frame: rest, frames 1..3 (the last is the deformed pose).
SceneSpec Moving(double scale) {
  SceneSpec s;
  BodyMotion m;
  m.faces.resize(4, 3);
  m.faces << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  m.rest.resize(4, 3);
  m.rest << 0, 0, 0, scale, 0, 0, 0, scale, 0, 0, 0, scale;
  for (int k = 1; k <= 3; ++k) {
    Positions x = m.rest;
    x.col(0).array() += 0.01 * k;
    m.frames.push_back(x);
  }
  m.deformed = m.frames.back();
  s.motion = m;
  return s;
}

struct Counting {
  std::atomic<int> builds{0};
  SceneBodies bodies{[this](const std::string&, const std::vector<std::string>& measurements) -> Result<SceneSpec> {
    ++builds;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // long enough for the other requests to arrive
    if (!measurements.empty() && measurements[0] == "height_m=1.5") return Status::Error("the body did not build");
    return Moving(measurements.empty() ? 0.1 : 0.2);
  }};
};

TEST(SceneBodies, EachPoseIsThatPoseOfTheScenesMotion) {
  Counting c;
  const SceneSpec want = Moving(0.1);
  for (const auto& [pose, x] : std::vector<std::pair<std::string, Positions>>{
           {"rest", want.motion->rest}, {"deformed", want.motion->deformed}, {"frame_1", want.motion->frames[0]}, {"frame_3", want.motion->frames[2]}}) {
    std::string obj;
    ServiceStatus st = c.bodies.Obj("arm_flexion", {}, pose, &obj);
    ASSERT_TRUE(st.ok()) << st.message;
    Result<TriMesh> mesh = ParseMesh(obj, pose + ".obj");
    ASSERT_TRUE(mesh.ok()) << mesh.message();
    EXPECT_EQ(mesh->vertices, x) << pose;
    EXPECT_EQ(mesh->faces, want.motion->faces) << pose;
  }
  EXPECT_EQ(c.builds, 1) << "one scene and measurements are built once";
}

TEST(SceneBodies, UnknownScenesPosesAndMeasurementsAreNamed) {
  Counting c;
  std::string obj;
  ServiceStatus st = c.bodies.Obj("moonwalk", {}, "rest", &obj);
  EXPECT_EQ(st.code, ServiceCode::kNotFound);
  EXPECT_EQ(st.message, "there is no built-in scene 'moonwalk'");
  st = c.bodies.Obj("pull_test_line", {}, "rest", &obj);
  EXPECT_EQ(st.code, ServiceCode::kNotFound);
  EXPECT_EQ(st.message, "scene 'pull_test_line' has no parametric body");
  st = c.bodies.Obj("arm_flexion", {"shoe_size=9"}, "rest", &obj);
  EXPECT_EQ(st.code, ServiceCode::kInvalidArgument);
  EXPECT_NE(st.message.find("'shoe_size' is not known"), std::string::npos) << st.message;
  for (const std::string pose : {"frame_0", "frame_4", "frame_", "pose"}) {
    st = c.bodies.Obj("arm_flexion", {}, pose, &obj);
    EXPECT_EQ(st.code, ServiceCode::kNotFound) << pose;
    EXPECT_EQ(st.message, "scene 'arm_flexion' has no pose '" + pose + "' (rest, deformed, frame_1..frame_3)");
  }
  EXPECT_EQ(c.builds, 1) << "the measurement was refused before building";
}

TEST(SceneBodies, ConcurrentRequestsBuildOnceAndAFewBodiesAreKept) {
  Counting c;
  std::vector<std::thread> threads;
  std::atomic<int> ok{0};
  for (int i = 0; i < 4; ++i)
    threads.emplace_back([&, i] {
      std::string obj;
      ok += c.bodies.Obj("knee_brace", {"height_m=1.7"}, i % 2 ? "rest" : "deformed", &obj).ok();
    });
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(ok, 4);
  EXPECT_EQ(c.builds, 1);
  // Four other bodies push it out; then it is built again.
  std::string obj;
  for (const char* h : {"height_m=1.6", "height_m=1.65", "height_m=1.75", "height_m=1.8"}) ASSERT_TRUE(c.bodies.Obj("knee_brace", {h}, "rest", &obj).ok());
  EXPECT_EQ(c.builds, 5);
  ASSERT_TRUE(c.bodies.Obj("knee_brace", {"height_m=1.8"}, "rest", &obj).ok());
  EXPECT_EQ(c.builds, 5) << "the last is kept";
  ASSERT_TRUE(c.bodies.Obj("knee_brace", {"height_m=1.7"}, "rest", &obj).ok());
  EXPECT_EQ(c.builds, 6) << "the first was pushed out";
}

TEST(SceneBodies, AFailedBuildIsReportedAndTriedAgain) {
  Counting c;
  std::string obj;
  ServiceStatus st = c.bodies.Obj("knee_brace", {"height_m=1.5"}, "rest", &obj);
  EXPECT_EQ(st.code, ServiceCode::kInvalidArgument);
  EXPECT_EQ(st.message, "scene 'knee_brace': the body did not build");
  st = c.bodies.Obj("knee_brace", {"height_m=1.5"}, "rest", &obj);
  EXPECT_FALSE(st.ok());
  EXPECT_EQ(c.builds, 2);
}

}  // namespace
}  // namespace kgd::server
