#include "core/mesh/trimesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>

#include "core/mesh/topology.h"
#include "core/scene/shapes.h"

namespace kgd {
namespace {

TEST(TriMesh, SheetAreasSumToTheRectangle) {
  const TriMesh m = RectangleSheet(0.10, 0.14, 0.0025);
  EXPECT_EQ(m.vertices.rows(), 41 * 57);
  EXPECT_EQ(m.faces.rows(), 4480);
  EXPECT_NEAR(FaceAreas(m.vertices, m.faces).sum(), 0.014, 1e-12);
  EXPECT_NEAR(MeanEdgeLength(m.vertices, m.faces), 0.0025 * (2 + std::sqrt(2.0)) / 3, 1e-12);
  EXPECT_TRUE(ValidateMesh(m.vertices, m.faces, "sheet").ok());
}

// Lumped vertex areas: an interior vertex of the sheet's grid carries one cell (six half-cells, a third
// each), the whole sum is the sheet's area.
TEST(TriMesh, LumpedVertexAreasShareEveryFaceInThirds) {
  const double h = 0.0025;
  const TriMesh m = RectangleSheet(0.10, 0.14, h);
  const Eigen::VectorXd a = LumpedVertexAreas(m.vertices, m.faces);
  EXPECT_NEAR(a.sum(), 0.014, 1e-12);
  const int interior = 20 * 41 + 20;  // row 20, column 20 of the 41 x 57 grid
  EXPECT_NEAR(a[interior], h * h, 1e-15);
  EXPECT_GT(a[0], 0.0);
  EXPECT_LT(a[0], 0.5 * h * h);
}

// A unit cube of twelve triangles: 1 m^3 whatever its pose; scaled by s, s^3; turned inside out, -1.
TEST(TriMesh, EnclosedVolumeOfACube) {
  const TriMesh cube = BoxSurface(1, 1, 1);
  const Positions& x = cube.vertices;
  const Faces& f = cube.faces;
  ASSERT_TRUE(CheckClosedOrientedManifold(f, "cube").ok());
  EXPECT_NEAR(EnclosedVolume(x, f), 1.0, 1e-14);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Positions moved = x * r.transpose();
  moved.rowwise() += Eigen::RowVector3d(5, -3, 2);
  EXPECT_NEAR(EnclosedVolume(moved, f), 1.0, 1e-12);
  EXPECT_NEAR(EnclosedVolume(0.1 * x, f), 1e-3, 1e-16);
  Faces flipped = f;
  flipped.col(1).swap(flipped.col(2));
  EXPECT_NEAR(EnclosedVolume(x, flipped), -1.0, 1e-14);
}

TEST(TriMesh, LimbIsClosedAndOutwardOriented) {
  LimbShape s;
  const TriMesh m = LimbRest(s);
  ASSERT_TRUE(ValidateMesh(m.vertices, m.faces, "limb").ok());
  // Closed: V - E + F = 2 and every edge used twice; outward: positive signed volume.
  std::map<std::pair<int, int>, int> edges;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      int a = m.faces(f, k), b = m.faces(f, (k + 1) % 3);
      edges[{std::min(a, b), std::max(a, b)}]++;
    }
  for (const auto& [e, count] : edges) ASSERT_EQ(count, 2);
  EXPECT_EQ(m.vertices.rows() - static_cast<long>(edges.size()) + m.faces.rows(), 2);
  EXPECT_GT(EnclosedVolume(m.vertices, m.faces), 0);
  // Normals on the cylinder point away from the axis.
  const Positions n = AreaWeightedVertexNormals(m.vertices, m.faces);
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) {
    const Eigen::Vector3d radial(m.vertices(v, 0), 0, m.vertices(v, 2));
    if (radial.norm() > 0.03 && std::abs(m.vertices(v, 1)) < 0.15) {
      ASSERT_GT(n.row(v).dot(radial), 0) << v;
    }
  }
}

TEST(TriMesh, ValidateMeshNamesTheElement) {
  Positions x(4, 3);
  x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, std::nan("");
  Faces f(2, 3);
  f << 0, 1, 2, 0, 2, 1;
  EXPECT_NE(ValidateMesh(x, f, "a.obj").message().find("a.obj: vertex 3 has a non-finite coordinate"), std::string::npos);
  x(3, 2) = 0;
  f(1, 2) = 9;
  EXPECT_NE(ValidateMesh(x, f, "a.obj").message().find("face 1 refers to vertex 9"), std::string::npos);
  f(1, 2) = 3;
  x.row(3) << 0.5, 0.5, 0;  // collinear with 0 and 2? no: (0,0),(0,1),(0.5,0.5) has area; make it collinear:
  x.row(3) << 0, 2, 0;
  EXPECT_NE(ValidateMesh(x, f, "a.obj").message().find("face 1 has zero area"), std::string::npos);
  EXPECT_NE(ValidateFaceList({0, 5}, 2, "att").message().find("entry 1 is face 5"), std::string::npos);
  // A body in centimetres or millimetres: named as such, with the scale that makes it metres.
  x.row(3) << 0, 170, 0;
  EXPECT_NE(ValidateMesh(x, f, "cm.obj").message().find("cm.obj: the mesh is 170 m across, but kgd reads metres (SI): centimetres? scale the mesh by 0.01"),
            std::string::npos)
      << ValidateMesh(x, f, "cm.obj").message();
  x.row(3) << 0, 1700, 0;
  EXPECT_NE(ValidateMesh(x, f, "mm.obj").message().find("the mesh is 1,700 m across, but kgd reads metres (SI): millimetres? scale the mesh by 0.001"),
            std::string::npos)
      << ValidateMesh(x, f, "mm.obj").message();
}

}  // namespace
}  // namespace kgd
