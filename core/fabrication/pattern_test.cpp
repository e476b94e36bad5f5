// Pattern pieces: flat garments stay exact, sleeves open along seams into disks whose flat shapes
// keep the rest shape's areas and angles, and seams that are not paths are refused by name.
#include "core/fabrication/pattern.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/fabrication/cut_sheet.h"
#include "core/mesh/topology.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/scene_file.h"

namespace kgd {
namespace {

TEST(Pattern, AFlatGarmentIsOnePieceWithNoDistortion) {
  Result<SceneSpec> s = PullTestScene("line");
  ASSERT_TRUE(s.ok());
  Result<Pattern> p = CutPattern(s->garment);
  ASSERT_TRUE(p.ok()) << p.message();
  ASSERT_EQ(p->pieces.size(), 1u);
  EXPECT_TRUE(p->seams.empty());
  const Distortion& d = p->pieces[0].distortion;
  EXPECT_LT(d.area_max, 1e-9);
  EXPECT_LT(d.angle_max_deg, 1e-7);
}

// A tube of radius r, height h: n rulings around, m rows up; every triangle spans two rulings, so the
// mesh unrolls without distortion (closed form: a rectangle n x chord by h).
TriMesh Tube(double r, double h, int n, int m) {
  TriMesh t;
  t.vertices.resize(n * (m + 1), 3);
  for (int j = 0; j <= m; ++j)
    for (int i = 0; i < n; ++i) t.vertices.row(j * n + i) << r * std::cos(2 * M_PI * i / n), h * j / m, r * std::sin(2 * M_PI * i / n);
  t.faces.resize(2 * n * m, 3);
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * n + i, b = j * n + (i + 1) % n, c = a + n, d = b + n;
      t.faces.row(2 * (j * n + i)) << a, c, b;
      t.faces.row(2 * (j * n + i) + 1) << b, c, d;
    }
  return t;
}

TEST(Pattern, ATubeUnrollsIntoItsRectangleExactlyWithItsSeamSidesEqual) {
  const double r = 0.04, h = 0.2;
  const int n = 24, m = 20;
  Result<Pattern> p = CutPattern(Tube(r, h, n, m));
  ASSERT_TRUE(p.ok()) << p.message();
  ASSERT_EQ(p->pieces.size(), 1u) << "one seam opens a developable tube";
  ASSERT_EQ(p->seams.size(), 1u);
  const PatternPiece& piece = p->pieces[0];
  EXPECT_LT(piece.distortion.area_max, 1e-6);
  EXPECT_LT(piece.distortion.angle_max_deg, 1e-4);
  // The rectangle: its side lengths are the rulings' chords around and the height up.
  const double chord = 2 * r * std::sin(M_PI / n);
  Positions flat3(piece.flat.rows(), 3);
  flat3 << piece.flat, Eigen::VectorXd::Zero(piece.flat.rows());
  EXPECT_NEAR(FaceAreas(flat3, piece.faces).sum(), n * chord * h, 1e-9);
  const std::vector<SeamSides> sides = SeamLengths(*p);
  EXPECT_NEAR(sides[0].a_mm, 1000 * h, 1e-3);
  EXPECT_NEAR(sides[0].b_mm, 1000 * h, 1e-3);
}

// Whether two non-adjacent edges of the closed polygon cross (a sweep would be faster; a few thousand
// edges are fine).
bool SelfCrossing(const FlatPositions& p) {
  const int n = static_cast<int>(p.rows());
  auto orient = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  };
  for (int i = 0; i < n; ++i)
    for (int j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;
      const Eigen::Vector2d a = p.row(i), b = p.row((i + 1) % n), c = p.row(j), d = p.row((j + 1) % n);
      if (orient(a, b, c) * orient(a, b, d) < 0 && orient(c, d, a) * orient(c, d, b) < 0) return true;
    }
  return false;
}

// The acceptance of a garment's pattern: every piece's flat area equals its rest area within its
// reported distortion; area distortion <= 2 % mean and <= 5 % max, angle distortion <= 2 degrees mean;
// outlines that do not cross themselves; the two sides of every seam equal within 0.5 mm.
void ExpectPattern(const std::string& name, const TriMesh& garment) {
  Result<Pattern> p = CutPattern(garment);
  ASSERT_TRUE(p.ok()) << p.message();
  ASSERT_GE(p->pieces.size(), 1u);
  for (size_t i = 0; i < p->pieces.size(); ++i) {
    const PatternPiece& piece = p->pieces[i];
    const Distortion& d = piece.distortion;
    const double area3 = FaceAreas(piece.rest, piece.faces).sum();
    Positions flat3(piece.flat.rows(), 3);
    flat3 << piece.flat, Eigen::VectorXd::Zero(piece.flat.rows());
    const double area2 = FaceAreas(flat3, piece.faces).sum();
    std::printf("%s piece %zu: %zu faces; flat area %.6g m^2 vs %.6g (%.3f %%); area distortion mean %.3f %% max %.3f %%; angle mean %.3f max %.3f deg\n",
                name.c_str(), i + 1, piece.garment_faces.size(), area2, area3, 100 * (area2 / area3 - 1), 100 * d.area_mean, 100 * d.area_max,
                d.angle_mean_deg, d.angle_max_deg);
    EXPECT_LE(d.area_mean, 0.02) << name << " piece " << i + 1;
    EXPECT_LE(d.area_max, 0.05) << name << " piece " << i + 1;
    EXPECT_LE(d.angle_mean_deg, 2.0) << name << " piece " << i + 1;
    EXPECT_NEAR(area2, area3, d.area_mean * area3 + 1e-9) << name << " piece " << i + 1;
    // The outline is a simple polygon: no two of its edges cross.
    FlatPositions outline(piece.outline.size(), 2);
    for (size_t k = 0; k < piece.outline.size(); ++k) outline.row(k) = piece.flat.row(piece.outline[k]);
    EXPECT_GT(SignedArea(outline), 0) << "counter-clockwise";
    EXPECT_FALSE(SelfCrossing(outline)) << name << " piece " << i + 1;
  }
  const std::vector<SeamSides> sides = SeamLengths(*p);
  ASSERT_EQ(sides.size(), p->seams.size());
  for (size_t i = 0; i < sides.size(); ++i) {
    std::printf("%s seam %zu: sides %.3f and %.3f mm\n", name.c_str(), i + 1, sides[i].a_mm, sides[i].b_mm);
    EXPECT_GT(sides[i].a_mm, 0);
    EXPECT_NEAR(sides[i].a_mm, sides[i].b_mm, 0.5) << name << " seam " << i + 1 << ": the two sides sewn together";
  }
}

void ExpectSleeve(const std::string& name) {
  Result<SceneSpec> s = BuiltinScene(name);
  ASSERT_TRUE(s.ok()) << s.message();
  ExpectPattern(name, s->garment);
}

TEST(Pattern, TheArmSleeveOpensIntoPiecesWithinTheDistortionLimitsAndSeamsThatSew) { ExpectSleeve("arm_flexion"); }
TEST(Pattern, TheKneeSleeveOpensIntoPiecesWithinTheDistortionLimitsAndSeamsThatSew) { ExpectSleeve("knee_flexion"); }

// The MakeHuman arm sleeve (../shared/bodies, subdivided twice as the paper does), when it is there.
TEST(Pattern, TheMakeHumanArmSleeveOpensIntoPiecesWithinTheDistortionLimitsAndSeamsThatSew) {
  const std::filesystem::path bodies = std::filesystem::path(KGD_SOURCE_DIR) / ".." / "shared" / "bodies" / "makehuman";
  if (!std::filesystem::exists(bodies / "rest.obj")) GTEST_SKIP() << "no real bodies at " << bodies.string() << " (../shared/bodies is not part of a clone)";
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "kgd_pattern_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "sleeve.json") << R"({"name": "makehuman_sleeve_arm", "body": {"rest": ")" << (bodies / "rest.obj").string()
                                     << R"(", "deformed": ")" << (bodies / "arm_flexion" / "pose.obj").string() << R"("},
      "garment": {"region": ")" << (bodies / "regions" / "sleeve_arm.faces.txt").string() << R"(", "subdivisions": 2}})";
  Result<SceneSpec> s = LoadScene((dir / "sleeve.json").string());
  ASSERT_TRUE(s.ok()) << s.message();
  ExpectPattern("makehuman sleeve_arm", s->garment);
}

TEST(Pattern, ASeamThatIsNotAPathIsRefusedByName) {
  Result<SceneSpec> s = PullTestScene("line");
  ASSERT_TRUE(s.ok());
  PatternOptions o;
  o.seams = {{{0, 500}}};
  Result<Pattern> p = CutPattern(s->garment, o);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.message().find("seam 1 is not a path along edges"), std::string::npos) << p.message();
}

}  // namespace
}  // namespace kgd
