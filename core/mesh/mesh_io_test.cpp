#include "core/mesh/mesh_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <cstring>
#include <fstream>
#include <sstream>

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

TEST(MeshIo, AGarmentPlyCarriesEachFacesDesignByteAndEnergyDensity) {
  const TriMesh m = RectangleSheet(0.02, 0.03, 0.01);
  const int nf = static_cast<int>(m.faces.rows());
  std::vector<uint8_t> design(nf, 0);
  design[1] = 1;
  const Eigen::VectorXd energy = Eigen::VectorXd::LinSpaced(nf, 0.5, 7.25);
  std::ostringstream out;
  ASSERT_TRUE(WriteGarmentPly(out, "g.ply", m.vertices, m.faces, design, energy).ok());
  const std::string bytes = out.str();
  const std::string end = "end_header\n";
  const size_t body = bytes.find(end) + end.size();
  EXPECT_NE(bytes.find("property uchar design\nproperty double energy_density_Pa\nend_header"), std::string::npos) << bytes.substr(0, body);
  // Each face: count (1), three int32 indices, the design byte, the energy density as a double.
  const size_t face_bytes = 1 + 12 + 1 + 8;
  ASSERT_EQ(bytes.size(), body + m.vertices.size() * 8 + nf * face_bytes);
  for (int f = 0; f < nf; ++f) {
    const char* face = bytes.data() + body + m.vertices.size() * 8 + f * face_bytes;
    double e = 0;
    std::memcpy(&e, face + 14, 8);
    EXPECT_EQ(static_cast<uint8_t>(face[13]), design[f]) << "face " << f;
    EXPECT_EQ(e, energy[f]) << "face " << f;
  }
  auto ply = ParseMesh(bytes, "g.ply");
  ASSERT_TRUE(ply.ok()) << ply.message();
  EXPECT_EQ(ply->vertices, m.vertices);
  // A design of the wrong length is refused, naming the property.
  design.pop_back();
  std::ostringstream short_out;
  const Status st = WriteGarmentPly(short_out, "g.ply", m.vertices, m.faces, design, energy);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("'design'"), std::string::npos) << st.message();
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
  std::filesystem::create_directories(Temp("folder.obj"));
  EXPECT_NE(ReadMesh(Temp("folder.obj")).message().find("folder.obj: is a folder"), std::string::npos);
  EXPECT_NE(ReadMesh(Temp("x.stl")).message().find("unknown mesh format"), std::string::npos);
  Write(Temp("trunc.ply"), "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                           "property double z\nend_header\n");
  EXPECT_NE(ReadMesh(Temp("trunc.ply")).message().find("vertex 0"), std::string::npos);
  Write(Temp("idx.txt"), "1\n2\n# comment\n\nthree\n");
  auto idx = ReadIndexList(Temp("idx.txt"));
  ASSERT_FALSE(idx.ok());
  EXPECT_NE(idx.message().find("idx.txt:5: expected one integer"), std::string::npos) << idx.message();
}

// A file that is not the mesh its name says (a photo saved as .obj) is refused by its first bytes,
// the message naming the file and quoting the line escaped and cut short, never its raw bytes; the
// same check runs first in ParseMesh (the design service runs it when a job is submitted).
TEST(MeshIo, AFileThatIsNotAMeshIsNamedWithItsFirstLineEscaped) {
  const std::string png("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16);
  EXPECT_EQ(CheckMeshBytes(png, "photo.obj").message(), R"(photo.obj is not an OBJ or PLY mesh (line 1: "\x89PNG" is not text))");
  EXPECT_EQ(ParseMesh(png, "photo.obj").message(), CheckMeshBytes(png, "photo.obj").message());
  EXPECT_EQ(CheckMeshBytes(png, "photo.ply").message(), R"(photo.ply is not an OBJ or PLY mesh (line 1: "\x89PNG" is not text))");
  EXPECT_EQ(CheckMeshBytes("Dear tailor, \"please\" sew this\n", "letter.obj").message(),
            R"(letter.obj is not an OBJ or PLY mesh (line 1: "Dear tailor, \"please\" sew this" is not an OBJ statement (v, f, vn, vt, o, g, s, usemtl, mtllib, # ...)))");
  EXPECT_EQ(CheckMeshBytes("v 0 0 0\nv 1 0 0\x01\n", "mixed.obj").message(), R"(mixed.obj is not an OBJ or PLY mesh (line 2: "v 1 0 0\x01" is not text))");
  EXPECT_EQ(CheckMeshBytes(std::string(100, 'x') + "\n", "long.obj").message(),
            "long.obj is not an OBJ or PLY mesh (line 1: \"" + std::string(40, 'x') + "...\" is not an OBJ statement (v, f, vn, vt, o, g, s, usemtl, mtllib, # ...))");
  EXPECT_FALSE(CheckMeshBytes("solid cube\n", "cube.ply").ok());
  // Meshes pass: comments, blank lines, a byte-order mark, UTF-8 in a comment, CRLF lines, PLY.
  for (const char* ok : {"# Blender\n\nmtllib a.mtl\no Cube\nv 0 0 0\n", "\xEF\xBB\xBFv 0 0 0\r\nf 1 1 1\r\n", "# gr\xC3\xB6\xC3\x9F" "e\nv 0 0 0\n", ""})
    EXPECT_TRUE(CheckMeshBytes(ok, "ok.obj").ok()) << CheckMeshBytes(ok, "ok.obj").message();
  EXPECT_TRUE(CheckMeshBytes("ply\nformat ascii 1.0\n", "ok.ply").ok());
  EXPECT_TRUE(CheckMeshBytes("ply\r\nformat ascii 1.0\r\n", "ok.ply").ok());
  // A parser's message quotes a bad line escaped too.
  EXPECT_EQ(ParseMesh(std::string("v 0 0 \x7f\n"), "del.obj").message(), R"(del.obj is not an OBJ or PLY mesh (line 1: "v 0 0 \x7F" is not text))");
  EXPECT_EQ(ParseMesh(std::string("v 0 0 z\xC3\xA9ro\n"), "utf.obj").message(), "utf.obj:1: vertex 0: expected three numbers, got 'v 0 0 z\xC3\xA9ro'");
}

// Corruptions a fuzzer found: each is an error naming the element, not an allocation of the declared
// size or a cast of NaN to an index.
TEST(MeshIo, CorruptPlyCountsAndIndicesAreErrors) {
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                             "property double z\nelement face 1\n";
  const std::string list = "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
  Write(Temp("nanlen.ply"), header + list + "nan 0 1 2\n");
  EXPECT_NE(ReadMesh(Temp("nanlen.ply")).message().find("face 0: bad list length"), std::string::npos)
      << ReadMesh(Temp("nanlen.ply")).message();
  Write(Temp("fraclen.ply"), header + list + "3.5 0 1 2\n");
  EXPECT_NE(ReadMesh(Temp("fraclen.ply")).message().find("face 0: bad list length"), std::string::npos);
  Write(Temp("nanidx.ply"), header + list + "3 0 nan 2\n");
  EXPECT_NE(ReadMesh(Temp("nanidx.ply")).message().find("face 0: vertex index nan is not an integer"),
            std::string::npos)
      << ReadMesh(Temp("nanidx.ply")).message();
  Write(Temp("hugeidx.ply"), header + list + "3 0 1 1e300\n");
  EXPECT_NE(ReadMesh(Temp("hugeidx.ply")).message().find("face 0: vertex index 1e+300 is not an integer"),
            std::string::npos);
  Write(Temp("huge.ply"), "ply\nformat binary_little_endian 1.0\nelement vertex 99999999999\nproperty double x\n"
                          "property double y\nproperty double z\nend_header\n");
  EXPECT_NE(ReadMesh(Temp("huge.ply")).message().find("huge.ply:3: element 'vertex' declares 99999999999 entries"),
            std::string::npos)
      << ReadMesh(Temp("huge.ply")).message();
  Write(Temp("count.ply"), "ply\nformat ascii 1.0\nelement vertex 1e5\nend_header\n");
  EXPECT_NE(ReadMesh(Temp("count.ply")).message().find("count.ply:3: bad element line"), std::string::npos);
  // Other lists keep whatever entries they hold.
  Write(Temp("uv.ply"), header + "property list uchar float texcoord\n" + list + "6 0.5 0.5 1 0 0.25 1 3 0 1 2\n");
  auto uv = ReadMesh(Temp("uv.ply"));
  ASSERT_TRUE(uv.ok()) << uv.message();
  EXPECT_EQ(uv->faces.rows(), 1);
}

}  // namespace
}  // namespace kgd
