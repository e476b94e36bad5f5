#include "core/sim/skin_pressure.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/scene/shapes.h"
#include "core/sim/garment_system.h"
#include "core/sim/membrane.h"
#include "core/sim/simulator.h"

namespace kgd {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A tube of `around` x `rings` vertices of radius r along y in [y0, y1], its first vertex at angle
// `phase` (radians); faces counter-clockwise seen from outside.
TriMesh Tube(double r, double y0, double y1, int around, int rings, double phase) {
  TriMesh m;
  m.vertices.resize(around * rings, 3);
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < around; ++i) {
      const double a = phase + 2 * kPi * i / around;
      m.vertices.row(j * around + i) << r * std::cos(a), y0 + (y1 - y0) * j / (rings - 1), r * std::sin(a);
    }
  m.faces.resize(2 * around * (rings - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < rings; ++j)
    for (int i = 0; i < around; ++i) {
      const int a = j * around + i, b = j * around + (i + 1) % around, c = a + around, d = b + around;
      m.faces.row(f++) << a, c, b;
      m.faces.row(f++) << b, c, d;
    }
  return m;
}

double Radial(const Eigen::RowVector3d& p) { return std::hypot(p.x(), p.z()); }

// The closed form of a tight sleeve: a tube of rest radius r0 stretched around a cylinder of radius r
// (hoop stretch lambda = r / r0, held at its length) carries the hoop tension T = t dW/ds2 (1, lambda)
// per unit length, and presses on the cylinder with p = T / r. The garment (48 around) is finer than
// the body (32 around) and turned half a step against it, so every garment vertex's force is shared
// among body vertices; away from the sleeve's ends every body vertex under it must carry T / r.
TEST(SkinPressure, ATightSleeveOnACylinderPressesWithTensionOverRadius) {
  LimbShape shape;
  shape.waist_depth = 0;  // a straight cylinder of radius 4 cm with caps
  const TriMesh body = LimbRest(shape);
  Result<std::shared_ptr<const BodyField>> field = BodyField::Build(body.vertices, body.faces);
  ASSERT_TRUE(field.ok()) << field.message();

  const double hoop = 1.1;  // rest radius = 4 cm / 1.1
  const TriMesh tube = Tube(shape.radius_m, -0.06, 0.06, 48, 24, kPi / 48);
  Result<Positions> on_body = PlaceOnZeroSet(**field, tube.vertices, "sleeve vertex");
  ASSERT_TRUE(on_body.ok()) << on_body.message();
  GarmentModel model;
  model.faces = tube.faces;
  model.rest = tube.vertices;
  model.rest.col(0) /= hoop;
  model.rest.col(2) /= hoop;
  model.design.assign(tube.faces.rows(), kCloth);
  model.effects.contact = ContactModel::kUnilateral;
  model.effects.clamps = true;
  model.body = *field;
  Clamp axial;  // every vertex held along the axis: the sleeve keeps its length
  axial.name = "axial";
  axial.axes = {false, true, false};
  for (int v = 0; v < tube.vertices.rows(); ++v) axial.vertices.push_back(v);
  model.clamps.push_back(axial);
  ASSERT_TRUE(ValidateModel(model).ok());
  GarmentSystem sys(model, *on_body);
  Simulator sim(&sys);
  Positions x = *on_body;
  SolverSettings settings;
  settings.grad_tol = 1e-9;
  const SolveReport report = sim.Solve(&x, settings);
  ASSERT_TRUE(report.converged()) << ToString(report.status);

  // The closed form at the equilibrium's radius.
  double r = 0;
  for (int v = 0; v < x.rows(); ++v) r += Radial(x.row(v)) / x.rows();
  const double r0 = Radial(model.rest.row(0));
  const StretchEnergy w = EnergyOfStretches(1.0, r / r0, LameParameters(model.cloth, model.lame), model.effects.relaxation);
  const double tension_N_per_m = model.cloth.thickness_m * w.W2;
  const double expected_Pa = tension_N_per_m / r;

  const SkinPressure p = ComputeSkinPressure(body, **field, x, tube.faces, model.effects.contact, model.contact_stiffness_N_per_m);
  int checked = 0;
  double lo = 1e300, hi = 0, mean = 0;
  for (int j = 0; j < body.vertices.rows(); ++j) {
    if (std::abs(body.vertices(j, 1)) > 0.03) continue;  // a sleeve end's ring away
    lo = std::min(lo, p.pressure_Pa[j]);
    hi = std::max(hi, p.pressure_Pa[j]);
    mean += p.pressure_Pa[j];
    ++checked;
  }
  mean /= checked;
  std::printf("T = %.4f N/m, r = %.5f m, T/r = %.2f Pa; the %d body vertices in the middle: mean %.2f Pa, %.2f .. %.2f Pa\n",
              tension_N_per_m, r, expected_Pa, checked, mean, lo, hi);
  EXPECT_EQ(checked, 7 * 32);
  EXPECT_NEAR(mean, expected_Pa, 0.01 * expected_Pa);
  // Vertex by vertex the pressure follows the curvature of the body's smooth surface, T times the local
  // curvature: the IMLS surface of a 32-gon is round to micrometres, but its curvature ripples by a few
  // per cent with the facets, and the garment's vertices sample it.
  EXPECT_NEAR(lo, expected_Pa, 0.04 * expected_Pa);
  EXPECT_NEAR(hi, expected_Pa, 0.04 * expected_Pa);
  EXPECT_NEAR(p.peak_Pa, expected_Pa, 0.04 * expected_Pa);
  EXPECT_NEAR(p.p95_Pa, expected_Pa, 0.04 * expected_Pa);
  // The total normal force is the contact forces' sum, p times the sleeve's area.
  EXPECT_NEAR(p.normal_force_N, ContactNormalForces(**field, x, model.effects.contact, model.contact_stiffness_N_per_m).sum(), 1e-9);
  EXPECT_NEAR(p.normal_force_N, expected_Pa * 2 * kPi * r * 0.12, 0.02 * p.normal_force_N);
}

// The garment's pressure is force over vertex area, and it reaches the body by linear interpolation:
// a pressure that varies linearly over a flat garment (7.5 mm mesh, offset) comes out exact at every
// body vertex it covers (10 mm mesh), and 0 at those it does not.
TEST(SkinPressure, ALinearPressureIsCarriedOntoTheBodyExactly) {
  const TriMesh body = RectangleSheet(0.1, 0.1, 0.01);  // y = 0
  TriMesh garment = RectangleSheet(0.06, 0.06, 0.0075);
  garment.vertices.rowwise() += Eigen::RowVector3d(0.02, -1e-5, 0.02);
  const Eigen::VectorXd area = LumpedVertexAreas(garment.vertices, garment.faces);
  auto q_at = [](const Eigen::RowVector3d& p) { return 1000 + 5e4 * p.x() - 2e4 * p.z(); };
  Eigen::VectorXd force(garment.vertices.rows());
  for (int i = 0; i < force.size(); ++i) force[i] = q_at(garment.vertices.row(i)) * area[i];
  const Eigen::VectorXd q = GarmentPressure(garment.vertices, garment.faces, force);
  for (int i = 0; i < q.size(); ++i) EXPECT_NEAR(q[i], q_at(garment.vertices.row(i)), 1e-9) << i;
  const SkinPressure p = PressureOnBody(body, garment.vertices, garment.faces, q);
  int covered = 0;
  for (int j = 0; j < body.vertices.rows(); ++j) {
    const Eigen::RowVector3d b = body.vertices.row(j);
    const bool under = b.x() > 0.02 - 1e-9 && b.x() < 0.08 + 1e-9 && b.z() > 0.02 - 1e-9 && b.z() < 0.08 + 1e-9;
    covered += under;
    EXPECT_NEAR(p.pressure_Pa[j], under ? q_at(b) : 0.0, 1e-9) << j;
  }
  EXPECT_EQ(covered, 49);
  EXPECT_EQ(p.loaded_vertices, 49);
  EXPECT_NEAR(p.peak_Pa, q_at(Eigen::RowVector3d(0.08, 0, 0.02)), 1e-9);
}

// Peak and p95 count the loaded vertices only: 1..100 Pa among zeros and negatives (bilateral
// contact pulling) give 100 and 95 (nearest rank).
TEST(SkinPressure, SummariesCountLoadedVerticesByNearestRank) {
  Eigen::VectorXd p = Eigen::VectorXd::Zero(300);
  for (int i = 0; i < 100; ++i) p[3 * i] = 100 - i, p[3 * i + 1] = -5;
  SkinPressure s;
  SummarizePressure(p, &s);
  EXPECT_EQ(s.peak_Pa, 100);
  EXPECT_EQ(s.peak_vertex, 0);
  EXPECT_EQ(s.p95_Pa, 95);
  EXPECT_EQ(s.loaded_vertices, 100);
  SummarizePressure(Eigen::VectorXd::Zero(5), &s);
  EXPECT_EQ(s.peak_Pa, 0);
  EXPECT_EQ(s.p95_Pa, 0);
  EXPECT_EQ(s.peak_vertex, -1);
}

// Unilateral contact presses only where the garment is in the body: a tube just outside the cylinder
// loads nothing; pushed in by 0.1 mm each vertex presses with 2 k Phi |grad Phi|.
TEST(SkinPressure, OnlyAGarmentInTheBodyPresses) {
  LimbShape shape;
  shape.waist_depth = 0;
  const TriMesh body = LimbRest(shape);
  Result<std::shared_ptr<const BodyField>> field = BodyField::Build(body.vertices, body.faces);
  ASSERT_TRUE(field.ok());
  const TriMesh tube = Tube(shape.radius_m, -0.05, 0.05, 48, 10, 0.0);
  Result<Positions> on = PlaceOnZeroSet(**field, tube.vertices, "v");
  ASSERT_TRUE(on.ok());
  Positions outside = *on, inside = *on;
  for (int v = 0; v < on->rows(); ++v) {
    const Eigen::RowVector3d n(on->row(v).x() / Radial(on->row(v)), 0, on->row(v).z() / Radial(on->row(v)));
    outside.row(v) += 1e-4 * n;
    inside.row(v) -= 1e-4 * n;
  }
  const double k = kDefaultContactStiffness;
  EXPECT_EQ(ComputeSkinPressure(body, **field, outside, tube.faces, ContactModel::kUnilateral, k).loaded_vertices, 0);
  const Eigen::VectorXd f = ContactNormalForces(**field, inside, ContactModel::kUnilateral, k);
  for (int v = 0; v < f.size(); ++v) EXPECT_NEAR(f[v], 2 * k * 1e-4, 0.05 * 2 * k * 1e-4) << v;
  EXPECT_GT(ComputeSkinPressure(body, **field, inside, tube.faces, ContactModel::kUnilateral, k).loaded_vertices, 0);
}

}  // namespace
}  // namespace kgd
