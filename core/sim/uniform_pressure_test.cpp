// The uniform pressure term: the load it puts on a flat sheet and on a closed surface (closed forms),
// its derivatives against central differences, and that the garment system builds it from its effect
// switch alone (term_list.h) and lists it in the breakdown.
#include "core/sim/uniform_pressure.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "core/testing/finite_difference_check.h"
#include "core/sim/garment_system.h"
#include "core/testing/term_test_support.h"

namespace kgd {
namespace {

// A square sheet in the plane z = 0 (side `s` m, normal +z): 4 vertices, 2 faces; the pressure alone.
GarmentModel Square(double s, double pressure_Pa) {
  GarmentModel m;
  m.rest.resize(4, 3);
  m.rest << 0, 0, 0, s, 0, 0, s, s, 0, 0, s, 0;
  m.faces.resize(2, 3);
  m.faces << 0, 1, 2, 0, 2, 3;
  m.design.assign(2, kCloth);
  m.effects = Effects{};
  m.effects.membrane = false;
  m.effects.fold_barrier = false;
  m.effects.uniform_pressure_Pa = pressure_Pa;
  return m;
}

// On a flat sheet of area A and normal n the load sums to p A n: the gradient of the assembled energy
// sums to -p A n, and moving the sheet by t changes the energy by -p A n . t, however it is deformed.
TEST(UniformPressure, LoadOnAFlatSheetIsPressureTimesArea) {
  const double side = 0.2, p = 150.0;
  GarmentSystem sys(Square(side, p), Square(side, p).rest);
  ASSERT_GE(sys.term_index("uniform_pressure"), 0);
  ASSERT_EQ(sys.term_names().size(), 1u);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  Positions x = sys.model().rest;
  for (Eigen::Index v = 0; v < x.rows(); ++v) x.row(v) += Eigen::RowVector3d(u(rng), u(rng), u(rng));
  Eigen::VectorXd g;
  EnergyBreakdown b;
  const double e = sys.Evaluate(x, &g, nullptr, &b);
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  for (Eigen::Index v = 0; v < x.rows(); ++v) force -= g.segment<3>(3 * v);
  const double load = p * side * side;
  EXPECT_NEAR(force.x(), 0.0, 1e-12 * load);
  EXPECT_NEAR(force.y(), 0.0, 1e-12 * load);
  EXPECT_NEAR(force.z(), load, 1e-12 * load);
  EXPECT_EQ(b["uniform_pressure"], e);
  const Eigen::RowVector3d t(0.01, -0.02, 0.03);
  const Positions moved = x.rowwise() + t;
  EXPECT_NEAR(sys.Evaluate(moved, nullptr, nullptr) - e, -load * t.z(), 1e-12 * load);
}

// Over a closed surface (a tetrahedron) the load sums to zero: a rigid translation costs nothing.
TEST(UniformPressure, LoadOnAClosedSurfaceSumsToZero) {
  testing::TermContextStorage s;
  s.model.rest.resize(4, 3);
  s.model.rest << 0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1;
  s.model.faces.resize(4, 3);
  s.model.faces << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  s.model.design.assign(4, kCloth);
  s.model.effects.uniform_pressure_Pa = 2000.0;
  const std::unique_ptr<EnergyTerm> term = MakeUniformPressureTerm(s.Context());
  ASSERT_TRUE(term);
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (int f = 0; f < 4; ++f) {
    const int v[3] = {s.model.faces(f, 0), s.model.faces(f, 1), s.model.faces(f, 2)};
    double g[9], H[81];
    EXPECT_TRUE(term->Evaluate(f, v, s.model.rest, g, H).derivatives);
    for (int a = 0; a < 3; ++a) total += Eigen::Map<Eigen::Vector3d>(g + 3 * a);
  }
  EXPECT_LT(total.norm(), 1e-12 * 2000.0 * 0.01);
  // Off: no term.
  s.model.effects.uniform_pressure_Pa = 0;
  EXPECT_FALSE(MakeUniformPressureTerm(s.Context()));
}

// The face's energy against central differences: its gradient is the load, its Hessian zero.
TEST(UniformPressure, FaceMatchesFiniteDifferences) {
  const Eigen::Vector3d an(0.003, -0.001, 0.002);
  const testing::TermFunction face = [&](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
    Eigen::Matrix<double, 9, 1> g9;
    const double e = EvaluateUniformPressureFace(an, 500.0, q.segment<3>(0), q.segment<3>(3), q.segment<3>(6), g ? &g9 : nullptr);
    if (g) *g = g9;
    if (H) *H = Eigen::MatrixXd::Zero(9, 9);
    return e;
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  for (int i = 0; i < 3; ++i) {
    Eigen::VectorXd q(9);
    for (int k = 0; k < 9; ++k) q[k] = u(rng);
    EXPECT_TRUE(testing::MatchesFiniteDifferences(face, q, {.step = 1e-6, .tolerance = 1e-6, .gradient_floor = 1e-3, .hessian_floor = 1.0}));
  }
}

}  // namespace
}  // namespace kgd
