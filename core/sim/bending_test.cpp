// Bending: the hinge angle, the energy's gradient and exact Hessian against central differences in
// every regime (flat, folded either way, bent far from a curved rest), its PSD Gauss-Newton part, rigid
// motions that cost nothing, and the closed form of a plate bent onto a cylinder.
#include "core/sim/bending.h"

#include <algorithm>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "core/mesh/topology.h"
#include "core/scene/builtin_scenes.h"
#include "core/sim/garment_system.h"
#include "core/scene/shapes.h"
#include "core/testing/finite_difference_check.h"

namespace kgd {
namespace {

// A hinge: edge along x, c in the xy plane on +y, d turned by `angle` about the edge from -y.
Vector12d Hinge(double angle) {
  Vector12d q;
  q << 0, 0, 0, 0.01, 0, 0, 0.004, 0.008, 0, 0.006, -0.009 * std::cos(angle), 0.009 * std::sin(angle);
  return q;
}

testing::TermFunction Term(double rest, double k, bool project = false) {
  return [=](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
    Vector12d g12;
    Matrix12d H12;
    const double E = EvaluateHingeBending(q, rest, k, g ? &g12 : nullptr, H ? &H12 : nullptr, project);
    if (g) *g = g12;
    if (H) *H = H12;
    return E;
  };
}

TEST(Bending, HingeAngleIsTheSignedDihedralAngle) {
  EXPECT_NEAR(HingeAngle({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}), 0.0, 1e-15);
  for (double angle : {0.3, -0.3, 1.2, -2.5}) {
    const Vector12d q = Hinge(angle);
    EXPECT_NEAR(std::abs(HingeAngle(q.segment<3>(0), q.segment<3>(3), q.segment<3>(6), q.segment<3>(9))), std::abs(angle), 1e-12);
  }
  // Folding one way or the other gives opposite signs.
  const Vector12d p = Hinge(0.4), m = Hinge(-0.4);
  EXPECT_LT(HingeAngle(p.segment<3>(0), p.segment<3>(3), p.segment<3>(6), p.segment<3>(9)) *
                HingeAngle(m.segment<3>(0), m.segment<3>(3), m.segment<3>(6), m.segment<3>(9)),
            0);
}

TEST(Bending, GradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0, 3e-4);
  const double k = 2e-5;  // J per rad^2
  // Flat at rest and bent; bent near and far from a curved rest; folded past 90 degrees; both signs.
  for (auto [angle, rest] : {std::pair{0.0, 0.0}, {0.3, 0.0}, {-0.3, 0.2}, {1.7, 0.5}, {-2.4, -0.1}, {0.05, 0.05}}) {
    Eigen::VectorXd q = Hinge(angle);
    for (int i = 0; i < 12; ++i) q[i] += n(rng);
    SCOPED_TRACE("angle " + std::to_string(angle) + " rest " + std::to_string(rest));
    EXPECT_TRUE(testing::MatchesFiniteDifferences(Term(rest, k), q, {.step = 1e-8, .tolerance = 1e-5, .gradient_floor = 1e-6, .hessian_floor = 1e-4}));
    // The solver's Hessian is the PSD Gauss-Newton part 2 k grad theta grad theta^T: with the gradient
    // g = 2 k (theta - rest) grad theta and E = k (theta - rest)^2, it is g g^T / (2 E). It equals the
    // exact one at the rest angle.
    Eigen::MatrixXd P;
    Eigen::VectorXd g;
    const double E = Term(rest, k, true)(q, &g, &P);
    if (E > 1e-12 * k) {
      EXPECT_LT((P - g * g.transpose() / (2 * E)).norm(), 1e-9 * P.norm());
    }
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P).eigenvalues().minCoeff(), -1e-12 * P.norm());
  }
  Eigen::MatrixXd exact, gauss_newton;
  const Eigen::VectorXd at_rest = Hinge(0.4);
  const Vector12d r = Hinge(0.4);
  const double rest = HingeAngle(r.segment<3>(0), r.segment<3>(3), r.segment<3>(6), r.segment<3>(9));
  Term(rest, k)(at_rest, nullptr, &exact);
  Term(rest, k, true)(at_rest, nullptr, &gauss_newton);
  EXPECT_LT((exact - gauss_newton).norm(), 1e-12 * exact.norm());
}

TEST(Bending, RigidMotionsCostNothing) {
  const Vector12d q = Hinge(0.7);
  const double rest = HingeAngle(q.segment<3>(0), q.segment<3>(3), q.segment<3>(6), q.segment<3>(9));
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  Vector12d moved;
  for (int v = 0; v < 4; ++v) moved.segment<3>(3 * v) = R * q.segment<3>(3 * v) + Eigen::Vector3d(0.2, -0.1, 0.05);
  Vector12d g;
  EXPECT_NEAR(EvaluateHingeBending(moved, rest, 1.0, &g, nullptr, true), 0.0, 1e-20);
  EXPECT_LT(g.norm(), 1e-9);
  // A collapsed triangle has no angle: infinite energy, named by the system.
  Vector12d flat = q;
  flat.segment<3>(6) = 0.5 * (q.segment<3>(0) + q.segment<3>(3));
  EXPECT_TRUE(std::isinf(EvaluateHingeBending(flat, rest, 1.0, nullptr, nullptr, true)));
}

// A flat sheet rolled onto a cylinder of radius R: the energy scales as D A / R^2, as the continuum's
// (D / 2) A / R^2 does. Hinge energies carry a mesh-dependent factor (Grinspun et al.'s weight is exact
// only in the limit of well-shaped meshes): on this right-triangle grid it is 2.9.
double RolledSheetEnergy(double R, double D) {
  const TriMesh sheet = RectangleSheet(0.06, 0.06, 0.002);  // in the x-z plane
  const Hinges h = MeshHinges(sheet.faces);
  Positions rolled = sheet.vertices;
  for (Eigen::Index v = 0; v < rolled.rows(); ++v) {
    const double s = sheet.vertices(v, 0);
    rolled(v, 0) = R * std::sin(s / R);
    rolled(v, 1) = R * (1 - std::cos(s / R));
  }
  const Eigen::VectorXd area = FaceAreas(sheet.vertices, sheet.faces);
  double energy = 0;
  for (size_t i = 0; i < h.vertices.size(); ++i) {
    const auto& v = h.vertices[i];
    Vector12d q;
    for (int a = 0; a < 4; ++a) q.segment<3>(3 * a) = rolled.row(v[a]).transpose();
    const double w = 0.5 * 3.0 * (sheet.vertices.row(v[1]) - sheet.vertices.row(v[0])).squaredNorm() / (area[h.faces[i][0]] + area[h.faces[i][1]]);
    energy += EvaluateHingeBending(q, 0.0, D * w, nullptr, nullptr, true);
  }
  return energy;
}

TEST(Bending, APlateRolledOntoACylinderStoresEnergyAsTheContinuumScales) {
  const double A = 0.06 * 0.06;
  const double e1 = RolledSheetEnergy(0.05, 1.0), e2 = RolledSheetEnergy(0.025, 1.0), e3 = RolledSheetEnergy(0.05, 3.0);
  const double continuum = 0.5 * 1.0 * A / (0.05 * 0.05);
  EXPECT_NEAR(e2 / e1, 4.0, 0.04);        // 1 / R^2
  EXPECT_NEAR(e3 / e1, 3.0, 1e-12);       // linear in D
  EXPECT_NEAR(e1 / continuum, 2.9, 0.05);  // the mesh's factor
  std::printf("rolled sheet, R = 0.05 m: %.6g J against the continuum's %.6g J (factor %.4f); R = 0.025 m: %.4fx\n", e1, continuum,
              e1 / continuum, e2 / e1);
}

// In the garment system: the hinges are a stencil like the faces; the bending term shows in the
// breakdown, its gradient matches central differences, and a local re-evaluation after moved
// vertices and redesigned faces gives exactly what a full one gives.
TEST(Bending, InTheGarmentSystemLikeEveryTerm) {
  SleeveOptions o;
  o.around = 12;
  o.sleeve_halflength_m = 0.05;
  o.flex_angle_rad = 0.5;
  SceneSpec s = SleeveOnLimbScene(o);
  s.effects.bending = true;
  for (size_t f = 0; f < s.design.size(); f += 3) s.design[f] = kReinforced;
  Result<GarmentModel> model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok()) << model.message();
  GarmentSystem sys(std::move(model).value(), s.initial);
  ASSERT_GE(sys.term_index("bending"), 0);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 5e-4);
  Positions x = s.initial;
  for (Eigen::Index v = 0; v < x.rows(); ++v)
    for (int k = 0; k < 3; ++k) x(v, k) += n(rng);
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> H = sys.hessian_pattern();
  EnergyBreakdown b;
  EvaluationRecord r;
  sys.Evaluate(x, &g, &H, &b, &r);
  EXPECT_GT(b["bending"], 0);
  EXPECT_EQ(std::count_if(b.terms.begin(), b.terms.end(), [](const auto& t) { return t.name == std::string("bending"); }), 1);
  // The bending term's own gradient (a system with only bending on: in the whole one membrane and
  // contact swamp it), against central differences on every coordinate.
  GarmentModel only = sys.model();
  only.effects = Effects{};
  only.effects.membrane = false;
  only.effects.fold_barrier = false;
  only.effects.bending = true;
  GarmentSystem bending(std::move(only), s.initial);
  const testing::TermFunction energy = [&bending](const Eigen::VectorXd& q, Eigen::VectorXd* gq, Eigen::MatrixXd*) {
    Positions p(q.size() / 3, 3);
    for (Eigen::Index v = 0; v < p.rows(); ++v) p.row(v) = q.segment<3>(3 * v).transpose();
    return bending.Evaluate(p, gq, nullptr);
  };
  Eigen::VectorXd q(x.size());
  for (Eigen::Index v = 0; v < x.rows(); ++v) q.segment<3>(3 * v) = x.row(v).transpose();
  EXPECT_NEAR(energy(q, nullptr, nullptr), b["bending"], 1e-12 * b["bending"]);
  EXPECT_TRUE(testing::MatchesFiniteDifferences(energy, q, {.step = 1e-8, .tolerance = 1e-5, .check_hessian = false}));

  // Moved vertices and redesigned faces: EvaluateFrom (few enough for its local path) equals a full
  // evaluation bit for bit.
  ASSERT_GT(sys.num_vertices(), 3 * (3 + 3 * 2));
  Positions y = x;
  for (int v : {3, 20, 41}) y.row(v) += Eigen::RowVector3d(n(rng), n(rng), n(rng));
  std::vector<uint8_t> design = sys.model().design;
  for (int f : {5, 30}) design[f] ^= 1;
  sys.SetDesign(design);
  Eigen::VectorXd g_ref, g_from = g;
  Eigen::SparseMatrix<double> H_ref = sys.hessian_pattern(), H_from = H;
  EnergyBreakdown b_ref, b_from;
  const double E_ref = sys.Evaluate(y, &g_ref, &H_ref, &b_ref);
  const double E_from = sys.EvaluateFrom(r, &g_from, &H_from, y, &g_from, &H_from, &b_from);
  EXPECT_EQ(E_from, E_ref);
  EXPECT_EQ(b_from["bending"], b_ref["bending"]);
  EXPECT_EQ(g_from, g_ref);
  EXPECT_TRUE(std::equal(H_from.valuePtr(), H_from.valuePtr() + H_from.nonZeros(), H_ref.valuePtr()));
}

TEST(Bending, StiffnessIsTheThinPlateFormula) {
  const Material m{5.7e6, 0.33, 0.35e-3};
  EXPECT_NEAR(BendingStiffness(m), 5.7e6 * std::pow(0.35e-3, 3) / (12 * (1 - 0.33 * 0.33)), 1e-18);
}

}  // namespace
}  // namespace kgd
