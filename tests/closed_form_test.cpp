// Acceptance 2: a homogeneous patch stretched uniaxially (clamps prescribe only the pull direction,
// lateral edges free) against the closed-form uniaxial solution of the same energy.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>

#include "core/scene/scene.h"
#include "core/scene/shapes.h"
#include "core/scene/simulate.h"
#include "core/sim/membrane.h"

namespace kgd {
namespace {

// The closed form, written independently of the simulator: W(s1, s2) of the 2D neo-Hookean membrane,
// the lateral stretch r from dW/ds1 = 0 (bisection), the relaxation rules, and the nominal force
// F = t * width * dPsi/ds2 with Psi(s2) = min over s1 of the (relaxed) energy.
struct ClosedForm {
  double mu, lambda;
  Relaxation relaxation;
  double W(double s1, double s2) const {
    const double L = std::log(s1 * s2);
    return 0.5 * mu * (s1 * s1 + s2 * s2 - 2) - mu * L + 0.5 * lambda * L * L;
  }
  double Lateral(double s2) const {  // root of mu s1 - mu / s1 + lambda ln(s1 s2) / s1 = 0
    double lo = 1e-3, hi = 1.0;
    for (int i = 0; i < 200; ++i) {
      const double m = 0.5 * (lo + hi);
      (mu * m * m - mu + lambda * std::log(m * s2) < 0 ? lo : hi) = m;
    }
    return 0.5 * (lo + hi);
  }
  // Minimizing lateral stretch (for the authors' variant the energy is flat below s2^-1/2; any such
  // s1 minimizes and the energy equals W(s2^-1/2, s2)).
  double Psi(double s2) const {
    const double r = Lateral(s2);
    if (relaxation == Relaxation::kAuthors) return W(std::max(r, 1 / std::sqrt(s2)), s2);
    return W(r, s2);
  }
  double Force(double s2, double thickness, double width) const {
    const double h = 1e-6;
    return thickness * width * (Psi(s2 + h) - Psi(s2 - h)) / (2 * h);
  }
};

class ClosedFormTest : public ::testing::TestWithParam<std::tuple<LameConversion, Relaxation, double>> {};

TEST_P(ClosedFormTest, UniaxialForceAndLateralStretchMatch) {
  const auto [conversion, relaxation, strain] = GetParam();
  const double width = 0.04, length = 0.06;
  SceneSpec s;
  s.name = "uniaxial";
  s.garment = RectangleSheet(width, length, 0.005);
  s.initial = s.garment.vertices;
  s.design.assign(s.garment.faces.rows(), kCloth);
  s.lame = conversion;
  s.effects.relaxation = relaxation;
  s.effects.clamps = true;
  Clamp bottom, top;
  bottom.name = "bottom";
  top.name = "top";
  bottom.axes = top.axes = {false, false, true};  // only the pull direction (z) is prescribed
  for (Eigen::Index v = 0; v < s.garment.vertices.rows(); ++v) {
    if (s.garment.vertices(v, 2) < 1e-9) bottom.vertices.push_back(v);
    if (s.garment.vertices(v, 2) > length - 1e-9) top.vertices.push_back(v);
  }
  top.displacement_m = Eigen::Vector3d(0, 0, strain * length);
  s.clamps = {bottom, top};
  s.solver.grad_tol = 1e-7;
  auto r = SimulateScene(s);
  ASSERT_TRUE(r.ok()) << r.message();
  // The authors' rule has a gradient jump on which uniaxial tension sits; Newton may stall there with
  // the energy and forces converged (reference-code notes, section 0.3): a typed stall is acceptable.
  if (relaxation == Relaxation::kAuthors && !r->solve.converged()) {
    EXPECT_TRUE(r->solve.status == SolveStatus::kStalled || r->solve.status == SolveStatus::kLineSearchFailed)
        << ToString(r->solve.status) << ": " << r->solve.message;
  } else {
    EXPECT_TRUE(r->solve.converged()) << ToString(r->solve.status) << ": " << r->solve.message;
  }

  const Lame lame = LameParameters(s.cloth, conversion);
  const ClosedForm cf{lame.mu_Pa, lame.lambda_Pa, relaxation};
  const double expected = cf.Force(1 + strain, s.cloth.thickness_m, width);
  const double force = r->clamp_forces[1].force_N.z();
  std::printf("closed form: strain %.2f  simulated %.9g N  closed form %.9g N  ratio %.7f\n", strain, force, expected,
              force / expected);
  EXPECT_NEAR(force / expected, 1.0, 0.005) << "force " << force << " N, closed form " << expected << " N";
  EXPECT_NEAR(r->clamp_forces[0].force_N.z(), -force, 1e-6 * std::abs(force));  // equilibrium of the sample

  // Lateral stretch: the width at mid-height.
  double xmin = 1e9, xmax = -1e9;
  for (Eigen::Index v = 0; v < r->positions.rows(); ++v)
    if (std::abs(s.garment.vertices(v, 2) - 0.5 * length) < 1e-9) {
      xmin = std::min(xmin, r->positions(v, 0));
      xmax = std::max(xmax, r->positions(v, 0));
    }
  const double lateral = (xmax - xmin) / width;
  const double r_free = cf.Lateral(1 + strain);
  // Without relaxation the lateral stretch is the unique r. With relaxation the energy is flat below the
  // wrinkling threshold (r for the exact rule, max(r, s2^-1/2) for the authors'), so any lateral stretch
  // up to it is an equilibrium: only the bound is determined.
  if (relaxation == Relaxation::kNone) {
    EXPECT_NEAR(lateral / r_free, 1.0, 0.005);
  } else {
    const double bound = relaxation == Relaxation::kExact ? r_free : std::max(r_free, 1 / std::sqrt(1 + strain));
    EXPECT_LE(lateral, bound * 1.005);
    EXPECT_GT(lateral, 0.5);
  }
}

std::string CaseName(const ::testing::TestParamInfo<ClosedFormTest::ParamType>& info) {
  const LameConversion c = std::get<0>(info.param);
  const Relaxation r = std::get<1>(info.param);
  const double strain = std::get<2>(info.param);
  return std::string(c == LameConversion::kSolid3D ? "Solid3D" : "PlaneStress") + "_" +
         (r == Relaxation::kExact ? "Exact" : r == Relaxation::kAuthors ? "Authors" : "None") + "_strain" +
         std::to_string(static_cast<int>(std::lround(100 * strain)));
}

INSTANTIATE_TEST_SUITE_P(AllVariants, ClosedFormTest,
                         ::testing::Combine(::testing::Values(LameConversion::kSolid3D, LameConversion::kPlaneStress),
                                            ::testing::Values(Relaxation::kExact, Relaxation::kAuthors, Relaxation::kNone),
                                            ::testing::Values(0.05, 0.10, 0.30)),
                         CaseName);

}  // namespace
}  // namespace kgd
