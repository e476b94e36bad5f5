// Acceptance 6: bad input through the real `kgd simulate`: a clear error naming the file and the
// element, exit code 2, never a crash.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>

namespace {

namespace fs = std::filesystem;

struct CommandRun {
  int exit_code;
  std::string output;
};

CommandRun Kgd(const std::string& args) {
  const std::string cmd = std::string(KGD_BINARY) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), out};
}

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / "kgd_bad_input" / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    Write("good.obj", "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0.01 0.01 0\nf 1 2 4\nf 1 4 3\n");
  }
  void Write(const std::string& name, const std::string& text) { std::ofstream(dir_ / name) << text; }
  std::string Scene(const std::string& json) {
    Write("scene.json", json);
    return (dir_ / "scene.json").string();
  }
  void ExpectError(const std::string& json, const std::string& needle) {
    const CommandRun r = Kgd("simulate " + Scene(json));
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.output;
    EXPECT_EQ(r.output.find("terminate"), std::string::npos) << r.output;
  }
  fs::path dir_;
};

TEST_F(BadInput, GoodSceneRuns) {
  const CommandRun r = Kgd("simulate --json " + Scene(R"({"garment": {"rest": "good.obj"}})"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"energy_J\""), std::string::npos) << r.output;
}

TEST_F(BadInput, MalformedMesh) {
  Write("bad.obj", "v 0 0 0\nv 0.01 zero 0\nv 0 0.01 0\nf 1 2 3\n");
  ExpectError(R"({"garment": {"rest": "bad.obj"}})", "bad.obj:2: vertex 1");
}

TEST_F(BadInput, NanCoordinate) {
  Write("nan.obj", "v 0 0 0\nv 0.01 0 0\nv 0 nan 0\nf 1 2 3\n");
  ExpectError(R"({"garment": {"rest": "nan.obj"}})", "nan.obj:3: vertex 2 has a non-finite coordinate");
}

TEST_F(BadInput, OutOfRangeIndex) {
  Write("oor.obj", "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nf 1 2 3\nf 1 3 9\n");
  ExpectError(R"({"garment": {"rest": "oor.obj"}})", "face 1 refers to vertex 9");
  ExpectError(R"({"garment": {"rest": "good.obj", "design": {"reinforced_faces": [0, 5]}}})",
              "garment.design.reinforced_faces: entry 1 is face 5");
}

TEST_F(BadInput, ZeroAreaTriangle) {
  Write("flat.obj", "v 0 0 0\nv 0.01 0 0\nv 0.02 0 0\nv 0 0.01 0\nf 1 2 4\nf 1 2 3\n");
  ExpectError(R"({"garment": {"rest": "flat.obj"}})", "flat.obj: face 1 has zero area");
}

TEST_F(BadInput, UnequalVertexCountsBetweenPoses) {
  Write("init.obj", "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nf 1 2 3\n");
  ExpectError(R"({"garment": {"rest": "good.obj", "initial": "init.obj"}})",
              "init.obj: has 3 vertices but the rest mesh has 4");
}

TEST_F(BadInput, UnknownSceneKeys) {
  ExpectError(R"({"garment": {"rest": "good.obj"}, "efects": {}})", "scene.json: efects: unknown key");
  ExpectError(R"({"garment": {"rest": "good.obj"}, "effects": {"contact": "sticky"}})",
              "effects.contact: 'sticky' is not one of: none, unilateral, bilateral");
  ExpectError(R"({"garment": {"rest": "good.obj"}, "solver": {"grad_tol": -1}})", "solver.grad_tol: must be > 0");
}

TEST_F(BadInput, MalformedJsonAndMissingFiles) {
  ExpectError(R"({"garment": {"rest": "good.obj"})", "scene.json: not valid JSON");
  ExpectError(R"({"garment": {"rest": "nowhere.obj"}})", "nowhere.obj: cannot open file");
  ExpectError(R"({"garment": {"rest": "good.obj"}, "effects": {"contact": "unilateral"}})",
              "body: missing, but effects.contact is 'unilateral'");
  const CommandRun r = Kgd("simulate " + (dir_ / "absent.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("absent.json: no such scene file"), std::string::npos) << r.output;
}

TEST_F(BadInput, NanInMaterial) {
  ExpectError(R"({"garment": {"rest": "good.obj"}, "materials": {"cloth": {"thickness_m": -2}}})",
              "materials.cloth: thickness_m must be > 0");
}

}  // namespace
