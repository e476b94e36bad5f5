#include "core/mesh/topology.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace kgd {
namespace {

// A tetrahedron, counter-clockwise seen from outside.
Faces Tetrahedron() {
  Faces f(4, 3);
  f << 0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2;
  return f;
}

// A 3 x 2 grid of quads (4 x 3 vertices), two triangles each.
Faces Strip(int nx = 3, int ny = 2) {
  Faces f(2 * nx * ny, 3);
  int k = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
      f.row(k++) << a, b, d;
      f.row(k++) << a, d, c;
    }
  return f;
}

TEST(Topology, ClosedManifoldAcceptsTetrahedronAndNamesDefects) {
  EXPECT_TRUE(CheckClosedOrientedManifold(Tetrahedron(), "tet").ok());
  EXPECT_EQ(EulerCharacteristic(Tetrahedron()), 2);
  Faces open = Tetrahedron().topRows(3);
  const Status s = CheckClosedOrientedManifold(open, "tet");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("boundary"), std::string::npos) << s.message();
  Faces flipped = Tetrahedron();
  std::swap(flipped(3, 1), flipped(3, 2));
  const Status t = CheckClosedOrientedManifold(flipped, "tet");
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.message().find("orientation"), std::string::npos) << t.message();
}

TEST(Topology, BoundaryLoopOfAStripFollowsTheFaces) {
  const Faces f = Strip();
  const auto loops = BoundaryLoops(f);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), 10u);  // 2 * (3 + 2) boundary edges of a 3 x 2 grid
  EXPECT_TRUE(BoundaryLoops(Tetrahedron()).empty());
}

TEST(Topology, PiecesAreEdgeConnected) {
  Faces two(4, 3);
  two << 0, 1, 2, 2, 1, 3,   // piece 0: two triangles sharing edge 1-2
      3, 4, 5, 6, 7, 8;      // faces touching piece 0 only at vertex 3, and a separate triangle
  const FacePieces p = EdgeConnectedPieces(two);
  EXPECT_EQ(p.count, 3);
  EXPECT_EQ(p.piece[0], p.piece[1]);
  EXPECT_NE(p.piece[1], p.piece[2]);
}

// Pieces of a subset: faces outside it neither join pieces nor get one. The strip's first row with its
// middle quad left out falls into two pieces; with the whole first row in, one.
TEST(Topology, PiecesOfASubsetConnectOnlyThroughItsOwnFaces) {
  const Faces f = Strip();  // row 0: faces 0-5 (quads 0, 1, 2), row 1: faces 6-11
  std::vector<char> in(f.rows(), 0);
  for (int k : {0, 1, 4, 5}) in[k] = 1;
  const FacePieces p = EdgeConnectedPieces(f, in);
  EXPECT_EQ(p.count, 2);
  EXPECT_EQ(p.piece[0], 0);
  EXPECT_EQ(p.piece[1], 0);
  EXPECT_EQ(p.piece[4], 1);
  EXPECT_EQ(p.piece[5], 1);
  for (int k : {2, 3, 6, 7, 8, 9, 10, 11}) EXPECT_EQ(p.piece[k], -1) << k;
  in[2] = in[3] = 1;
  EXPECT_EQ(EdgeConnectedPieces(f, in).count, 1);
  EXPECT_EQ(EdgeConnectedPieces(f, std::vector<char>(f.rows(), 1)).count, EdgeConnectedPieces(f).count);
}

// Face neighbours across interior edges: on the tetrahedron every face has the other three; on the
// strip a face with an edge on the boundary has fewer than three, an inner face three.
TEST(Topology, FaceNeighborsShareAnInteriorEdge) {
  const auto tet = FaceNeighbors(Tetrahedron());
  for (const auto& n : tet) EXPECT_EQ(n.size(), 3u);
  const auto strip = FaceNeighbors(Strip());
  ASSERT_EQ(strip.size(), 12u);
  EXPECT_EQ(strip[0].size(), 2u);  // vertices 0, 1, 5: edge 0-1 on the boundary
  EXPECT_EQ(strip[3].size(), 3u);  // vertices 1, 6, 5: its quad's diagonal, quad 0's edge, the next row's
  for (size_t f = 0; f < strip.size(); ++f)
    for (int g : strip[f]) EXPECT_NE(std::find(strip[g].begin(), strip[g].end(), static_cast<int>(f)), strip[g].end());
}

TEST(Topology, MidpointSubdivisionQuadruplesAndInterpolates) {
  const Faces f = Strip();
  Positions x(12, 3);
  for (int v = 0; v < 12; ++v) x.row(v) << v % 4, v / 4, 0.1 * v;
  const Subdivision s = SubdivideMidpoint(f, 12);
  EXPECT_EQ(s.faces.rows(), 4 * f.rows());
  // New vertices: one per edge; a 3 x 2 grid of split quads has 17 + 6 = 23 edges.
  EXPECT_EQ(s.prolongation.rows(), 12 + 23);
  const Positions y = s.prolongation * x;
  for (int r = 0; r < y.rows(); ++r) EXPECT_NEAR(Eigen::VectorXd(s.prolongation.row(r).transpose()).sum(), 1.0, 1e-15);
  // Child 3 of face 0 is the middle triangle: its corners are the parent's edge midpoints.
  const Eigen::Vector3d mid01 = 0.5 * (x.row(f(0, 0)) + x.row(f(0, 1))).transpose();
  EXPECT_LT((y.row(s.faces(3, 0)).transpose() - mid01).norm(), 1e-15);
  EXPECT_TRUE(BoundaryLoops(s.faces).size() == 1);
  EXPECT_EQ(EulerCharacteristic(s.faces), EulerCharacteristic(f));
}

TEST(Topology, ExtractFacesReindexes) {
  const Faces f = Strip();
  const SubMesh sub = ExtractFaces(f, {4, 5});
  EXPECT_EQ(sub.vertex_ids, (std::vector<int>{2, 3, 6, 7}));
  for (int k = 0; k < 3; ++k) EXPECT_EQ(sub.vertex_ids[sub.faces(0, k)], f(4, k));
}

TEST(Topology, VertexNeighborsAreUnique) {
  const auto n = VertexNeighbors(Tetrahedron(), 4);
  for (const auto& list : n) EXPECT_EQ(list.size(), 3u);
}

TEST(Topology, VertexFacesListEachVertexsFacesInOrder) {
  const Faces t = Tetrahedron();
  // A fifth vertex that no face names has an empty list.
  const VertexFaceIncidence inc = VertexFaces(t, 5);
  ASSERT_EQ(inc.begin.size(), 6u);
  EXPECT_EQ(inc.face.size(), 12u);
  for (int v = 0; v < 4; ++v) {
    std::vector<int> expected;
    for (int f = 0; f < t.rows(); ++f)
      if (t(f, 0) == v || t(f, 1) == v || t(f, 2) == v) expected.push_back(f);
    EXPECT_EQ(std::vector<int>(inc.face.begin() + inc.begin[v], inc.face.begin() + inc.begin[v + 1]), expected)
        << "vertex " << v;
  }
  EXPECT_EQ(inc.begin[4], inc.begin[5]);
}

}  // namespace
}  // namespace kgd
