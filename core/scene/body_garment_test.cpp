#include "core/scene/body_garment.h"

#include <gtest/gtest.h>

#include "core/mesh/topology.h"
#include "core/scene/shapes.h"

namespace kgd {
namespace {

// A 4 x 3 grid of quads in the plane z = 0 (5 x 4 vertices, 24 triangles), 1 cm cells.
TriMesh Grid() {
  TriMesh m;
  const int nx = 4, ny = 3;
  m.vertices.resize((nx + 1) * (ny + 1), 3);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) m.vertices.row(j * (nx + 1) + i) << 0.01 * i, 0.01 * j, 0.0;
  m.faces.resize(2 * nx * ny, 3);
  int k = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
      m.faces.row(k++) << a, b, d;
      m.faces.row(k++) << a, d, c;
    }
  return m;
}

TEST(BodyGarment, CutSubdividesAndFollowsTheBody) {
  const TriMesh body = Grid();
  const std::vector<int> region = {0, 1, 2, 3, 8, 9};  // two quads in row 0 and the first quad of row 1
  const Result<GarmentCut> cut = CutGarment(body.faces, body.vertices, region, {2, 3}, 2, "region", "attach");
  ASSERT_TRUE(cut.ok()) << cut.message();
  EXPECT_EQ(cut->garment.faces.rows(), 6 * 16);
  EXPECT_EQ(cut->attachment_faces.size(), 2u * 16u);
  for (int f : cut->attachment_faces) EXPECT_TRUE(cut->body_face_of[f] == 2 || cut->body_face_of[f] == 3);
  // Any pose of the body carries the garment along: a rigid shift moves every garment vertex with it.
  Positions moved = body.vertices;
  moved.col(2).array() += 0.05;
  const Positions g = cut->from_body * moved;
  EXPECT_LT((g.col(2).array() - 0.05).abs().maxCoeff(), 1e-15);
  EXPECT_TRUE(ValidateMesh(cut->garment.vertices, cut->garment.faces, "garment").ok());
  EXPECT_EQ(BoundaryLoops(cut->garment.faces).size(), 1u);
}

TEST(BodyGarment, AttachmentOutsideTheRegionIsNamed) {
  const TriMesh body = Grid();
  const Result<GarmentCut> cut = CutGarment(body.faces, body.vertices, {0, 1}, {1, 5}, 0, "sleeve.faces.txt", "sleeve.attach.txt");
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.message().find("sleeve.attach.txt: entry 2: body face 5 is not part of the garment region"), std::string::npos)
      << cut.message();
}

TEST(BodyGarment, PiecesAreListed) {
  const TriMesh body = Grid();
  const Result<GarmentCut> cut = CutGarment(body.faces, body.vertices, {0, 1, 6, 7, 22}, {}, 0, "shirt.faces.txt", "a");
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.message().find("shirt.faces.txt: the garment region is 3 separate pieces"), std::string::npos) << cut.message();
  EXPECT_NE(cut.message().find("body face 22"), std::string::npos) << cut.message();
}

TEST(BodyGarment, IndicesOutOfRangeAndDuplicatesAreNamed) {
  const TriMesh body = Grid();
  Result<GarmentCut> cut = CutGarment(body.faces, body.vertices, {0, 99}, {}, 0, "r.txt", "a.txt");
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.message().find("99"), std::string::npos) << cut.message();
  cut = CutGarment(body.faces, body.vertices, {0, 1, 1}, {}, 0, "r.txt", "a.txt");
  ASSERT_FALSE(cut.ok());
  cut = CutGarment(body.faces, body.vertices, {}, {}, 0, "r.txt", "a.txt");
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.message().find("empty"), std::string::npos) << cut.message();
}

TEST(BodyGarment, MotionValidationNamesThePose) {
  const TriMesh body = Grid();
  BodyMotion m{body.faces, body.vertices, body.vertices, {body.vertices}};
  EXPECT_TRUE(ValidateBodyMotion(m, {"rest.obj", "pose.obj", "frame_01.obj"}).ok());
  m.frames[0].row(6) = m.frames[0].row(0);  // collapses faces around vertex 6
  const Status s = ValidateBodyMotion(m, {"rest.obj", "pose.obj", "frame_01.obj"});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("frame_01.obj"), std::string::npos) << s.message();
  m.frames[0] = body.vertices.topRows(10);
  EXPECT_NE(ValidateBodyMotion(m, {"rest.obj", "pose.obj", "frame_01.obj"}).message().find("frame_01.obj: has 10 vertices"),
            std::string::npos);
}

// The volume a motion changes: a closed box shrunk by 10 % in every direction in its second frame
// (0.9^3 of its volume), against an open grid, which has none.
TEST(BodyGarment, MotionVolumeChangeFindsThePoseFurthestFromRest) {
  const TriMesh box = BoxSurface(0.3, 0.5, 0.2);
  const Positions& x = box.vertices;
  const Faces& f = box.faces;
  Positions moved = x;
  moved.rowwise() += Eigen::RowVector3d(0.1, 0.2, 0.3);
  const BodyMotion m{f, x, moved, {moved, 0.9 * x, 1.02 * x}};
  const std::optional<BodyVolumeChange> c = MotionVolumeChange(m);
  ASSERT_TRUE(c.has_value());
  EXPECT_NEAR(c->rest_m3, 0.03, 1e-15);
  EXPECT_EQ(c->frame, 2);
  EXPECT_NEAR(c->Relative(), 0.9 * 0.9 * 0.9 - 1.0, 1e-12);
  EXPECT_EQ(DescribeBodyVolume(*c), "0.03 m^3 at rest, 0.02187 m^3 in frame 2 (-27.1 %)");
  EXPECT_NE(BodyVolumeNote(*c).find("loses 27.1 % of its volume"), std::string::npos) << BodyVolumeNote(*c);
  EXPECT_NEAR(MotionVolumeChange(BodyMotion{f, x, moved, {}})->Relative(), 0.0, 1e-12);
  EXPECT_EQ(BodyVolumeNote(*MotionVolumeChange(BodyMotion{f, x, 1.0099 * x, {}})), "");  // +3.0 %: within the threshold
  EXPECT_NE(BodyVolumeNote(*MotionVolumeChange(BodyMotion{f, x, 1.02 * x, {}})).find("gains 6.1 %"), std::string::npos);
  const TriMesh open = Grid();
  EXPECT_FALSE(MotionVolumeChange(BodyMotion{open.faces, open.vertices, open.vertices, {}}).has_value());
}

}  // namespace
}  // namespace kgd
