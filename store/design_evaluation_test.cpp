// The evaluation file round-trips bit for bit, is written whole or not at all, and refuses files that
// are not evaluations with a message naming the file.
#include "store/design_evaluation.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

namespace kgd {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("kgd_design_evaluation_test_" + name)).string();
}

DesignEvaluation Sample(int frames, int baselines, int vertices = 7, int faces = 5, int body = 4) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  auto positions = [&](int n) {
    Positions x(n, 3);
    for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] = u(rng);
    return x;
  };
  auto field = [&] {
    Eigen::VectorXd w(faces);
    for (int f = 0; f < faces; ++f) w[f] = 1e3 * (1 + u(rng));
    return w;
  };
  DesignEvaluation e;
  e.iteration = 42;
  e.note = frames ? "" : "no motion frames: the scene has one pose";
  for (int k = 0; k < frames; ++k) {
    Eigen::VectorXd pressure(body);
    for (int j = 0; j < body; ++j) pressure[j] = j % 2 ? 0.0 : 2e3 * (1 + u(rng));
    e.frames.push_back({positions(vertices), positions(body), field(), 0.1 * (k + 1), k % 2 ? "converged" : "stalled", pressure});
  }
  const char* names[] = {"line", "x"};
  for (int b = 0; b < baselines; ++b) {
    EvaluatedBaseline s;
    s.name = names[b];
    for (int f = 0; f < faces; ++f) s.design.push_back((f + b) % 2);
    s.positions = positions(vertices);
    s.energy_density_Pa = field();
    s.area_fraction = 0.15 + b, s.energy_J = 0.3, s.reinforced_energy_J = 0.1, s.reinforced_density_J_per_m2 = 15.2, s.density_ratio = 1.9 + b;
    s.status = "converged";
    e.baselines.push_back(s);
  }
  return e;
}

void ExpectSame(const DesignEvaluation& a, const DesignEvaluation& b) {
  EXPECT_EQ(a.iteration, b.iteration);
  EXPECT_EQ(a.note, b.note);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (size_t k = 0; k < a.frames.size(); ++k) {
    EXPECT_TRUE(a.frames[k].garment == b.frames[k].garment) << k;
    EXPECT_TRUE(a.frames[k].body == b.frames[k].body) << k;
    EXPECT_TRUE(a.frames[k].energy_density_Pa == b.frames[k].energy_density_Pa) << k;
    EXPECT_EQ(a.frames[k].energy_J, b.frames[k].energy_J);
    EXPECT_EQ(a.frames[k].status, b.frames[k].status);
    EXPECT_TRUE(a.frames[k].skin_pressure_Pa == b.frames[k].skin_pressure_Pa) << k;
  }
  ASSERT_EQ(a.baselines.size(), b.baselines.size());
  for (size_t i = 0; i < a.baselines.size(); ++i) {
    const EvaluatedBaseline &x = a.baselines[i], &y = b.baselines[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.design, y.design);
    EXPECT_TRUE(x.positions == y.positions);
    EXPECT_TRUE(x.energy_density_Pa == y.energy_density_Pa);
    EXPECT_EQ(x.area_fraction, y.area_fraction);
    EXPECT_EQ(x.energy_J, y.energy_J);
    EXPECT_EQ(x.reinforced_energy_J, y.reinforced_energy_J);
    EXPECT_EQ(x.reinforced_density_J_per_m2, y.reinforced_density_J_per_m2);
    EXPECT_EQ(x.density_ratio, y.density_ratio);
    EXPECT_EQ(x.status, y.status);
  }
}

TEST(DesignEvaluation, RoundTripsBitForBit) {
  for (const auto& [frames, baselines] : {std::pair{8, 2}, std::pair{0, 2}, std::pair{3, 0}, std::pair{0, 0}}) {
    const DesignEvaluation e = Sample(frames, baselines);
    const std::string path = TempPath("roundtrip.evaluation.h5");
    ASSERT_TRUE(WriteDesignEvaluation(path, e).ok());
    Result<DesignEvaluation> back = ReadDesignEvaluation(path);
    ASSERT_TRUE(back.ok()) << back.message();
    ExpectSame(*back, e);
    // Without skin pressure (no contact), the frames read back without it.
    DesignEvaluation bare = e;
    for (EvaluatedFrame& f : bare.frames) f.skin_pressure_Pa.resize(0);
    ASSERT_TRUE(WriteDesignEvaluation(path, bare).ok());
    back = ReadDesignEvaluation(path);
    ASSERT_TRUE(back.ok()) << back.message();
    ExpectSame(*back, bare);
    std::filesystem::remove(path);
  }
}

TEST(DesignEvaluation, ASkinPressureThatIsNotOnePerBodyVertexIsRefused) {
  DesignEvaluation e = Sample(3, 0);
  for (EvaluatedFrame& f : e.frames) f.skin_pressure_Pa.conservativeResize(3);
  const std::string path = TempPath("bad_pressure.evaluation.h5");
  const Status st = WriteDesignEvaluation(path, e);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("3 values for 4 body vertices"), std::string::npos) << st.message();
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(DesignEvaluation, LivesBesideTheDesignFile) {
  EXPECT_EQ(EvaluationPath("/data/jobs/job-7.h5"), "/data/jobs/job-7.evaluation.h5");
  EXPECT_EQ(EvaluationPath("arm.h5"), "arm.evaluation.h5");
}

TEST(DesignEvaluation, InconsistentSizesAreRefusedAndLeaveNothingBehind) {
  DesignEvaluation e = Sample(3, 2);
  e.frames[2].garment.conservativeResize(3, 3);
  const std::string path = TempPath("bad.evaluation.h5");
  std::filesystem::remove(path);
  const Status st = WriteDesignEvaluation(path, e);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find(path), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("frames differ in size"), std::string::npos) << st.message();
  EXPECT_FALSE(std::filesystem::exists(path));
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::temp_directory_path()))
    EXPECT_EQ(entry.path().string().find(path + ".tmp"), std::string::npos) << "a temporary file was left: " << entry.path();
}

TEST(DesignEvaluation, AWriteIntoAMissingFolderFailsWithTheFileNamed) {
  const Status st = WriteDesignEvaluation("/nonexistent-folder/x.evaluation.h5", Sample(1, 1));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("/nonexistent-folder/x.evaluation.h5"), std::string::npos) << st.message();
}

TEST(DesignEvaluation, RefusesWhatIsNotAnEvaluation) {
  const std::string text = TempPath("not.h5");
  { std::ofstream(text) << "hello"; }
  Result<DesignEvaluation> r = ReadDesignEvaluation(text);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find(text), std::string::npos);
  EXPECT_NE(r.message().find("not an HDF5 file"), std::string::npos) << r.message();
  Result<DesignEvaluation> missing = ReadDesignEvaluation(TempPath("missing.h5"));
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("no such file"), std::string::npos);
  std::filesystem::remove(text);
}

}  // namespace
}  // namespace kgd
