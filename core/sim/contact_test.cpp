#include "core/sim/contact.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "core/scene/shapes.h"
#include "core/testing/finite_difference_check.h"

namespace kgd {
namespace {

std::shared_ptr<const BodyField> Limb() {
  LimbShape s;
  s.around = 24;
  const TriMesh m = LimbRest(s);
  auto f = BodyField::Build(m.vertices, m.faces);
  EXPECT_TRUE(f.ok()) << f.message();
  return *f;
}

// One vertex's contact energy as a term of its three coordinates (the exact Hessian, or with
// `project` the projected one), on `field` with `cache`.
testing::TermFunction ContactVertexTerm(const BodyField& field, NeighborCache& cache, ContactModel model, double k, bool project) {
  return [&field, &cache, model, k, project](const Eigen::VectorXd& q, Eigen::VectorXd* gq, Eigen::MatrixXd* Hq) {
    Eigen::Vector3d g3;
    Eigen::Matrix3d H3;
    const double E = EvaluateContactVertex(field, q, &cache, model, k, gq ? &g3 : nullptr, Hq ? &H3 : nullptr, project).energy_J;
    if (gq) *gq = g3;
    if (Hq) *Hq = H3;
    return E;
  };
}

// Penalty gradient and exact Hessian against central differences, inside and outside the body.
TEST(Contact, GradientAndHessianMatchFiniteDifferences) {
  const auto field = Limb();
  const double k = kDefaultContactStiffness;
  for (ContactModel model : {ContactModel::kUnilateral, ContactModel::kBilateral}) {
    for (double radial : {0.037, 0.0395, 0.0415}) {  // inside (Phi < 0) and outside (Phi > 0)
      SCOPED_TRACE(std::to_string(radial));
      const Eigen::Vector3d x(radial * std::cos(0.3), 0.1, radial * std::sin(0.3));
      NeighborCache cache;
      Eigen::Vector3d g;
      Eigen::Matrix3d H;
      const ContactEvaluation ce = EvaluateContactVertex(*field, x, &cache, model, k, &g, &H, false);
      ASSERT_TRUE(ce.supported);
      if (radial < 0.039) {
        EXPECT_LT(ce.phi_m, 0);
      }
      if (radial > 0.041) {
        EXPECT_GT(ce.phi_m, 0);
      }
      const testing::TermFunction term = ContactVertexTerm(*field, cache, model, k, false);
      EXPECT_TRUE(testing::MatchesFiniteDifferences(term, x, {.step = 1e-7, .tolerance = 1e-5, .gradient_floor = 1e-3, .hessian_floor = 1.0}));
      if (model == ContactModel::kUnilateral && ce.phi_m > 0) {
        EXPECT_EQ(ce.energy_J, 0.0);
        EXPECT_EQ(g.norm(), 0.0);
      }
    }
  }
}

// The point on the ray x(r) = (r cos 0.3, 0.1, r sin 0.3) where Phi = target (m), by bisection between
// r = 0.037 (inside) and 0.0415 (outside).
Eigen::Vector3d PointAtPhi(const BodyField& field, double target) {
  auto at = [](double r) { return Eigen::Vector3d(r * std::cos(0.3), 0.1, r * std::sin(0.3)); };
  double lo = 0.037, hi = 0.0415;
  for (int i = 0; i < 200 && hi - lo > 1e-16; ++i) {
    const double mid = 0.5 * (lo + hi);
    NeighborCache cache;
    (EvaluateContactVertex(field, at(mid), &cache, ContactModel::kBilateral, 1.0, nullptr, nullptr, false).phi_m < target ? lo : hi) = mid;
  }
  return at(0.5 * (lo + hi));
}

// At the surface, where the unilateral penalty switches on (Phi = 0, its kink: the Hessian jumps from 0
// to 2 k grad Phi grad Phi^T): just inside, the energy, force and stiffness are the model's k Phi^2,
// 2 k Phi grad Phi and 2 k (grad Phi grad Phi^T + Phi Hess Phi), matching central differences; just
// outside, unilateral contact is exactly zero and bilateral continues smoothly. The projected Hessian
// is the eigenvalue clamp of the exact one throughout (there it is rank one up to Phi Hess Phi).
TEST(Contact, AtTheSurfaceTheKinkIsWhereTheModelPutsIt) {
  const auto field = Limb();
  const double k = kDefaultContactStiffness;
  for (double phi : {-1e-6, -1e-8, 1e-8, 1e-6}) {
    const Eigen::Vector3d x = PointAtPhi(*field, phi);
    for (ContactModel model : {ContactModel::kUnilateral, ContactModel::kBilateral}) {
      SCOPED_TRACE(::testing::Message() << "Phi " << phi << (model == ContactModel::kUnilateral ? " unilateral" : " bilateral"));
      NeighborCache cache;
      Eigen::Vector3d g;
      Eigen::Matrix3d H, P;
      const ContactEvaluation ce = EvaluateContactVertex(*field, x, &cache, model, k, &g, &H, false);
      EvaluateContactVertex(*field, x, &cache, model, k, nullptr, &P, true);
      ASSERT_TRUE(ce.supported);
      ASSERT_NEAR(ce.phi_m, phi, 1e-3 * std::abs(phi));
      const Eigen::Vector3d n = ce.phi_grad;
      ASSERT_GT(n.norm(), 0.5);
      if (model == ContactModel::kUnilateral && phi > 0) {
        EXPECT_EQ(ce.energy_J, 0.0);
        EXPECT_EQ(g.norm(), 0.0);
        EXPECT_EQ(H.norm(), 0.0);
        EXPECT_EQ(P.norm(), 0.0);
      } else {
        EXPECT_NEAR(ce.energy_J, k * ce.phi_m * ce.phi_m, 1e-12 * k * ce.phi_m * ce.phi_m);
        EXPECT_LT((g - 2 * k * ce.phi_m * n).norm(), 1e-12 * k * std::abs(ce.phi_m));
        // Along the normal the stiffness is 2 k |grad Phi|^2 up to the curvature term (|Phi Hess Phi| is
        // below 1e-4 of it this close to the surface).
        const Eigen::Vector3d nh = n.normalized();
        EXPECT_NEAR(nh.dot(H * nh), 2 * k * n.squaredNorm(), 1e-4 * 2 * k * n.squaredNorm());
        EXPECT_NEAR(nh.dot(P * nh), 2 * k * n.squaredNorm(), 1e-4 * 2 * k * n.squaredNorm());
      }
      // Central differences with a step well inside |Phi| (never across the kink).
      const double step = 1e-2 * std::abs(phi);
      const testing::TermFunction term = ContactVertexTerm(*field, cache, model, k, false);
      const testing::TermFunction projected = ContactVertexTerm(*field, cache, model, k, true);
      EXPECT_TRUE(testing::MatchesFiniteDifferences(term, x, {.step = step, .tolerance = 1e-5, .gradient_floor = 1e-3 * k * std::abs(phi), .hessian_floor = 1e-3 * k}));
      EXPECT_TRUE(testing::ProjectionIsEigenvalueClamp(term, projected, x));
      EXPECT_TRUE(testing::ProjectionIsPsd(term, projected, x));
    }
  }
}

// Deeper inside, where Phi Hess Phi makes the exact Hessian indefinite, too: the eigenvalue clamp.
TEST(Contact, ProjectedHessianIsTheEigenvalueClampOfTheExactOne) {
  const auto field = Limb();
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(0.036, -0.05, 0.005), PointAtPhi(*field, -2e-3), PointAtPhi(*field, 1e-3)}) {
    SCOPED_TRACE(::testing::Message() << x.transpose());
    NeighborCache cache;
    const testing::TermFunction exact = [&](const Eigen::VectorXd& q, Eigen::VectorXd*, Eigen::MatrixXd* Hq) {
      Eigen::Matrix3d H3;
      EvaluateContactVertex(*field, q, &cache, ContactModel::kBilateral, 5000, nullptr, &H3, false);
      *Hq = H3;
      return 0.0;
    };
    const testing::TermFunction projected = [&](const Eigen::VectorXd& q, Eigen::VectorXd*, Eigen::MatrixXd* Hq) {
      Eigen::Matrix3d H3;
      EvaluateContactVertex(*field, q, &cache, ContactModel::kBilateral, 5000, nullptr, &H3, true);
      *Hq = H3;
      return 0.0;
    };
    EXPECT_TRUE(testing::ProjectionIsEigenvalueClamp(exact, projected, x));
  }
}

}  // namespace
}  // namespace kgd
