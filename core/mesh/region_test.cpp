#include "core/mesh/region.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "core/mesh/topology.h"

namespace kgd {
namespace {

constexpr double kPi = std::numbers::pi;

// A closed cylinder about the z axis: `segments` vertices round each of rings + 1 rings from z = 0 to
// z = height (quads split into two triangles), and a fan at each end; counter-clockwise seen from outside.
TriMesh Cylinder(double radius, double height, int segments, int rings, const Eigen::Vector3d& offset = Eigen::Vector3d::Zero()) {
  TriMesh m;
  const int ring_vertices = segments * (rings + 1);
  m.vertices.resize(ring_vertices + 2, 3);
  for (int j = 0; j <= rings; ++j)
    for (int i = 0; i < segments; ++i) {
      const double t = 2 * kPi * i / segments;
      m.vertices.row(j * segments + i) = (Eigen::Vector3d(radius * std::cos(t), radius * std::sin(t), height * j / rings) + offset).transpose();
    }
  const int bottom = ring_vertices, top = ring_vertices + 1;
  m.vertices.row(bottom) = offset.transpose();
  m.vertices.row(top) = (offset + Eigen::Vector3d(0, 0, height)).transpose();
  m.faces.resize(2 * segments * rings + 2 * segments, 3);
  int k = 0;
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < segments; ++i) {
      const int a = j * segments + i, b = j * segments + (i + 1) % segments, c = b + segments, d = a + segments;
      m.faces.row(k++) << a, b, c;
      m.faces.row(k++) << a, c, d;
    }
  for (int i = 0; i < segments; ++i) {
    m.faces.row(k++) << bottom, (i + 1) % segments, i;
    m.faces.row(k++) << top, rings * segments + i, rings * segments + (i + 1) % segments;
  }
  return m;
}

// Two meshes as one (the second's indices shifted).
TriMesh Join(const TriMesh& a, const TriMesh& b) {
  TriMesh m;
  m.vertices.resize(a.vertices.rows() + b.vertices.rows(), 3);
  m.vertices << a.vertices, b.vertices;
  m.faces.resize(a.faces.rows() + b.faces.rows(), 3);
  m.faces << a.faces, (b.faces.array() + static_cast<int>(a.vertices.rows())).matrix();
  return m;
}

// A flat n x n grid of squares of side h in the plane z = 0, centred on the origin, each split into two
// right triangles.
TriMesh Grid(int n, double h) {
  TriMesh m;
  m.vertices.resize((n + 1) * (n + 1), 3);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.row(j * (n + 1) + i) << (i - n / 2.0) * h, (j - n / 2.0) * h, 0;
  m.faces.resize(2 * n * n, 3);
  int k = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
      m.faces.row(k++) << a, b, c;
      m.faces.row(k++) << a, c, d;
    }
  return m;
}

RegionSpec Spec(std::vector<RegionRule> rules) { return RegionSpec{{RegionGroup{RegionOp::kUnion, std::move(rules)}}}; }
PlaneRule Above(double z) { return {Eigen::Vector3d(0, 0, z), Eigen::Vector3d(0, 0, 1)}; }
PlaneRule Below(double z) { return {Eigen::Vector3d(0, 0, z), Eigen::Vector3d(0, 0, -2)}; }  // any length

Eigen::Vector3d CentroidOf(const TriMesh& m, int f) {
  return (m.vertices.row(m.faces(f, 0)) + m.vertices.row(m.faces(f, 1)) + m.vertices.row(m.faces(f, 2))).transpose() / 3.0;
}

bool Has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// A refusal names a face and its centroid.
void ExpectNamesAFaceAndAPoint(const std::string& m) {
  EXPECT_TRUE(Has(m, "face ")) << m;
  EXPECT_TRUE(Has(m, " at (")) << m;
  EXPECT_TRUE(Has(m, ") m")) << m;
}

// Radius 5 cm, 40 cm long, 48 segments, rings 1 cm apart.
const double kR = 0.05, kSide = 2 * kR * std::sin(kPi / 48), kPerimeter = 48 * kSide;
TriMesh Tube() { return Cylinder(kR, 0.4, 48, 40); }

TEST(Region, TwoPlanesGiveABandWithTwoLoopsOfKnownLengthAndArea) {
  const TriMesh tube = Tube();
  Result<std::vector<int>> faces = SelectRegion(tube, Spec({Above(0.1), Below(0.3)}));
  ASSERT_TRUE(faces.ok()) << faces.message();
  EXPECT_EQ(faces->size(), 2u * 48 * 20);  // the quads between rings 10 and 30
  for (int f : *faces) {
    EXPECT_GT(CentroidOf(tube, f).z(), 0.1);
    EXPECT_LT(CentroidOf(tube, f).z(), 0.3);
  }
  Result<Region> region = CheckRegion(tube, *faces);
  ASSERT_TRUE(region.ok()) << region.message();
  EXPECT_EQ(region->vertices, 21 * 48);
  EXPECT_NEAR(region->area_m2, kPerimeter * 0.2, 1e-12);
  ASSERT_EQ(region->loops.size(), 2u);
  for (const RegionLoop& loop : region->loops) {
    EXPECT_EQ(loop.vertices.size(), 48u);
    EXPECT_NEAR(loop.length_m, kPerimeter, 1e-12);
    EXPECT_NEAR(loop.centre_m.head<2>().norm(), 0, 1e-12);
    EXPECT_TRUE(std::abs(loop.centre_m.z() - 0.1) < 1e-12 || std::abs(loop.centre_m.z() - 0.3) < 1e-12) << loop.centre_m.z();
    EXPECT_GT(loop.outside_area_m2, 0.1 * kPerimeter);  // the tube beyond and its end cap: no hole
  }
  EXPECT_TRUE(region->filled_faces.empty());
}

TEST(Region, TidyingFillsNotchesAndRemovesEarsOfAnObliqueCut) {
  // A plane tilted 40 degrees from the tube's cross-section cuts its triangulated quads: each
  // triangle along the cut is in or out as its centroid falls, leaving notches and ears. Tidied, no
  // face outside has two edges on the region, none inside fewer than two, and the open end is shorter.
  const TriMesh tube = Tube();
  const PlaneRule oblique{Eigen::Vector3d(0, 0, 0.2), Eigen::Vector3d(std::sin(0.7), 0, std::cos(0.7))};
  RegionSpec raw = Spec({oblique, Below(0.35)});
  raw.tidy_boundary = false;
  const std::vector<int> zigzag = SelectRegion(tube, raw).value(), tidy = SelectRegion(tube, Spec({oblique, Below(0.35)})).value();
  const std::vector<std::vector<int>> across = FaceNeighbors(tube.faces);
  auto count = [&](const std::vector<int>& faces) {
    std::vector<char> in(tube.faces.rows(), 0);
    for (int f : faces) in[f] = 1;
    std::pair<int, int> notches_ears{0, 0};
    for (int f = 0; f < tube.faces.rows(); ++f) {
      int n = 0;
      for (int g : across[f]) n += in[g];
      if (!in[f] && n >= 2) ++notches_ears.first;
      if (in[f] && n <= 1) ++notches_ears.second;
    }
    return notches_ears;
  };
  EXPECT_GT(count(zigzag).first + count(zigzag).second, 0);
  EXPECT_EQ(count(tidy), std::make_pair(0, 0));
  const Result<Region> a = CheckRegion(tube, zigzag), b = CheckRegion(tube, tidy);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(b.ok()) << b.message();
  ASSERT_EQ(a->loops.size(), 2u);
  ASSERT_EQ(b->loops.size(), 2u);
  const double cut_a = std::max(a->loops[0].length_m, a->loops[1].length_m), cut_b = std::max(b->loops[0].length_m, b->loops[1].length_m);
  EXPECT_LT(cut_b, cut_a);  // 43.7 cm against 46.8 (the ellipse: 36.6 cm)
}

TEST(Region, AttachmentBandsHoldTheFacesWithinTheWidthOfEachLoopAlongTheSurface) {
  const TriMesh tube = Tube();
  Result<Region> region = CheckRegion(tube, SelectRegion(tube, Spec({Above(0.1), Below(0.3)})).value());
  ASSERT_TRUE(region.ok()) << region.message();
  const double width = 0.025;
  Result<std::vector<AttachmentBand>> bands = AttachmentBands(tube, *region, width);
  ASSERT_TRUE(bands.ok()) << bands.message();
  ASSERT_EQ(bands->size(), 2u);
  for (const AttachmentBand& band : *bands) {
    const double z_loop = region->loops[band.loop].centre_m.z();
    // Along the tube the distance to a loop is |z - z_loop|; a face's is its centroid's (the mean of
    // its corners'). In: every face within the width less 1 mm; out: every face beyond it plus 1 mm.
    std::vector<char> in(tube.faces.rows(), 0);
    for (int f : band.faces) in[f] = 1;
    for (int f : region->faces) {
      const double d = std::abs(CentroidOf(tube, f).z() - z_loop);
      if (d < width - 1e-3) {
        EXPECT_TRUE(in[f]) << "face " << f << " at " << d;
      }
      if (d > width + 1e-3) {
        EXPECT_FALSE(in[f]) << "face " << f << " at " << d;
      }
    }
    EXPECT_NEAR(band.area_m2 / kPerimeter, width, 0.34e-2);  // within a third of a ring of the width
  }
  const Result<std::vector<AttachmentBand>> none = AttachmentBands(tube, *region, 0.001);  // below a third of a ring
  ASSERT_FALSE(none.ok());
  EXPECT_TRUE(Has(none.message(), "boundary loop 1")) << none.message();
}

TEST(Region, GeodesicDistanceOnAFlatGridIsTheStraightLineWithinATenthOfAPercent) {
  const TriMesh grid = Grid(80, 0.005);  // 40 cm square, 5 mm squares
  const int centre = 40 * 81 + 40;
  const Eigen::VectorXd d = GeodesicDistances(grid.vertices, grid.faces, {{centre, 0.0}});
  double worst = 0;
  for (Eigen::Index v = 0; v < grid.vertices.rows(); ++v) {
    const double exact = grid.vertices.row(v).norm();
    if (exact > 0.02) worst = std::max(worst, std::abs(d[v] - exact) / exact);
  }
  EXPECT_LT(worst, 1e-3);  // Dijkstra along the edges: 41 % across the diagonals (two steps for one)
  RecordProperty("worst_relative_error", std::to_string(worst));
}

TEST(Region, GeodesicRuleOnAPlaneGivesADiscOfAreaPiRSquared) {
  const TriMesh grid = Grid(80, 0.005);
  const double radius = 0.1;
  Result<std::vector<int>> faces = SelectRegion(grid, Spec({GeodesicRule{Eigen::Vector3d(0.001, -0.002, 0.003), radius}}));
  ASSERT_TRUE(faces.ok()) << faces.message();
  Result<Region> region = CheckRegion(grid, *faces);
  ASSERT_TRUE(region.ok()) << region.message();
  EXPECT_NEAR(region->area_m2, kPi * radius * radius, 0.01 * kPi * radius * radius);
  ASSERT_EQ(region->loops.size(), 1u);
  // The loop runs along triangle edges: longer than the circle (1.18x here; 1.39x untidied).
  EXPECT_GT(region->loops[0].length_m, 2 * kPi * radius);
  EXPECT_LT(region->loops[0].length_m, 1.3 * 2 * kPi * radius);
  EXPECT_LT((region->loops[0].centre_m - Eigen::Vector3d(0.001, -0.002, 0)).norm(), 0.005);  // within a square
}

TEST(Region, GeodesicRuleMeasuresAlongTheSurfaceNotThroughSpace) {
  // From a point on the tube (r = 5 cm), the far side lies 2 r = 10 cm away through space but pi r =
  // 15.7 cm along the surface: a 12 cm disc reaches 12 cm up the tube and 12 / 5 rad = 137 degrees
  // round it (x = -3.7 cm), not to the far side (x = -5 cm).
  const TriMesh tube = Tube();
  Result<std::vector<int>> faces = SelectRegion(tube, Spec({GeodesicRule{Eigen::Vector3d(kR, 0, 0.2), 0.12}}));
  ASSERT_TRUE(faces.ok()) << faces.message();
  double min_x = 1, up = 0;
  for (int f : *faces) {
    const Eigen::Vector3d c = CentroidOf(tube, f);
    min_x = std::min(min_x, c.x());
    up = std::max(up, c.z() - 0.2);
  }
  EXPECT_GT(min_x, -0.040);
  EXPECT_LT(min_x, -0.033);
  EXPECT_GT(up, 0.11);
  EXPECT_LT(up, 0.12);
}

TEST(Region, NearKeepsThePieceNearestThePoint) {
  const TriMesh two = Join(Tube(), Cylinder(kR, 0.4, 48, 40, Eigen::Vector3d(0.5, 0, 0)));
  Result<std::vector<int>> both = SelectRegion(two, Spec({Above(0.1), Below(0.3)}));
  ASSERT_TRUE(both.ok()) << both.message();
  EXPECT_EQ(both->size(), 2u * 2 * 48 * 20);
  Result<std::vector<int>> second = SelectRegion(two, Spec({Above(0.1), Below(0.3), NearRule{Eigen::Vector3d(0.7, 0.1, 0.2)}}));
  ASSERT_TRUE(second.ok()) << second.message();
  EXPECT_EQ(second->size(), 2u * 48 * 20);
  for (int f : *second) EXPECT_GT(CentroidOf(two, f).x(), 0.4);
  Result<std::vector<int>> first = SelectRegion(two, Spec({Above(0.1), Below(0.3), NearRule{Eigen::Vector3d(-0.2, 0, 0.2)}}));
  ASSERT_TRUE(first.ok()) << first.message();
  for (int f : *first) EXPECT_LT(CentroidOf(two, f).x(), 0.1);
}

TEST(Region, UnionAndDifferenceCombineGroupsInOrder) {
  const TriMesh tube = Tube();
  const RegionSpec halves{{RegionGroup{RegionOp::kUnion, {Above(0.1), Below(0.2)}}, RegionGroup{RegionOp::kUnion, {Above(0.2), Below(0.3)}}}};
  EXPECT_EQ(SelectRegion(tube, halves).value(), SelectRegion(tube, Spec({Above(0.1), Below(0.3)})).value());
  const RegionSpec cut{{RegionGroup{RegionOp::kUnion, {Above(0.1), Below(0.3)}}, RegionGroup{RegionOp::kSubtract, {Above(0.2)}}}};
  EXPECT_EQ(SelectRegion(tube, cut).value(), SelectRegion(tube, Spec({Above(0.1), Below(0.2)})).value());
  // Subtracting everything leaves nothing, which is refused.
  const RegionSpec all{{RegionGroup{RegionOp::kUnion, {Above(0.1)}}, RegionGroup{RegionOp::kSubtract, {Above(-1.0)}}}};
  const Result<std::vector<int>> none = SelectRegion(tube, all);
  ASSERT_FALSE(none.ok());
  EXPECT_TRUE(Has(none.message(), "select no face")) << none.message();
}

TEST(Region, ARuleThatSelectsNothingOrIsMalformedIsNamed) {
  const TriMesh tube = Tube();
  const Result<std::vector<int>> beyond = SelectRegion(tube, Spec({Above(0.5)}));
  ASSERT_FALSE(beyond.ok());
  EXPECT_TRUE(Has(beyond.message(), "--plane 0,0,0.5,0,0,1: selects no face of the body")) << beyond.message();
  const Result<std::vector<int>> crossed = SelectRegion(tube, Spec({Above(0.3), Below(0.1)}));
  ASSERT_FALSE(crossed.ok());
  EXPECT_TRUE(Has(crossed.message(), "--plane 0,0,0.1,0,0,-2: leaves no face")) << crossed.message();
  const Result<std::vector<int>> zero = SelectRegion(tube, Spec({PlaneRule{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}}));
  ASSERT_FALSE(zero.ok());
  EXPECT_TRUE(Has(zero.message(), "normal")) << zero.message();
  const Result<std::vector<int>> no_radius = SelectRegion(tube, Spec({GeodesicRule{Eigen::Vector3d(kR, 0, 0.2), 0}}));
  ASSERT_FALSE(no_radius.ok());
  EXPECT_TRUE(Has(no_radius.message(), "radius")) << no_radius.message();
  const Result<std::vector<int>> off = SelectRegion(tube, Spec({GeodesicRule{Eigen::Vector3d(1, 0, 0.2), 0.1}}));
  ASSERT_FALSE(off.ok());
  EXPECT_TRUE(Has(off.message(), "from the surface")) << off.message();
  ExpectNamesAFaceAndAPoint(off.message());
  EXPECT_FALSE(SelectRegion(tube, RegionSpec{}).ok());
}

TEST(Region, TwoPiecesAreRefusedNamingAFaceOfEach) {
  const TriMesh tube = Tube();
  const RegionSpec two{{RegionGroup{RegionOp::kUnion, {Above(0.05), Below(0.15)}}, RegionGroup{RegionOp::kUnion, {Above(0.25), Below(0.35)}}}};
  const Result<Region> region = CheckRegion(tube, SelectRegion(tube, two).value());
  ASSERT_FALSE(region.ok());
  const std::string& m = region.message();
  EXPECT_TRUE(Has(m, "2 edge-connected pieces")) << m;
  EXPECT_TRUE(Has(m, "960 faces with face 480 at (")) << m;   // first face of ring 5
  EXPECT_TRUE(Has(m, "960 faces with face 2400 at (")) << m;  // first face of ring 25
  EXPECT_TRUE(Has(m, "--near")) << m;
}

TEST(Region, AHoleIsRefusedOrFilled) {
  // The band less a geodesic disc of 1.5 cm (4.6 cm^2 once tidied, below the 20 cm^2 a hole may have).
  const TriMesh tube = Tube();
  const RegionSpec holed{{RegionGroup{RegionOp::kUnion, {Above(0.1), Below(0.3)}},
                          RegionGroup{RegionOp::kSubtract, {GeodesicRule{Eigen::Vector3d(kR, 0, 0.2), 0.015}}}}};
  const std::vector<int> faces = SelectRegion(tube, holed).value();
  const Result<Region> refused = CheckRegion(tube, faces);
  ASSERT_FALSE(refused.ok());
  EXPECT_TRUE(Has(refused.message(), "hole")) << refused.message();
  EXPECT_TRUE(Has(refused.message(), "--fill-holes")) << refused.message();
  ExpectNamesAFaceAndAPoint(refused.message());
  // The same hole is an opening when holes may be no larger than 1 cm^2.
  EXPECT_TRUE(CheckRegion(tube, faces, {1e-4, false}).ok());
  const Result<Region> filled = CheckRegion(tube, faces, {kDefaultMaxHoleArea_m2, true});
  ASSERT_TRUE(filled.ok()) << filled.message();
  EXPECT_EQ(filled->faces, SelectRegion(tube, Spec({Above(0.1), Below(0.3)})).value());
  EXPECT_EQ(filled->faces.size(), faces.size() + filled->filled_faces.size());
  EXPECT_EQ(filled->loops.size(), 2u);
}

TEST(Region, ALoopOnTheMeshsOwnBoundaryIsAHole) {
  const TriMesh grid = Grid(20, 0.01);
  // Everything but a disc in the middle: its outer loop is the grid's edge (an opening of the mesh).
  // (Untidied: tidying would take the ears at the grid's corners, and the loop would border them.)
  const RegionSpec ring{{RegionGroup{RegionOp::kUnion, {Above(-1.0)}}, RegionGroup{RegionOp::kSubtract, {GeodesicRule{Eigen::Vector3d::Zero(), 0.05}}}},
                        false};
  const Result<Region> region = CheckRegion(grid, SelectRegion(grid, ring).value(), {0.0, false});
  ASSERT_FALSE(region.ok());
  EXPECT_TRUE(Has(region.message(), "own boundary")) << region.message();
  ExpectNamesAFaceAndAPoint(region.message());
}

TEST(Region, ABandOneFaceWideIsASliver) {
  const TriMesh tube = Tube();
  const Result<Region> ring = CheckRegion(tube, SelectRegion(tube, Spec({Above(0.2), Below(0.21)})).value());
  ASSERT_FALSE(ring.ok());
  EXPECT_TRUE(Has(ring.message(), "sliver")) << ring.message();
  EXPECT_TRUE(Has(ring.message(), "two boundary loops")) << ring.message();
  ExpectNamesAFaceAndAPoint(ring.message());
  // Two rings wide is no sliver.
  EXPECT_TRUE(CheckRegion(tube, SelectRegion(tube, Spec({Above(0.19), Below(0.21)})).value()).ok());
}

TEST(Region, TwoBlocksJoinedByOneRowOfSquaresAreASliver) {
  // A 20 x 20 grid of 1 cm squares: the squares of columns 0-7 and 12-19 in rows 5-14, joined by row 10.
  const TriMesh grid = Grid(20, 0.01);
  auto select = [&](int bridge_rows) {
    std::vector<int> faces;
    for (int j = 0; j < 20; ++j)
      for (int i = 0; i < 20; ++i) {
        const bool block = j >= 5 && j < 15 && (i < 8 || i >= 12);
        const bool bridge = j >= 10 && j < 10 + bridge_rows;
        if (block || (bridge && i >= 8 && i < 12)) faces.push_back(2 * (j * 20 + i)), faces.push_back(2 * (j * 20 + i) + 1);
      }
    return faces;
  };
  const Result<Region> thin = CheckRegion(grid, select(1), {0.0, false});
  ASSERT_FALSE(thin.ok());
  EXPECT_TRUE(Has(thin.message(), "sliver")) << thin.message();
  ExpectNamesAFaceAndAPoint(thin.message());
  const int f = std::stoi(thin.message().substr(thin.message().find("wide at face ") + 13));
  EXPECT_NEAR(CentroidOf(grid, f).y(), 0.005, 0.006) << thin.message();  // on the bridge's row
  EXPECT_TRUE(CheckRegion(grid, select(2), {0.0, false}).ok());
}

TEST(Region, APinchIsRefusedNamingTheVertex) {
  // A 6 x 6 grid of squares, less two opposite triangles at its centre vertex: one piece, whose faces
  // meet at the centre in two fans.
  const TriMesh grid = Grid(6, 0.01);
  const int centre = 3 * 7 + 3;
  std::vector<int> around;
  for (int f = 0; f < grid.faces.rows(); ++f)
    if ((grid.faces.row(f).array() == centre).any()) around.push_back(f);
  ASSERT_EQ(around.size(), 6u);
  std::vector<int> faces;
  for (int f = 0; f < grid.faces.rows(); ++f)
    if (f != around[0] && f != around[3]) faces.push_back(f);
  const Result<Region> region = CheckRegion(grid, faces, {0.0, false});
  ASSERT_FALSE(region.ok());
  EXPECT_TRUE(Has(region.message(), "pinched at vertex " + std::to_string(centre) + " at (0.0000, 0.0000, 0.0000) m")) << region.message();
  ExpectNamesAFaceAndAPoint(region.message());
}

TEST(Region, AnEdgeOfThreeFacesIsNotManifold) {
  TriMesh book;
  book.vertices.resize(5, 3);
  book.vertices << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1;
  book.faces.resize(3, 3);
  book.faces << 0, 1, 2, 1, 0, 3, 0, 1, 4;
  const Result<Region> region = CheckRegion(book, {0, 1, 2});
  ASSERT_FALSE(region.ok());
  EXPECT_TRUE(Has(region.message(), "not manifold: edge (0, 1) at (0.5000, 0.0000, 0.0000) m has 3 of its faces")) << region.message();
  ExpectNamesAFaceAndAPoint(region.message());
}

TEST(Region, FaceListsOutOfRangeOrEmptyAreRefused) {
  const TriMesh tube = Tube();
  EXPECT_FALSE(CheckRegion(tube, {}).ok());
  EXPECT_TRUE(Has(CheckRegion(tube, {1, 1}).message(), "repeats face 1"));
  EXPECT_TRUE(Has(CheckRegion(tube, {100000}).message(), "out of range"));
}

}  // namespace
}  // namespace kgd
