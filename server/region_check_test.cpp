// The studio's region check (server/region_check.h) on the studio test torso (tests/data/studio): what it
// answers equals what core's region functions and the garment cut give on the same faces, the mirror of
// the painted half is the region `kgd region`'s rules select, and bad input is named.
#include "server/region_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numeric>
#include <set>
#include <sstream>

#include "core/beso/design_constraints.h"
#include "core/mesh/mesh_io.h"
#include "core/scene/body_garment.h"
#include "tests/studio_test_data.h"

namespace kgd::server {
namespace {

const std::string& kDir = kStudioDataDir;

struct Studio {
  std::string obj = ReadText(kDir + "rest.obj");
  TriMesh body = *ParseMesh(obj, "rest.obj");
  Positions centroids = FaceCentroids(body.vertices, body.faces);

  // The region sleeve_rules.txt's rules select: "--plane X,Y,Z,NX,NY,NZ" per line.
  std::vector<int> RulesRegion() const {
    RegionSpec spec;
    spec.groups.emplace_back();
    std::istringstream lines(ReadText(kDir + "sleeve_rules.txt"));
    for (std::string flag, value; lines >> flag >> value;) {
      EXPECT_EQ(flag, "--plane");
      double v[6];
      char comma;
      std::istringstream in(value);
      in >> v[0] >> comma >> v[1] >> comma >> v[2] >> comma >> v[3] >> comma >> v[4] >> comma >> v[5];
      spec.groups[0].rules.push_back(PlaneRule{{v[0], v[1], v[2]}, {v[3], v[4], v[5]}});
    }
    EXPECT_EQ(spec.groups[0].rules.size(), 2u);
    Result<std::vector<int>> faces = SelectRegion(body, spec);
    EXPECT_TRUE(faces.ok()) << faces.message();
    return faces.ok() ? *faces : std::vector<int>{};
  }
  // Of `faces`, those whose centroid has x < 0 (left), or its y within [y0, y1].
  std::vector<int> Left(const std::vector<int>& faces) const {
    std::vector<int> out;
    for (int f : faces)
      if (centroids(f, 0) < 0) out.push_back(f);
    return out;
  }
  std::vector<int> Between(double y0, double y1) const {
    std::vector<int> out;
    for (int f = 0; f < centroids.rows(); ++f)
      if (centroids(f, 1) >= y0 && centroids(f, 1) <= y1) out.push_back(f);
    return out;
  }
  RegionCheckRequest Request(const std::vector<int>& faces) const {
    RegionCheckRequest r;
    r.body_name = "rest.obj";
    r.body_bytes = obj;
    r.faces = JoinFaces(faces);
    return r;
  }
};

const Studio& S() {
  static const Studio s;
  return s;
}

TEST(RegionCheck, ATubeHasTwoLoopsAndTheAreaBandsAndCountsOfCoreOnTheSameFaces) {
  const std::vector<int> band = S().RulesRegion();
  ASSERT_EQ(band.size(), 800u);
  RegionCheckRequest r = S().Request(band);
  r.attach_width_m = "0.02";
  Result<RegionCheckAnswer> a = CheckPaintedRegion(r, 1.0);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(a->valid) << a->refusal;
  EXPECT_EQ(a->faces, band) << "the rules' faces are tidy already: the check keeps them";
  Result<Region> region = CheckRegion(S().body, band);
  ASSERT_TRUE(region.ok());
  EXPECT_EQ(a->region.area_m2, region->area_m2);
  EXPECT_EQ(a->region.vertices, region->vertices);
  ASSERT_EQ(a->region.loops.size(), 2u);
  for (size_t l = 0; l < 2; ++l) {
    EXPECT_EQ(a->region.loops[l].vertices, region->loops[l].vertices);
    EXPECT_EQ(a->region.loops[l].length_m, region->loops[l].length_m);
  }
  Result<std::vector<AttachmentBand>> bands = AttachmentBands(S().body, *region, 0.02);
  ASSERT_TRUE(bands.ok());
  // The committed face lists (what `kgd region` wrote, scene.json names) are these: the page's test compares with them.
  EXPECT_EQ(*ReadIndexList(kDir + "garment_region.txt"), band);
  std::set<int> attached;
  for (const AttachmentBand& b : *bands) attached.insert(b.faces.begin(), b.faces.end());
  EXPECT_EQ(*ReadIndexList(kDir + "attachment_body_faces.txt"), std::vector<int>(attached.begin(), attached.end()));
  ASSERT_EQ(a->bands.size(), bands->size());
  for (size_t b = 0; b < bands->size(); ++b) {
    EXPECT_EQ(a->bands[b].faces, (*bands)[b].faces);
    EXPECT_EQ(a->bands[b].area_m2, (*bands)[b].area_m2);
    EXPECT_EQ(a->bands[b].faces.size(), 80u) << "one ring of quads along each loop within 2 cm (rings are 2 cm apart)";
  }
  // Midpoint subdivision: 4 faces per face, a vertex more per edge (E = (3F + boundary edges) / 2).
  const int boundary_edges = static_cast<int>(region->loops[0].vertices.size() + region->loops[1].vertices.size());
  EXPECT_EQ(a->subdivided_faces, 4 * 800);
  EXPECT_EQ(a->subdivided_vertices, region->vertices + (3 * 800 + boundary_edges) / 2);
  // Predictions grow with the preset's accuracy and with the machine factor.
  EXPECT_LT(a->predicted_job_s.at("draft"), a->predicted_job_s.at("standard"));
  EXPECT_LT(a->predicted_job_s.at("standard"), a->predicted_job_s.at("precise"));
  Result<RegionCheckAnswer> slower = CheckPaintedRegion(r, 3.0);
  EXPECT_GT(slower->predicted_job_s.at("standard"), a->predicted_job_s.at("standard"));
  r.motions = "2";  // a design that weighs two motions simulates two garments per iteration
  Result<RegionCheckAnswer> two = CheckPaintedRegion(r, 1.0);
  EXPECT_GT(two->predicted_job_s.at("standard"), a->predicted_job_s.at("standard"));
}

TEST(RegionCheck, TheMirrorOfThePaintedHalfIsTheRegionOfTheRules) {
  // The studio torso is small and mirror symmetric about x = 0 to rounding: every face has its image.
  EXPECT_LE(S().body.faces.rows(), 4000);
  const Result<MirrorPairing> pairing = PairMirrorFaces(S().body, SymmetryPlane{});
  ASSERT_TRUE(pairing.ok()) << pairing.message();
  EXPECT_LT(pairing->max_distance_m, 1e-9);
  const std::vector<int> band = S().RulesRegion();
  const std::vector<int> half = S().Left(band);
  ASSERT_EQ(half.size(), 400u);
  RegionCheckRequest r = S().Request(half);
  r.keep_out = JoinFaces(S().Left(S().Between(1.08, 1.12)));
  r.mirror = "true";
  Result<RegionCheckAnswer> a = CheckPaintedRegion(r, 1.0);
  ASSERT_TRUE(a.ok()) << a.message();
  EXPECT_TRUE(a->mirrored);
  EXPECT_TRUE(a->valid) << a->refusal;
  EXPECT_EQ(a->faces, band);
  EXPECT_EQ(a->region.loops.size(), 2u);
  EXPECT_EQ(a->keep_out, S().Between(1.08, 1.12)) << "the keep-out list is mirrored too";
  // Unmirrored, the half is a strip: one piece with one loop round it.
  r.mirror = "";
  r.keep_out = "";
  a = CheckPaintedRegion(r, 1.0);
  ASSERT_TRUE(a.ok()) << a.message();
  EXPECT_FALSE(a->mirrored);
  EXPECT_EQ(a->region.loops.size(), 1u);
  EXPECT_LT(a->faces.size(), half.size()) << "the strip's corners are ears, which tidying removes";
  EXPECT_EQ(a->faces, TidyRegionBoundary(S().body.faces, half));
}

// A body symmetric only within the tolerance (as the parametric body, whose surface-nets grid is not
// centred on the plane), where the mirror pairing is not one-to-one: a tube of radius 15 cm whose
// right side (x > 0) has four times the columns of its left. Its left side's faces of rows 5..14 mirrored
// are those rows all round: every right face is the partner of none or of a painted face's image.
TEST(RegionCheck, TheMirrorOnABodySymmetricWithinTheToleranceLeavesNoGap) {
  constexpr int kRows = 20, kRight = 80, kLeft = 20, kAround = kRight + kLeft;
  std::ostringstream obj;
  obj.precision(12);
  for (int j = 0; j <= kRows; ++j)
    for (int k = 0; k < kAround; ++k) {
      const double t = k < kRight ? M_PI * k / kRight : M_PI + M_PI * (k - kRight) / kLeft;
      obj << "v " << 0.15 * std::sin(t) << " " << 0.02 * j << " " << 0.15 * std::cos(t) << "\n";
    }
  std::vector<int> painted, expected;
  int f = 0;
  for (int j = 0; j < kRows; ++j)
    for (int k = 0; k < kAround; ++k, f += 2) {
      const int v00 = j * kAround + k + 1, v01 = j * kAround + (k + 1) % kAround + 1, v10 = v00 + kAround, v11 = v01 + kAround;
      obj << "f " << v00 << " " << v01 << " " << v11 << "\nf " << v00 << " " << v11 << " " << v10 << "\n";
      if (j < 5 || j >= 15) continue;
      expected.insert(expected.end(), {f, f + 1});
      if (k >= kRight) painted.insert(painted.end(), {f, f + 1});
    }
  RegionCheckRequest r;
  r.body_name = "tube.obj";
  r.body_bytes = obj.str();
  r.faces = JoinFaces(painted);
  r.mirror = "true";
  Result<RegionCheckAnswer> a = CheckPaintedRegion(r, 1.0);
  ASSERT_TRUE(a.ok()) << a.message();
  EXPECT_TRUE(a->valid) << a->refusal;
  EXPECT_EQ(a->region.loops.size(), 2u);
  EXPECT_EQ(a->faces, expected);
}

TEST(RegionCheck, TwoPiecesAreRefusedInTheWordsOfKgdRegion) {
  std::vector<int> two = S().Between(1.0, 1.06);
  for (int f : S().Between(1.14, 1.2)) two.push_back(f);
  Result<RegionCheckAnswer> a = CheckPaintedRegion(S().Request(two), 1.0);
  ASSERT_TRUE(a.ok()) << a.message();
  EXPECT_FALSE(a->valid);
  const Result<Region> core = CheckRegion(S().body, two);
  ASSERT_FALSE(core.ok());
  EXPECT_EQ(a->refusal, "rest.obj: " + core.message()) << "kgd region prints BODY: and CheckRegion's message";
  EXPECT_NE(a->refusal.find("piece"), std::string::npos) << a->refusal;
  EXPECT_EQ(a->predicted_job_s.size(), 3u) << "an invalid region still gets its prediction";
}

TEST(RegionCheck, KeepInBodyFacesBecomeTheGarmentFacesCutFromThem) {
  const std::vector<int> band = S().RulesRegion();
  const std::vector<int> keep_in = S().Between(1.0, 1.02);  // the ring along the lower loop
  ASSERT_EQ(keep_in.size(), 80u);
  for (int s : {0, 1, 2}) {
    RegionCheckRequest r = S().Request(band);
    r.keep_in = JoinFaces(keep_in);
    r.subdivisions = std::to_string(s);
    Result<RegionCheckAnswer> a = CheckPaintedRegion(r, 1.0);
    ASSERT_TRUE(a.ok()) << a.message();
    ASSERT_TRUE(a->valid);
    EXPECT_EQ(a->keep_in, keep_in);
    EXPECT_EQ(a->keep_in_garment_faces.size(), keep_in.size() << (2 * s)) << "subdivisions " << s;
    EXPECT_TRUE(a->keep_out_garment_faces.empty());
    // They are the garment faces that lie on those body faces: centroids within the ring's heights.
    Result<GarmentCut> cut = CutGarment(S().body.faces, S().body.vertices, band, {}, s, "region", "");
    ASSERT_TRUE(cut.ok());
    const Positions c = FaceCentroids(cut->garment.vertices, cut->garment.faces);
    std::set<int> in(a->keep_in_garment_faces.begin(), a->keep_in_garment_faces.end());
    for (int g = 0; g < c.rows(); ++g) EXPECT_EQ(in.count(g) == 1, c(g, 1) < 1.02 + 1e-9) << "garment face " << g << " at y " << c(g, 1);
  }
}

TEST(RegionCheck, BadInputIsNamed) {
  const std::vector<int> band = S().RulesRegion();
  auto refused = [](const RegionCheckRequest& r) {
    Result<RegionCheckAnswer> a = CheckPaintedRegion(r, 1.0);
    EXPECT_FALSE(a.ok());
    return a.ok() ? std::string() : a.message();
  };
  RegionCheckRequest r = S().Request(band);
  r.body_name = "torso.obj";
  r.body_bytes = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 zz\n";
  EXPECT_NE(refused(r).find("part 'body': torso.obj:5"), std::string::npos) << refused(r);

  r = S().Request(band);
  r.faces += " 99999";
  EXPECT_NE(refused(r).find("face 99999 (item 801) is out of range: the body has 2480 faces"), std::string::npos) << refused(r);
  r.faces = "12 x7";
  EXPECT_NE(refused(r).find("part 'faces': item 2 'x7'"), std::string::npos) << refused(r);
  r.faces = " \n";
  EXPECT_NE(refused(r).find("part 'faces': the region is empty"), std::string::npos) << refused(r);
  r = S().Request(band);
  r.attach_width_m = "2cm";
  EXPECT_NE(refused(r).find("part 'attachWidthM': '2cm' is not a finite number"), std::string::npos) << refused(r);
  r = S().Request(band);
  r.max_mesh_faces = 3000;
  r.subdivisions = "2";
  EXPECT_NE(refused(r).find("part 'subdivisions': the garment's faces (800 x 4^2) 12800 is over the limit of 3000 (--max-mesh-faces)"), std::string::npos)
      << refused(r);
  r.max_mesh_faces = 2000;
  EXPECT_NE(refused(r).find("part 'body': rest.obj: faces 2480 is over the limit of 2000 (--max-mesh-faces)"), std::string::npos) << refused(r);
  r.max_mesh_vertices = 1000;
  EXPECT_NE(refused(r).find("part 'body': rest.obj: vertices 1242 is over the limit of 1000 (--max-mesh-vertices)"), std::string::npos) << refused(r);
  r = S().Request(band);
  r.keep_out = "0";
  EXPECT_NE(refused(r).find("part 'keepOut': face 0 at"), std::string::npos) << refused(r);

  // A body whose right side (x > 0) is widened by half: the left side's faces have no mirror face.
  TriMesh wide = S().body;
  for (Eigen::Index v = 0; v < wide.vertices.rows(); ++v)
    if (wide.vertices(v, 0) > 0) wide.vertices(v, 0) *= 1.5;
  std::ostringstream obj;
  obj.precision(12);
  for (Eigen::Index v = 0; v < wide.vertices.rows(); ++v) obj << "v " << wide.vertices.row(v) << "\n";
  for (Eigen::Index f = 0; f < wide.faces.rows(); ++f) obj << "f " << (wide.faces.row(f).array() + 1) << "\n";
  r = S().Request(S().Left(band));
  r.body_name = "wide.obj";
  r.body_bytes = obj.str();
  r.mirror = "true";
  const std::string m = refused(r);
  EXPECT_NE(m.find("part 'mirror': the body (wide.obj) is not mirror symmetric about the plane through (0, 0, 0) with normal (1, 0, 0): face "),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("has no mirror face"), std::string::npos) << m;
  // Unmirrored, the same body and faces are a region.
  r.mirror = "false";
  Result<RegionCheckAnswer> a = CheckPaintedRegion(r, 1.0);
  ASSERT_TRUE(a.ok()) << a.message();
  EXPECT_TRUE(a->valid) << a->refusal;
}

}  // namespace
}  // namespace kgd::server
