#include "core/mesh/mesh_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/scene/shapes.h"

namespace kgd {
namespace {

std::string Temp(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "kgd_mesh_io_test";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

void Write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(MeshIo, ObjAndPlyRoundTrip) {
  const TriMesh m = RectangleSheet(0.02, 0.03, 0.005);
  ASSERT_TRUE(WriteObj(Temp("a.obj"), m.vertices, m.faces).ok());
  auto obj = ReadMesh(Temp("a.obj"));
  ASSERT_TRUE(obj.ok()) << obj.message();
  EXPECT_EQ(obj->faces, m.faces);
  EXPECT_LT((obj->vertices - m.vertices).cwiseAbs().maxCoeff(), 1e-9);
  Eigen::VectorXd d = Eigen::VectorXd::LinSpaced(m.faces.rows(), 0, 1);
  ASSERT_TRUE(WritePly(Temp("a.ply"), m.vertices, m.faces, {{"energy_density_Pa", d, false}}).ok());
  auto ply = ReadMesh(Temp("a.ply"));
  ASSERT_TRUE(ply.ok()) << ply.message();
  EXPECT_EQ(ply->faces, m.faces);
  EXPECT_EQ(ply->vertices, m.vertices);  // doubles: exact
}

TEST(MeshIo, AsciiPlyWithQuads) {
  Write(Temp("q.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
  auto m = ReadMesh(Temp("q.ply"));
  ASSERT_TRUE(m.ok()) << m.message();
  EXPECT_EQ(m->faces.rows(), 2);
}

TEST(MeshIo, ErrorsNameFileAndLine) {
  Write(Temp("bad1.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n");
  auto m = ReadMesh(Temp("bad1.obj"));
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.message().find("bad1.obj:3: vertex 2"), std::string::npos) << m.message();
  Write(Temp("bad2.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n");
  m = ReadMesh(Temp("bad2.obj"));
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.message().find("bad2.obj:3: vertex 2 has a non-finite coordinate"), std::string::npos) << m.message();
  Write(Temp("bad3.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n");
  m = ReadMesh(Temp("bad3.obj"));
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.message().find("face 1 refers to vertex 7"), std::string::npos) << m.message();
  Write(Temp("bad4.obj"), "v 0 0 0\nf 1 2\n");
  EXPECT_NE(ReadMesh(Temp("bad4.obj")).message().find("bad4.obj:2: face 0 has 2 corners"), std::string::npos);
  EXPECT_NE(ReadMesh(Temp("missing.obj")).message().find("cannot open"), std::string::npos);
  EXPECT_NE(ReadMesh(Temp("x.stl")).message().find("unknown mesh format"), std::string::npos);
  Write(Temp("trunc.ply"), "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                           "property double z\nend_header\n");
  EXPECT_NE(ReadMesh(Temp("trunc.ply")).message().find("vertex 0"), std::string::npos);
  Write(Temp("idx.txt"), "1\n2\n# comment\n\nthree\n");
  auto idx = ReadIndexList(Temp("idx.txt"));
  ASSERT_FALSE(idx.ok());
  EXPECT_NE(idx.message().find("idx.txt:5: expected one integer"), std::string::npos) << idx.message();
}

}  // namespace
}  // namespace kgd
