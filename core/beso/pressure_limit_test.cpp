// The skin-pressure limit of a design job (pressure_limit.h, docs/MODEL.md "Pressure limit"): which
// faces it keeps out, the refusal of a limit the fully cloth garment breaks, a limited design that keeps
// the limit where the unlimited one breaks it, and the scene key's round trip through a scene file.
#include "core/beso/pressure_limit.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/beso/design_loop.h"
#include "core/scene/scene_file.h"
#include "core/scene/shapes.h"
#include "core/scene/simulate.h"

namespace kgd {
namespace {

// A small sleeve cut from a limb whose joint flexes by 0.8 rad (the paper's way: rest straight).
SceneSpec FlexingSleeve() {
  LimbShape shape;
  shape.around = 16;
  std::vector<double> axial;
  const TriMesh rest = LimbRest(shape, &axial);
  SceneSpec s;
  s.name = "flexing_sleeve";
  s.motion = BodyMotion{rest.faces, rest.vertices, LimbPosed(shape, rest.vertices, 0.8), {}};
  for (Eigen::Index f = 0; f < rest.faces.rows(); ++f) {
    double lo = 1e300, hi = -1e300;
    for (int k = 0; k < 3; ++k) lo = std::min(lo, axial[rest.faces(f, k)]), hi = std::max(hi, axial[rest.faces(f, k)]);
    if (lo < -0.09 || hi > 0.09) continue;
    s.garment_region.push_back(static_cast<int>(f));
    if (lo < -0.07 || hi > 0.07) s.attachment_body_faces.push_back(static_cast<int>(f));
  }
  s.effects.contact = ContactModel::kUnilateral;
  s.effects.attachments = true;
  const Status st = CutGarmentFromMotion(&s);
  EXPECT_TRUE(st.ok()) << st.message();
  return s;
}

BesoSettings Quick(double max_pressure_Pa) {
  BesoSettings s;
  s.budget = 0.5;
  s.evolutionary_ratio = 0.06;
  s.admission_ratio = 0.06;
  s.max_iterations = 60;
  s.max_pressure_Pa = max_pressure_Pa;
  return s;
}

// The skin's peak pressure of `design` in the scene's deformed pose, simulated from the body.
double PeakPressure(SceneSpec s, const std::vector<uint8_t>& design) {
  s.design = design;
  Result<SimulationResult> r = SimulateScene(s);
  EXPECT_TRUE(r.ok()) << r.message();
  return r.ok() ? r->skin.peak_Pa : 0.0;
}

// A strip of four triangles over vertices 0..5: faces 0 (0 1 2), 1 (1 3 2), 2 (2 3 4), 3 (3 5 4).
Faces Strip() {
  Faces f(4, 3);
  f << 0, 1, 2, 1, 3, 2, 2, 3, 4, 3, 5, 4;
  return f;
}

TEST(PressureLimit, KeepsOutTheFacesAroundEveryVertexPressingAboveTheLimit) {
  const Faces faces = Strip();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  q[0] = 5;    // above: face 0
  q[5] = 2.9;  // below
  const std::vector<uint8_t> reinforced(4, kReinforced), all(4, 1);
  EXPECT_EQ(FacesToKeepOut(faces, 6, {q}, 3.0, reinforced, all), std::vector<int>({0}));
  q[4] = 3.5;  // vertex 4: faces 2 and 3
  EXPECT_EQ(FacesToKeepOut(faces, 6, {q}, 3.0, reinforced, all), std::vector<int>({0, 2, 3}));
  // Another pose pressing on vertex 1 adds faces 0 and 1; a face that may not go stays.
  Eigen::VectorXd other = Eigen::VectorXd::Zero(6);
  other[1] = 4;
  EXPECT_EQ(FacesToKeepOut(faces, 6, {q, other}, 3.0, reinforced, {1, 0, 1, 1}), std::vector<int>({0, 2, 3}));
  EXPECT_EQ(FacesToKeepOut(faces, 6, {q, other}, 3.0, reinforced, all), std::vector<int>({0, 1, 2, 3}));
  // Nothing above the limit: nothing.
  EXPECT_TRUE(FacesToKeepOut(faces, 6, {Eigen::VectorXd::Zero(6)}, 3.0, reinforced, all).empty());
}

TEST(PressureLimit, GrowsTheRingUntilItRemovesReinforcement) {
  const Faces faces = Strip();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  q[0] = 5;  // around vertex 0: face 0 only, cloth; the reinforcement is face 3, two rings away
  const std::vector<uint8_t> design = {kCloth, kCloth, kCloth, kReinforced}, all(4, 1);
  // Ring 1: face 0 (cloth); ring 2 (vertices 0 1 2): faces 0 1 2, cloth; ring 3: face 3, reinforced.
  EXPECT_EQ(FacesToKeepOut(faces, 6, {q}, 3.0, design, all), std::vector<int>({0, 3}));
  // No reinforcement that may go: the first ring only.
  EXPECT_EQ(FacesToKeepOut(faces, 6, {q}, 3.0, design, {1, 1, 1, 0}), std::vector<int>({0}));
}

// A limit the fully cloth garment already breaks is refused before iteration 0, naming the limit and
// the peak.
TEST(PressureLimit, ALimitTheFullyClothGarmentBreaksIsRefusedByName) {
  const SceneSpec s = FlexingSleeve();
  const double cloth_peak = PeakPressure(s, std::vector<uint8_t>(s.garment.faces.rows(), kCloth));
  ASSERT_GT(cloth_peak, 0);
  const Result<std::vector<BesoIteration>> run = RunBeso(s, Quick(0.5 * cloth_peak));
  ASSERT_FALSE(run.ok());
  char limit[64], peak[64];
  std::snprintf(limit, sizeof limit, "max_pressure_kPa %.4g", 0.5e-3 * cloth_peak);
  std::snprintf(peak, sizeof peak, "already presses the skin %.3g kPa", 1e-3 * cloth_peak);
  EXPECT_NE(run.message().find(limit), std::string::npos) << run.message();
  EXPECT_NE(run.message().find(peak), std::string::npos) << run.message();
  EXPECT_NE(run.message().find("fully cloth garment"), std::string::npos) << run.message();
}

// Between the fully cloth garment's peak and the unlimited design's, the limit holds: the limited run
// converges on a design that presses at most the limit (as recorded, and simulated afresh from the
// body), where the unlimited design breaks it, and its recorded peaks are the skin's.
TEST(PressureLimit, TheLimitedDesignKeepsTheLimitTheUnlimitedOneBreaks) {
  const SceneSpec s = FlexingSleeve();
  const double cloth_peak = PeakPressure(s, std::vector<uint8_t>(s.garment.faces.rows(), kCloth));
  const Result<std::vector<BesoIteration>> free = RunBeso(s, Quick(0));
  ASSERT_TRUE(free.ok()) << free.message();
  EXPECT_EQ(free->back().peak_pressure_Pa, 0) << "no limit: not measured";
  const double free_peak = PeakPressure(s, free->back().design);
  ASSERT_GT(free_peak, 1.2 * cloth_peak) << "the reinforcement presses harder than cloth";
  const BesoSettings limited_settings = Quick(cloth_peak + 0.3 * (free_peak - cloth_peak));
  const double limit = limited_settings.max_pressure_Pa;
  const Result<std::vector<BesoIteration>> limited = RunBeso(s, limited_settings);
  ASSERT_TRUE(limited.ok()) << limited.message();
  const BesoIteration& last = limited->back();
  const double area = FaceAreas(s.garment.vertices, s.garment.faces).sum();
  EXPECT_EQ(BesoEndOf(*limited, limited_settings, area), BesoEnd::kConverged) << DescribeBesoEnd(BesoEndOf(*limited, limited_settings, area), *limited, limited_settings);
  EXPECT_GT(last.peak_pressure_Pa, 0);
  EXPECT_LE(last.peak_pressure_Pa, limit);
  EXPECT_LE(PeakPressure(s, last.design), limit);
  EXPECT_GT(last.pressure_kept_out_fraction, 0) << "the limit kept faces out";
  // Iteration 0 (fully reinforced) presses above the limit: the record holds the skin's peak.
  EXPECT_NEAR(limited->front().peak_pressure_Pa, PeakPressure(s, limited->front().design), 1e-6 * limited->front().peak_pressure_Pa);
  EXPECT_GT(limited->front().peak_pressure_Pa, limit);
  std::printf("fully cloth %.0f Pa; unlimited design %.0f Pa (density ratio %.3f, %zu iterations); limit %.0f Pa: design %.0f Pa "
              "(density ratio %.3f, area %.3f, kept out %.3f, %zu iterations)\n",
              cloth_peak, free_peak, free->back().density_ratio, free->size(), limit, last.peak_pressure_Pa, last.density_ratio, last.area_fraction,
              last.pressure_kept_out_fraction, limited->size());
}

// The scene key max_pressure_kPa: exported and loaded back (in Pa, SI inside); a value not above 0
// refused naming the key.
TEST(PressureLimit, TheSceneKeyRoundTripsThroughAFile) {
  SceneSpec s = FlexingSleeve();
  s.max_pressure_Pa = 3000;
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "kgd_pressure_limit_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ASSERT_TRUE(ExportScene(s, dir.string()).ok());
  Result<SceneSpec> loaded = LoadScene((dir / "scene.json").string());
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  EXPECT_DOUBLE_EQ(loaded->max_pressure_Pa, 3000);
  std::ifstream in(dir / "scene.json");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = text.find("\"max_pressure_kPa\"");
  ASSERT_NE(at, std::string::npos) << text;
  const size_t value = text.find_first_of("0123456789", at);
  text.replace(value, text.find_first_of(",\n}", value) - value, "0");
  std::ofstream(dir / "scene.json") << text;
  const Result<SceneSpec> bad = LoadScene((dir / "scene.json").string());
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("max_pressure_kPa"), std::string::npos) << bad.message();
  // Without the key: no limit.
  s.max_pressure_Pa = 0;
  ASSERT_TRUE(ExportScene(s, dir.string()).ok());
  EXPECT_EQ(LoadScene((dir / "scene.json").string())->max_pressure_Pa, 0);
}

}  // namespace
}  // namespace kgd
