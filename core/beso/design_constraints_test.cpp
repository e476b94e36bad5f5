// Keep-out, keep-in and mirror symmetry in BESO: the pairing of a symmetric sheet is its mirror face
// for face, an asymmetric garment is refused naming its faces, and the design loop keeps the
// constraints in every iteration while meeting its targets.
#include "core/beso/design_constraints.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/beso/design_loop.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/shapes.h"

namespace kgd {
namespace {

// RectangleSheet with its diagonals mirrored about the plane x = width / 2 ("/" left of it, "\" right),
// so that the mesh is symmetric about that plane face for face. Same vertices, same face count.
Faces MirroredDiagonals(const TriMesh& sheet, double width) {
  Faces faces = sheet.faces;
  int columns = 0;  // vertices per row
  while (sheet.vertices(columns, 2) == sheet.vertices(0, 2) && columns < sheet.vertices.rows()) ++columns;
  for (Eigen::Index f = 0; f + 1 < faces.rows(); f += 2) {
    const int a = std::min({faces(f, 0), faces(f, 1), faces(f, 2)});  // the quad's lower-left vertex
    const int b = a + 1, c = a + columns, d = c + 1;
    if (sheet.vertices(a, 0) + 1e-12 < 0.5 * width) continue;
    faces.row(f) << a, c, b;  // "\" diagonal from b to c, normals along -y as before
    faces.row(f + 1) << b, c, d;
  }
  return faces;
}

// The pull test (10 x 14 cm, clamped along z at both ends) on the mirrored-diagonal sheet: symmetric
// about x = 5 cm in mesh and load.
SceneSpec SymmetricPullTest() {
  SceneSpec s = *PullTestScene("all_cloth");
  s.garment.faces = MirroredDiagonals(s.garment, 0.10);
  return s;
}

SymmetryPlane MidPlane() {
  SymmetryPlane p;
  p.point_m = Eigen::Vector3d(0.05, 0, 0);
  return p;
}

TEST(MirrorPairing, ASymmetricSheetPairsFaceForFace) {
  const SceneSpec s = SymmetricPullTest();
  Result<MirrorPairing> p = PairMirrorFaces(s.garment, MidPlane());
  ASSERT_TRUE(p.ok()) << p.message();
  const int nf = static_cast<int>(s.garment.faces.rows());
  EXPECT_LT(p->max_distance_m, 1e-12);
  for (int f = 0; f < nf; ++f) {
    ASSERT_EQ(p->mirror[p->mirror[f]], f) << "face " << f;  // an involution
    EXPECT_NE(p->mirror[f], f);                              // no face lies across the plane
  }
  EXPECT_EQ(static_cast<int>(p->groups.size()), nf / 2);
  for (const std::vector<int>& g : p->groups) EXPECT_EQ(g.size(), 2u);
}

TEST(MirrorPairing, AnAsymmetricGarmentIsRefusedNamingItsFaces) {
  const SceneSpec s = SymmetricPullTest();
  SymmetryPlane off = MidPlane();
  off.point_m.x() = 0.06;  // 1 cm off centre: the faces within 2 cm of the far edge mirror off the sheet
  Result<MirrorPairing> p = PairMirrorFaces(s.garment, off);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.message().find("not symmetric"), std::string::npos) << p.message();
  // Face 0 (x in [0, 2.5 mm]) mirrors to x ~ 11.9 cm, beyond the sheet: it is named.
  EXPECT_NE(p.message().find("faces 0, "), std::string::npos) << p.message();
  // The default sheet's diagonals all lean one way: mirrored, no centroid lands on another exactly, and
  // a tolerance below the offset refuses every face.
  SymmetryPlane tight = MidPlane();
  tight.tolerance_m = 1e-4;
  Result<MirrorPairing> q = PairMirrorFaces(PullTestScene("all_cloth")->garment, tight);
  ASSERT_FALSE(q.ok());
  EXPECT_NE(q.message().find(std::to_string(s.garment.faces.rows()) + " of " + std::to_string(s.garment.faces.rows())), std::string::npos)
      << q.message();
}

TEST(DesignUnits, KeepListsSpreadOverMirrorGroupsAndConflictsAreNamed) {
  const SceneSpec s = SymmetricPullTest();
  const int nf = static_cast<int>(s.garment.faces.rows());
  Result<MirrorPairing> p = PairMirrorFaces(s.garment, MidPlane());
  ASSERT_TRUE(p.ok());
  Result<DesignUnits> u = MakeDesignUnits(nf, {0}, {5}, {}, &*p);
  ASSERT_TRUE(u.ok()) << u.message();
  EXPECT_TRUE(u->keep_out[0]);
  EXPECT_TRUE(u->keep_out[p->mirror[0]]);  // the mirror image of a kept-out face is kept out
  EXPECT_TRUE(u->locked[u->unit_of[p->mirror[5]]]);
  EXPECT_EQ(u->unit_of[5], u->unit_of[p->mirror[5]]);
  const std::vector<uint8_t> full = FullDesign(*u);
  EXPECT_EQ(full[0], kCloth);
  EXPECT_EQ(full[p->mirror[0]], kCloth);
  EXPECT_EQ(full[5], kReinforced);
  EXPECT_TRUE(CheckDesignConstraints(*u, full).ok());
  std::vector<uint8_t> broken = full;
  broken[p->mirror[7]] = kCloth;
  EXPECT_FALSE(CheckDesignConstraints(*u, broken).ok());

  Result<DesignUnits> both = MakeDesignUnits(nf, {3}, {3}, {}, nullptr);
  ASSERT_FALSE(both.ok());
  EXPECT_NE(both.message().find("both hold face 3"), std::string::npos) << both.message();
  Result<DesignUnits> mirrored = MakeDesignUnits(nf, {3}, {p->mirror[3]}, {}, &*p);
  ASSERT_FALSE(mirrored.ok());
  EXPECT_NE(mirrored.message().find("mirror images"), std::string::npos) << mirrored.message();
  EXPECT_FALSE(MakeDesignUnits(nf, {nf}, {}, {}, nullptr).ok());
}

BesoSettings QuickSettings(int iterations) {
  BesoSettings b;
  b.budget = 0.6;
  b.evolutionary_ratio = 0.05;
  b.admission_ratio = 0.05;
  b.max_iterations = iterations;
  return b;
}

// Keep-out faces are cloth and keep-in faces reinforced in every iteration, iteration 0 included; the
// targets are met with the kept-in area counted.
TEST(DesignLoopConstraints, KeepOutAndKeepInHoldInEveryIteration) {
  SceneSpec s = *PullTestScene("all_cloth");
  const Eigen::VectorXd area = FaceAreas(s.garment.vertices, s.garment.faces);
  const int nf = static_cast<int>(area.size());
  // Keep out the middle of the sheet, where the pull strains most; keep in a strip along one edge.
  const Positions c = FaceCentroids(s.garment.vertices, s.garment.faces, [&] {
    std::vector<int> all(nf);
    for (int f = 0; f < nf; ++f) all[f] = f;
    return all;
  }());
  for (int f = 0; f < nf; ++f) {
    if (std::abs(c(f, 0) - 0.05) < 0.01 && std::abs(c(f, 2) - 0.07) < 0.01) s.keep_out_faces.push_back(f);
    if (c(f, 0) < 0.005 && c(f, 2) > 0.03 && c(f, 2) < 0.11) s.keep_in_faces.push_back(f);
  }
  ASSERT_FALSE(s.keep_out_faces.empty());
  ASSERT_FALSE(s.keep_in_faces.empty());
  Result<std::vector<BesoIteration>> run = RunBeso(s, QuickSettings(8));
  ASSERT_TRUE(run.ok()) << run.message();
  ASSERT_EQ(run->size(), 9u);
  const double largest = area.maxCoeff();
  for (const BesoIteration& it : *run) {
    SCOPED_TRACE("iteration " + std::to_string(it.iteration));
    for (int f : s.keep_out_faces) ASSERT_EQ(it.design[f], kCloth) << "face " << f;
    for (int f : s.keep_in_faces) ASSERT_EQ(it.design[f], kReinforced) << "face " << f;
    double reinforced = 0;
    for (int f = 0; f < nf; ++f) reinforced += it.design[f] == kReinforced ? area[f] : 0.0;
    EXPECT_LE(std::abs(reinforced - it.target_area_m2), 0.5 * largest + 1e-15);
  }
  // Without the keep-out the middle is reinforced to the end: the constraint bites.
  SceneSpec free = s;
  free.keep_out_faces.clear();
  free.keep_in_faces.clear();
  Result<std::vector<BesoIteration>> unconstrained = RunBeso(free, QuickSettings(8));
  ASSERT_TRUE(unconstrained.ok());
  int middle_reinforced = 0;
  for (int f : s.keep_out_faces) middle_reinforced += unconstrained->back().design[f] == kReinforced;
  EXPECT_GT(middle_reinforced, 0);

  // Keep-in over the budget is refused, with the figures.
  SceneSpec greedy = s;
  greedy.keep_out_faces.clear();
  greedy.keep_in_faces.clear();
  for (int f = 0; f < nf; ++f)
    if (c(f, 2) < 0.10) greedy.keep_in_faces.push_back(f);  // 71 % of the sheet, budget 60 %
  Result<std::vector<BesoIteration>> over = RunBeso(greedy, QuickSettings(2));
  ASSERT_FALSE(over.ok());
  EXPECT_NE(over.message().find("garment.keep_in cover 71"), std::string::npos) << over.message();
  EXPECT_NE(over.message().find("budget of 60"), std::string::npos) << over.message();
}

// Every iteration's design is symmetric face for face, and its area meets the target within half the
// largest pair's area.
TEST(DesignLoopConstraints, SymmetricDesignsAreSymmetricFaceForFace) {
  SceneSpec s = SymmetricPullTest();
  s.symmetry = MidPlane();
  const Eigen::VectorXd area = FaceAreas(s.garment.vertices, s.garment.faces);
  Result<MirrorPairing> p = PairMirrorFaces(s.garment, *s.symmetry);
  ASSERT_TRUE(p.ok());
  Result<std::vector<BesoIteration>> run = RunBeso(s, QuickSettings(8));
  ASSERT_TRUE(run.ok()) << run.message();
  ASSERT_EQ(run->size(), 9u);
  int changed = 0;
  for (const BesoIteration& it : *run) {
    SCOPED_TRACE("iteration " + std::to_string(it.iteration));
    for (size_t f = 0; f < it.design.size(); ++f) ASSERT_EQ(it.design[f], it.design[p->mirror[f]]) << "face " << f;
    double reinforced = 0;
    for (size_t f = 0; f < it.design.size(); ++f) reinforced += it.design[f] == kReinforced ? area[f] : 0.0;
    EXPECT_LE(std::abs(reinforced - it.target_area_m2), area.maxCoeff() + 1e-15);  // half a pair
    changed += it.iteration > 0 && it.design != (*run)[it.iteration - 1].design;
  }
  EXPECT_GT(changed, 4);
  // Asked by the job (--symmetric) on a scene that names no plane: the sagittal plane x = 0, which
  // this sheet (x in [0, 0.1]) is not symmetric about: refused, the faces named.
  SceneSpec unnamed = SymmetricPullTest();
  BesoSettings sym = QuickSettings(2);
  sym.symmetric = true;
  Result<std::vector<BesoIteration>> refused = RunBeso(unnamed, sym);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("not symmetric about the plane through [0, 0, 0] with normal [1, 0, 0]"), std::string::npos)
      << refused.message();
  EXPECT_NE(refused.message().find(" of " + std::to_string(s.garment.faces.rows()) + " faces have no face within"), std::string::npos)
      << refused.message();
}

}  // namespace
}  // namespace kgd
