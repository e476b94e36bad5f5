// `kgd region` through the real binary: a sleeve chosen by two planes and a point on the MakeHuman rest
// body (../shared/bodies/makehuman, CC0; skipped with a message when the folder is absent), its files
// read back as a scene reads them, the MakeHuman data's own regions through the same checks, and bad
// input refused with exit 2 and a message that names it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "core/mesh/mesh_io.h"
#include "core/mesh/region.h"
#include "core/scene/scene_file.h"
#include "tests/kgd_cli.h"

namespace kgd {
namespace {

namespace fs = std::filesystem;
using cli_test::Kgd;

fs::path BodiesDir() { return fs::path(KGD_SOURCE_DIR) / ".." / "shared" / "bodies" / "makehuman"; }

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "kgd_region_command" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

bool Has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// The right elbow of the MakeHuman rest body (+x is the body's left): the middle of the data's
// sleeve_arm, whose open ends are centred at (-0.255, 1.244, 0.017) and (-0.394, 1.116, 0.045) m;
// the arm's axis runs from the first to the second, (-0.726, -0.672, 0.146). Two planes 8 cm either
// side of the elbow across that axis, facing each other, and the elbow's point.
const std::string kSleeveRules =
    "--plane -0.267,1.234,0.020,-0.726,-0.672,0.146 --plane -0.383,1.126,0.043,0.726,0.672,-0.146 --near -0.325,1.180,0.031";

TEST(RegionCommand, TwoPlanesAcrossTheArmAndNearTheElbowGiveOneSleeveWithTwoOpenEnds) {
  const fs::path bodies = BodiesDir();
  if (!fs::exists(bodies / "rest.obj")) GTEST_SKIP() << "no real bodies at " << bodies.string() << " (../shared/bodies is not part of a clone)";
  const fs::path dir = FreshDir("sleeve");
  // The planes alone also cut through the trunk: two pieces, refused.
  const auto planes = Kgd("region " + (bodies / "rest.obj").string() + " " + kSleeveRules.substr(0, kSleeveRules.find(" --near")) +
                          " --out " + (dir / "planes").string());
  EXPECT_EQ(planes.exit_code, 2) << planes.output;
  EXPECT_TRUE(Has(planes.output, "2 edge-connected pieces")) << planes.output;
  const auto run = Kgd("region " + (bodies / "rest.obj").string() + " " + kSleeveRules + " --attach 0.025 --out " + (dir / "sleeve").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(Has(run.output, ", 1 piece, ")) << run.output;
  EXPECT_TRUE(Has(run.output, "boundary loops        2\n")) << run.output;

  // The files are what a scene reads: the region passes the same checks and has two open ends round
  // the arm (a girth of 20-32 cm), each within 3 cm of its plane's point; the bands lie in the region.
  const TriMesh rest = ReadMesh((bodies / "rest.obj").string()).value();
  Result<std::vector<int>> faces = ReadIndexList((dir / "sleeve.faces.txt").string());
  ASSERT_TRUE(faces.ok()) << faces.message();
  Result<Region> region = CheckRegion(rest, *faces);
  ASSERT_TRUE(region.ok()) << region.message();
  ASSERT_EQ(region->loops.size(), 2u);
  const Eigen::Vector3d ends[2] = {{-0.267, 1.234, 0.020}, {-0.383, 1.126, 0.043}};
  for (const RegionLoop& loop : region->loops) {
    EXPECT_GT(loop.length_m, 0.20);
    EXPECT_LT(loop.length_m, 0.32);
    EXPECT_LT(std::min((loop.centre_m - ends[0]).norm(), (loop.centre_m - ends[1]).norm()), 0.03) << loop.centre_m.transpose();
  }
  EXPECT_GT(region->area_m2, 0.16 * 0.20);  // 16 cm of an arm at least 20 cm round
  Result<std::vector<int>> attach = ReadIndexList((dir / "sleeve.attach.txt").string());
  ASSERT_TRUE(attach.ok()) << attach.message();
  EXPECT_FALSE(attach->empty());
  EXPECT_LT(attach->size(), faces->size());
  for (int f : *attach) EXPECT_TRUE(std::binary_search(faces->begin(), faces->end(), f)) << f;

  // --free the upper end: one band, along the lower end only.
  const auto lower = Kgd("region " + (bodies / "rest.obj").string() + " " + kSleeveRules + " --attach 0.025 --free -0.267,1.234,0.020 --out " +
                         (dir / "lower").string());
  ASSERT_EQ(lower.exit_code, 0) << lower.output;
  const std::vector<int> lower_band = ReadIndexList((dir / "lower.attach.txt").string()).value();
  EXPECT_FALSE(lower_band.empty());
  EXPECT_LT(lower_band.size(), attach->size());
  for (int f : lower_band) {
    const Eigen::Vector3d c = (rest.vertices.row(rest.faces(f, 0)) + rest.vertices.row(rest.faces(f, 1)) + rest.vertices.row(rest.faces(f, 2))).transpose() / 3;
    EXPECT_LT((c - ends[1]).norm(), (c - ends[0]).norm()) << f;
  }

  nlohmann::json scene;
  scene["name"] = "region_sleeve";
  scene["budget"] = 0.15;
  scene["body"] = {{"rest", (bodies / "rest.obj").string()}, {"deformed", (bodies / "arm_flexion" / "pose.obj").string()}};
  scene["garment"] = {{"region", "sleeve.faces.txt"}, {"design", "all_cloth"}};
  scene["attachments"] = {{"body_faces", "sleeve.attach.txt"}};
  scene["effects"] = {{"contact", "unilateral"}, {"attachments", true}};
  std::ofstream(dir / "scene.json") << scene.dump(2);
  Result<SceneSpec> loaded = LoadScene((dir / "scene.json").string());
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  EXPECT_EQ(loaded->garment.faces.rows(), static_cast<long>(faces->size()));
  EXPECT_EQ(loaded->attachment_faces.size(), attach->size());
}

TEST(RegionCommand, TheMakeHumanRegionsPassTheChecksWithTheirOpenEnds) {
  const fs::path bodies = BodiesDir();
  if (!fs::exists(bodies / "rest.obj")) GTEST_SKIP() << "no real bodies at " << bodies.string() << " (../shared/bodies is not part of a clone)";
  const TriMesh rest = ReadMesh((bodies / "rest.obj").string()).value();
  const std::pair<const char*, size_t> regions[] = {{"sleeve_arm", 2}, {"sleeve_knee", 2}, {"shirt", 4}, {"shorts", 3}};
  for (const auto& [name, loops] : regions) {
    const std::vector<int> faces = ReadIndexList((bodies / "regions" / (std::string(name) + ".faces.txt")).string()).value();
    Result<Region> region = CheckRegion(rest, faces);
    ASSERT_TRUE(region.ok()) << name << ": " << region.message();
    EXPECT_EQ(region->loops.size(), loops) << name;
  }
}

// Two tetrahedra of 1 m, the second 3 m along x, as an OBJ file.
fs::path TwoTetrahedra(const fs::path& dir) {
  std::ofstream obj(dir / "tets.obj");
  for (double x0 : {0.0, 3.0}) obj << "v " << x0 << " 0 0\nv " << x0 + 1 << " 0 0\nv " << x0 << " 1 0\nv " << x0 << " 0 1\n";
  for (int o : {0, 4}) obj << "f " << o + 1 << " " << o + 3 << " " << o + 2 << "\nf " << o + 1 << " " << o + 2 << " " << o + 4 << "\nf " << o + 2
                           << " " << o + 3 << " " << o + 4 << "\nf " << o + 1 << " " << o + 4 << " " << o + 3 << "\n";
  return dir / "tets.obj";
}

TEST(RegionCommand, BadInputExits2NamingIt) {
  const fs::path dir = FreshDir("bad");
  const std::string out = " --out " + (dir / "r").string();
  const std::string tets = TwoTetrahedra(dir).string();

  auto missing = Kgd("region " + (dir / "nothing.obj").string() + " --plane 0,0,0,0,0,1" + out);
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_TRUE(Has(missing.output, "nothing.obj")) << missing.output;

  auto none = Kgd("region " + tets + " --plane 0,0,10,0,0,1" + out);
  EXPECT_EQ(none.exit_code, 2) << none.output;
  EXPECT_TRUE(Has(none.output, "--plane 0,0,10,0,0,1: selects no face of the body")) << none.output;

  auto short_plane = Kgd("region " + tets + " --plane 0,0,1" + out);
  EXPECT_EQ(short_plane.exit_code, 2) << short_plane.output;
  EXPECT_TRUE(Has(short_plane.output, "3 numbers, expected 6 (X,Y,Z,NX,NY,NZ)")) << short_plane.output;

  auto no_radius = Kgd("region " + tets + " --geodesic 0,0,0" + out);
  EXPECT_EQ(no_radius.exit_code, 2) << no_radius.output;
  EXPECT_TRUE(Has(no_radius.output, "--radius")) << no_radius.output;

  auto dangling = Kgd("region " + tets + " --plane -1,-1,-1,0,0,1 --subtract" + out);
  EXPECT_EQ(dangling.exit_code, 2) << dangling.output;
  EXPECT_TRUE(Has(dangling.output, "--subtract at the end")) << dangling.output;

  // Both tetrahedra: two pieces, each named by a face and its centroid.
  auto two = Kgd("region " + tets + " --plane -1,-1,-1,0,0,1" + out);
  EXPECT_EQ(two.exit_code, 2) << two.output;
  EXPECT_TRUE(Has(two.output, "2 edge-connected pieces")) << two.output;
  EXPECT_TRUE(Has(two.output, "face 0 at (")) << two.output;
  EXPECT_TRUE(Has(two.output, "face 4 at (")) << two.output;
  EXPECT_FALSE(fs::exists(dir / "r.faces.txt"));

  // --near keeps the second: a closed region, with no open end to attach along.
  auto second = Kgd("region " + tets + " --plane -1,-1,-1,0,0,1 --near 3.2,0.2,-0.5" + out);
  EXPECT_EQ(second.exit_code, 0) << second.output;
  EXPECT_EQ(ReadIndexList((dir / "r.faces.txt").string()).value(), (std::vector<int>{4, 5, 6, 7}));
  auto closed = Kgd("region " + tets + " --plane -1,-1,-1,0,0,1 --near 3.2,0.2,-0.5 --attach 0.1" + out);
  EXPECT_EQ(closed.exit_code, 2) << closed.output;
  EXPECT_TRUE(Has(closed.output, "closed")) << closed.output;
}

}  // namespace
}  // namespace kgd
