// Pattern pieces: flat garments stay exact, sleeves open along seams into disks whose flat shapes
// keep the rest shape's areas and angles, and seams that are not paths are refused by name.
#include "core/fabrication/pattern.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

#include "core/fabrication/cut_sheet.h"
#include "core/fabrication/sew_line.h"
#include "core/mesh/topology.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/paper_scenes.h"
#include "core/testing/paper_test_scene.h"
#include "core/scene/scene_file.h"

namespace kgd {
namespace {

// A piece's distortion measured here from the garment itself, not from what CutPattern reports: each
// piece face is mapped back to its garment face (the same corners, in order), its 3D triangle taken
// from the garment's vertices and its flat triangle from the piece's flat positions; corner angles from
// the law of cosines. Per face: area |A_flat / A_3d - 1| and the largest corner angle change (degrees),
// area-weighted means and maxima. Flipped flat triangles are counted (and score 180 degrees).
struct Measured {
  double area_mean = 0, area_max = 0, angle_mean_deg = 0, angle_max_deg = 0;
  int flipped = 0, wrong_corners = 0;
};

std::array<double, 3> Angles(const std::array<Eigen::Vector3d, 3>& p) {
  std::array<double, 3> l, a;
  for (int k = 0; k < 3; ++k) l[k] = (p[(k + 2) % 3] - p[(k + 1) % 3]).norm();  // side opposite corner k
  for (int k = 0; k < 3; ++k) {
    const double b = l[(k + 1) % 3], c = l[(k + 2) % 3];
    a[k] = std::acos(std::clamp((b * b + c * c - l[k] * l[k]) / (2 * b * c), -1.0, 1.0));
  }
  return a;
}

Measured MeasureFromGarment(const TriMesh& garment, const PatternPiece& piece) {
  Measured m;
  double total = 0;
  for (Eigen::Index f = 0; f < piece.faces.rows(); ++f) {
    const int g = piece.garment_faces[f];
    std::array<Eigen::Vector3d, 3> p, q;
    for (int k = 0; k < 3; ++k) {
      const int v = piece.faces(f, k);
      m.wrong_corners += piece.garment_vertex[v] != garment.faces(g, k);
      p[k] = garment.vertices.row(garment.faces(g, k)).transpose();
      q[k] = Eigen::Vector3d(piece.flat(v, 0), piece.flat(v, 1), 0);
    }
    const double a3 = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).norm();
    const double a2 = 0.5 * (q[1] - q[0]).cross(q[2] - q[0]).z();  // signed: counter-clockwise positive
    const double area = std::abs(a2 / a3 - 1);
    const std::array<double, 3> A = Angles(p), B = Angles(q);
    double angle = 0;
    for (int k = 0; k < 3; ++k) angle = std::max(angle, std::abs(A[k] - B[k]) * 180 / M_PI);
    if (a2 <= 0) ++m.flipped, angle = 180;
    m.area_mean += a3 * area;
    m.angle_mean_deg += a3 * angle;
    m.area_max = std::max(m.area_max, area);
    m.angle_max_deg = std::max(m.angle_max_deg, angle);
    total += a3;
  }
  m.area_mean /= total;
  m.angle_mean_deg /= total;
  return m;
}

// The figures CutPattern reports are the ones measured here (to round-off; it zeroes noise below
// 1e-12 in area and 1e-9 degrees in angle).
void ExpectReportedIsMeasured(const Distortion& d, const Measured& m, const std::string& what) {
  EXPECT_NEAR(d.area_mean, m.area_mean, 1e-9 + 1e-6 * m.area_mean) << what;
  EXPECT_NEAR(d.area_max, m.area_max, 1e-9 + 1e-6 * m.area_max) << what;
  EXPECT_NEAR(d.angle_mean_deg, m.angle_mean_deg, 1e-6 + 1e-6 * m.angle_mean_deg) << what;
  EXPECT_NEAR(d.angle_max_deg, m.angle_max_deg, 1e-6 + 1e-6 * m.angle_max_deg) << what;
}

TEST(Pattern, AFlatGarmentIsOnePieceWithNoDistortion) {
  Result<SceneSpec> s = PullTestScene("line");
  ASSERT_TRUE(s.ok());
  Result<Pattern> p = CutPattern(s->garment);
  ASSERT_TRUE(p.ok()) << p.message();
  ASSERT_EQ(p->pieces.size(), 1u);
  EXPECT_TRUE(p->seams.empty());
  const Measured m = MeasureFromGarment(s->garment, p->pieces[0]);
  EXPECT_EQ(m.wrong_corners, 0);
  EXPECT_EQ(m.flipped, 0);
  EXPECT_LT(m.area_max, 1e-9);
  EXPECT_LT(m.angle_max_deg, 1e-6);
  ExpectReportedIsMeasured(p->pieces[0].distortion, m, "the flat sample");
  // Its sew line: the rectangle's four corners kept, straight between them.
  const PatternPiece& piece = p->pieces[0];
  EXPECT_EQ(piece.sew_corners.size(), 4u);
  EXPECT_LT(MaxTurningDeg(piece.sew_line, piece.sew_corners), 1e-6);
  const Eigen::RowVector2d extent = piece.sew_line.colwise().maxCoeff() - piece.sew_line.colwise().minCoeff();
  const Eigen::RowVector2d outline_extent = piece.flat.colwise().maxCoeff() - piece.flat.colwise().minCoeff();
  EXPECT_NEAR((extent - outline_extent).norm(), 0, 1e-12);
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
  const TriMesh tube = Tube(r, h, n, m);
  Result<Pattern> p = CutPattern(tube);
  ASSERT_TRUE(p.ok()) << p.message();
  ASSERT_EQ(p->pieces.size(), 1u) << "one seam opens a developable tube";
  ASSERT_EQ(p->seams.size(), 1u);
  const PatternPiece& piece = p->pieces[0];
  const Measured measured = MeasureFromGarment(tube, piece);
  EXPECT_EQ(measured.wrong_corners, 0);
  EXPECT_EQ(measured.flipped, 0);
  EXPECT_LT(measured.area_max, 1e-6);
  EXPECT_LT(measured.angle_max_deg, 1e-4);
  ExpectReportedIsMeasured(piece.distortion, measured, "the tube");
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

// The distance in the plane from q to the closed polyline p.
double DistanceToLoop(const Eigen::Vector2d& q, const FlatPositions& p) {
  double best = 1e300;
  for (Eigen::Index j = 0; j < p.rows(); ++j) {
    const Eigen::Vector2d a = p.row(j), b = p.row((j + 1) % p.rows());
    const double t = std::clamp((q - a).dot(b - a) / std::max((b - a).squaredNorm(), 1e-300), 0.0, 1.0);
    best = std::min(best, (q - a - t * (b - a)).norm());
  }
  return best;
}

// A piece's sew line as a tailor would cut it: its corners are the outline's vertices at seam ends,
// exactly, and no others; away from them it turns by less than 10 degrees between consecutive segments
// (points about a millimetre apart), where a `stepped` outline (a coarse mesh's) turns by more than 30;
// every point within 1 mm of the
// outline (in the plane, and on the body as reported); it does not cross itself; and the cut line, the sew
// line moved out by the seam allowance, neither crosses itself nor comes nearer the sew line than the
// allowance.
void ExpectSewLine(const std::string& what, const Pattern& pattern, size_t i, bool stepped) {
  const PatternPiece& piece = pattern.pieces[i];
  std::set<int> ends;
  for (const Seam& seam : pattern.seams) ends.insert(seam.vertices.front()), ends.insert(seam.vertices.back());
  FlatPositions outline(piece.outline.size(), 2);
  std::vector<int> outline_corners;
  std::multiset<std::pair<double, double>> expected, got;
  for (size_t k = 0; k < piece.outline.size(); ++k) {
    outline.row(k) = piece.flat.row(piece.outline[k]);
    if (ends.count(piece.garment_vertex[piece.outline[k]])) outline_corners.push_back(k), expected.insert({outline(k, 0), outline(k, 1)});
  }
  for (int c : piece.sew_corners) got.insert({piece.sew_line(c, 0), piece.sew_line(c, 1)});
  EXPECT_EQ(got, expected) << what << ": the sew line's corners are the outline's seam ends";
  const double turning = MaxTurningDeg(piece.sew_line, piece.sew_corners), staircase = MaxTurningDeg(outline, outline_corners);
  double plane = 0;
  for (Eigen::Index j = 0; j < piece.sew_line.rows(); ++j) plane = std::max(plane, DistanceToLoop(piece.sew_line.row(j).transpose(), outline));
  std::printf("%s sew line: %zd points, turning max %.2f deg away from %zu corners (outline %.1f), deviation max %.3f mm\n", what.c_str(),
              piece.sew_line.rows(), turning, piece.sew_corners.size(), staircase, piece.sew_deviation_max_mm);
  if (stepped) EXPECT_GT(staircase, 30) << what << ": the outline steps at mesh edges";
  EXPECT_LT(turning, 10) << what;
  EXPECT_NEAR(piece.sew_turning_max_deg, turning, 1e-9) << what;
  EXPECT_LE(1000 * plane, 1.0) << what;
  EXPECT_LE(piece.sew_deviation_max_mm, 1.0) << what;
  EXPECT_FALSE(SelfCrossing(piece.sew_line)) << what;
  // The cut line: the sheet's layer 1 path of this piece (its sew line is layer 14, in mm).
  const Sheet sheet = PatternSheet(pattern, {}, SheetOptions{});
  std::vector<const SheetPath*> sew, cut;
  for (const SheetPath& path : sheet.paths)
    if (path.layer == "14") sew.push_back(&path);
    else if (path.layer == "1") cut.push_back(&path);
  ASSERT_EQ(cut.size(), pattern.pieces.size());
  FlatPositions sew_mm(sew[i]->points.size(), 2), cut_mm(cut[i]->points.size(), 2);
  for (size_t k = 0; k < sew[i]->points.size(); ++k) sew_mm.row(k) = sew[i]->points[k].transpose();
  for (size_t k = 0; k < cut[i]->points.size(); ++k) cut_mm.row(k) = cut[i]->points[k].transpose();
  double nearest = 1e300;
  for (Eigen::Index k = 0; k < cut_mm.rows(); ++k) nearest = std::min(nearest, DistanceToLoop(cut_mm.row(k).transpose(), sew_mm));
  EXPECT_FALSE(SelfCrossing(cut_mm)) << what << ": the cut line";
  EXPECT_GE(nearest, 0.99 * SheetOptions{}.seam_allowance_mm) << what << ": the cut line";
}

// The acceptance of a garment's pattern, measured from the garment and the flat pieces (MeasureFromGarment):
// every garment face in exactly one piece, no flat triangle flipped, area distortion <= 2 % mean and
// <= 5 % max, angle distortion <= 2 degrees mean; every piece's flat area equals its rest area within
// its mean area distortion; the figures CutPattern reports are these; outlines that do not cross
// themselves; sew lines as ExpectSewLine; the two sides of every seam, along the sew lines, equal within
// 0.5 mm.
void ExpectPattern(const std::string& name, const TriMesh& garment, bool stepped = true) {
  Result<Pattern> p = CutPattern(garment);
  ASSERT_TRUE(p.ok()) << p.message();
  ASSERT_GE(p->pieces.size(), 1u);
  std::vector<int> pieces_of_face(garment.faces.rows(), 0);
  for (const PatternPiece& piece : p->pieces)
    for (int f : piece.garment_faces) ++pieces_of_face[f];
  EXPECT_EQ(std::count(pieces_of_face.begin(), pieces_of_face.end(), 1), garment.faces.rows()) << name << ": a face in no piece or in two";
  for (size_t i = 0; i < p->pieces.size(); ++i) {
    const PatternPiece& piece = p->pieces[i];
    const std::string what = name + " piece " + std::to_string(i + 1);
    const Measured d = MeasureFromGarment(garment, piece);
    EXPECT_EQ(d.wrong_corners, 0) << what;
    EXPECT_EQ(d.flipped, 0) << what;
    const double area3 = FaceAreas(garment.vertices, garment.faces(piece.garment_faces, Eigen::all)).sum();
    Positions flat3(piece.flat.rows(), 3);
    flat3 << piece.flat, Eigen::VectorXd::Zero(piece.flat.rows());
    const double area2 = FaceAreas(flat3, piece.faces).sum();
    std::printf("%s piece %zu: %zu faces; flat area %.6g m^2 vs %.6g (%.3f %%); area distortion mean %.3f %% max %.3f %%; angle mean %.3f max %.3f deg\n",
                name.c_str(), i + 1, piece.garment_faces.size(), area2, area3, 100 * (area2 / area3 - 1), 100 * d.area_mean, 100 * d.area_max,
                d.angle_mean_deg, d.angle_max_deg);
    EXPECT_LE(d.area_mean, 0.02) << what;
    EXPECT_LE(d.area_max, 0.05) << what;
    EXPECT_LE(d.angle_mean_deg, 2.0) << what;
    EXPECT_NEAR(area2, area3, d.area_mean * area3 + 1e-9) << what;
    ExpectReportedIsMeasured(piece.distortion, d, what);
    // The outline is a simple polygon: no two of its edges cross.
    FlatPositions outline(piece.outline.size(), 2);
    for (size_t k = 0; k < piece.outline.size(); ++k) outline.row(k) = piece.flat.row(piece.outline[k]);
    EXPECT_GT(SignedArea(outline), 0) << "counter-clockwise";
    EXPECT_FALSE(SelfCrossing(outline)) << name << " piece " << i + 1;
    ExpectSewLine(what, *p, i, stepped);
  }
  const std::vector<SeamSides> sides = SeamLengths(*p);
  ASSERT_EQ(sides.size(), p->seams.size());
  for (size_t i = 0; i < sides.size(); ++i) {
    std::printf("%s seam %zu: sides %.3f and %.3f mm\n", name.c_str(), i + 1, sides[i].a_mm, sides[i].b_mm);
    EXPECT_GT(sides[i].a_mm, 0);
    EXPECT_NEAR(sides[i].a_mm, sides[i].b_mm, 0.5) << name << " seam " << i + 1 << ": the two sides sewn together";
  }
}

// The built-in scene's garment: cut from the body in its motion's rest pose, so the scene is built with
// the motion cut short to that pose (the same garment bit for bit, without posing the body through
// the motion's frames, which was most of the time of these tests).
void ExpectSleeve(const std::string& name) {
  Result<SceneSpec> s = PaperSceneAtRest(name);
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
  ExpectPattern("makehuman sleeve_arm", s->garment, /*stepped=*/false);
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
