#include "core/sim/garment_system.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <omp.h>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <set>
#include <string>

#include "core/scene/scene.h"
#include "core/scene/builtin_scenes.h"
#include "core/sim/attachment.h"
#include "core/sim/contact.h"
#include "core/testing/finite_difference_check.h"
#include "core/sim/fold_barrier.h"
#include "core/sim/membrane.h"
#include "core/sim/simulator.h"

namespace kgd {
namespace {

// A small sleeve on the limb with every effect on: contact, attachments, a clamp, mixed design.
struct Fixture {
  std::unique_ptr<GarmentSystem> sys;
  Positions x;
};

// A small sleeve on the limb: 12 vertices around, 10 cm long.
SceneSpec SmallSleeve(ContactModel contact) {
  SleeveOptions o;
  o.around = 12;
  o.sleeve_halflength_m = 0.05;
  o.contact = contact;
  return SleeveOnLimbScene(o);
}

// Clamps vertices 0 and 1 on `axes`.
void PinFirstTwoVertices(SceneSpec* s, std::array<bool, 3> axes) {
  s->effects.clamps = true;
  Clamp c;
  c.name = "pin";
  c.vertices = {0, 1};
  c.axes = axes;
  s->clamps = {c};
}

// Unit outward normals of the garment at its initial positions, oriented by the body field.
Positions OutwardNormals(GarmentSystem& sys, const SceneSpec& s) {
  Positions out = AreaWeightedVertexNormals(s.initial, s.garment.faces);
  auto inside = [&](const Positions& p) { return (sys.VertexPhi(p).array() < 0).count(); };
  if (inside(s.initial + 2e-3 * out) > inside(s.initial - 2e-3 * out)) out = -out;
  return out;
}

Fixture MakeSystem(ContactModel contact, Relaxation relax) {
  SceneSpec s = SmallSleeve(contact);
  s.effects.relaxation = relax;
  for (size_t f = 0; f < s.design.size(); f += 3) s.design[f] = kReinforced;
  PinFirstTwoVertices(&s, {true, false, true});
  auto model = BuildGarmentModel(s);
  EXPECT_TRUE(model.ok()) << model.message();
  Fixture fx;
  fx.sys = std::make_unique<GarmentSystem>(std::move(model).value(), s.initial);
  fx.x = s.initial;
  // Perturb so that regimes mix (taut, wrinkled, slack) and some vertices sit inside the body.
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1.5e-3);
  for (Eigen::Index v = 0; v < fx.x.rows(); ++v)
    for (int k = 0; k < 3; ++k) fx.x(v, k) += n(rng);
  fx.sys->ApplyClamps(&fx.x);
  return fx;
}

Eigen::VectorXd Flat(const Positions& x) {
  Eigen::VectorXd q(x.size());
  for (Eigen::Index v = 0; v < x.rows(); ++v) q.segment<3>(3 * v) = x.row(v).transpose();
  return q;
}

// Every effect off (membrane included) and no clamps: a base to switch single terms on in.
Effects NoEffects(Relaxation relaxation) {
  Effects e;
  e.membrane = false;
  e.relaxation = relaxation;
  e.fold_barrier = false;
  e.contact = ContactModel::kNone;
  return e;
}

// `model` with only the effects `only` (no clamps: every coordinate free).
std::unique_ptr<GarmentSystem> Only(const GarmentModel& model, const Effects& only, const Positions& initial) {
  GarmentModel m = model;
  m.effects = only;
  EXPECT_TRUE(ValidateModel(m).ok()) << ValidateModel(m).message();
  return std::make_unique<GarmentSystem>(std::move(m), initial);
}

// The assembled Hessian of `sys` at x as a dense matrix on all 3n coordinates (zero on clamped ones).
Eigen::MatrixXd DenseHessian(GarmentSystem& sys, const Positions& x, Eigen::VectorXd* g, double* E) {
  Eigen::SparseMatrix<double> H = sys.hessian_pattern();
  *E = sys.Evaluate(x, g, &H);
  const Eigen::MatrixXd upper_full = Eigen::MatrixXd(Eigen::SparseMatrix<double>(H.selfadjointView<Eigen::Upper>()));
  const auto& fi = sys.free_index();
  const Eigen::Index n = static_cast<Eigen::Index>(fi.size());
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      if (fi[i] >= 0 && fi[j] >= 0) dense(i, j) = upper_full(fi[i], fi[j]);
  return dense;
}

Positions Unflat(const Eigen::VectorXd& q) {
  Positions x(q.size() / 3, 3);
  for (Eigen::Index v = 0; v < x.rows(); ++v) x.row(v) = q.segment<3>(3 * v).transpose();
  return x;
}

// Finite differences of a whole system take thousands of evaluations of a small garment: on one thread
// (the results are bit-identical whatever the thread count), as the threads' synchronization would cost
// more than the work on a busy machine. Restores the thread count when it goes.
struct OneThread {
  int before = omp_get_max_threads();
  OneThread() { omp_set_num_threads(1); }
  ~OneThread() { omp_set_num_threads(before); }
};

// One term of the system as a function of all 3n coordinates: energy, gradient and assembled Hessian
// of `with` minus those of `without` (null: nothing), both evaluated at the same positions.
testing::TermFunction TermPart(GarmentSystem& with, GarmentSystem* without) {
  return [&with, without](const Eigen::VectorXd& q, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
    const Positions x = Unflat(q);
    Eigen::VectorXd gw, go;
    double E = 0, Eo = 0;
    if (H) {
      *H = DenseHessian(with, x, g ? &gw : nullptr, &E);
      if (without) *H -= DenseHessian(*without, x, g ? &go : nullptr, &Eo);
    } else {
      E = with.Evaluate(x, g ? &gw : nullptr, nullptr);
      if (without) Eo = without->Evaluate(x, g ? &go : nullptr, nullptr);
    }
    if (g) *g = without ? Eigen::VectorXd(gw - go) : gw;
    return E - Eo;
  };
}

// Each term's assembled gradient against central differences of that term's energy, on every
// coordinate (free, clamped, attached, in contact) and relative to the term's own gradient, so no term
// hides behind a larger one; the terms' gradients and energies sum to the whole system's. Every term
// on: membrane (mixed regimes and design), fold barrier, attachments, contact of each model, friction
// (lagged pressed into the body) and bending; the attachment Hessian is exact and checked too.
TEST(GarmentSystem, EachTermsGradientMatchesFiniteDifferencesOnEveryCoordinate) {
  const OneThread one_thread;
  std::set<std::string> checked;
  for (ContactModel contact : {ContactModel::kUnilateral, ContactModel::kBilateral, ContactModel::kNone}) {
    SCOPED_TRACE(contact == ContactModel::kNone ? "no contact" : contact == ContactModel::kUnilateral ? "unilateral" : "bilateral");
    Fixture fx = MakeSystem(contact, Relaxation::kExact);
    const SceneSpec s = SmallSleeve(contact);
    GarmentModel all = fx.sys->model();
    all.effects.bending = true;
    if (contact != ContactModel::kNone) all.effects.friction = 0.4;
    GarmentSystem sys(all, s.initial);
    Positions pressed;
    if (contact != ContactModel::kNone) {
      pressed = s.initial - 1e-3 * OutwardNormals(sys, s);
      sys.Lag(pressed);
    }
    Eigen::VectorXd g_all;
    EnergyBreakdown e;
    const double E_all = sys.Evaluate(fx.x, &g_all, nullptr, &e);
    if (contact != ContactModel::kNone) {
      EXPECT_GT((sys.VertexPhi(fx.x).array() < 0).count(), 0) << "vertices in contact";
      EXPECT_GT(e["friction"], 0);
    }
    Eigen::VectorXd g_sum = Eigen::VectorXd::Zero(g_all.size()), g_abs = g_sum;
    double E_sum = 0;
    for (const char* name : sys.term_names()) {
      SCOPED_TRACE(name);
      const std::string term = name;
      Effects only = NoEffects(all.effects.relaxation);
      if (term == "membrane") only.membrane = true;
      if (term == "fold_barrier") only.fold_barrier = true;
      if (term == "attachment") only.attachments = true;
      if (term == "bending") only.bending = true;
      if (term == "contact" || term == "friction") only.contact = contact;
      std::unique_ptr<GarmentSystem> with = Only(all, only, s.initial), without;
      if (term == "friction") {
        without = Only(all, only, s.initial);
        with = Only(all, [&] { Effects f = only; f.friction = all.effects.friction; return f; }(), s.initial);
        with->Lag(pressed);
      }
      ASSERT_GE(with->term_index(name), 0);
      const testing::TermFunction part = TermPart(*with, without.get());
      Eigen::VectorXd g;
      const double E = part(Flat(fx.x), &g, nullptr);
      EXPECT_NEAR(E, e[name], 1e-12 * (std::abs(E) + std::abs(e["contact"])));
      E_sum += E;
      g_sum += g;
      g_abs += g.cwiseAbs();
      // Only contact and friction depend on the contact model: the others are differentiated once.
      if (!checked.insert(term + (term == "contact" || term == "friction" ? std::to_string(static_cast<int>(contact)) : "")).second) continue;
      const bool exact_hessian = term == "attachment";  // friction's: the next test
      EXPECT_TRUE(testing::MatchesFiniteDifferences(part, Flat(fx.x), {.step = 1e-8, .tolerance = 1e-5, .check_hessian = exact_hessian}));
    }
    EXPECT_NEAR(E_sum, E_all, 1e-12 * std::abs(E_all));
    EXPECT_LE((g_sum - g_all).cwiseAbs().maxCoeff(), 1e-12 * g_abs.maxCoeff());
  }
}

// The assembled Hessians the solver gets, against central differences of the assembled gradient on
// every coordinate:
//  - friction's is exact (PSD by construction): everywhere, lagged pressed into the body and evaluated
//    slid off the anchors;
//  - bending's is the Gauss-Newton part 2 k grad theta grad theta^T, which is the exact Hessian where
//    every hinge is at its rest angle: the rest shape turned, moved and scaled by 1.1;
//  - the fold barrier's is the Gauss-Newton part b'' grad q grad q^T; the dropped b' Hess q has no 3x3
//    block on a vertex (q is linear in each vertex), so on every vertex the assembled block is the exact
//    one: the sleeve shrunk to a twentieth of its area, every face active.
TEST(GarmentSystem, AssembledHessiansOfFrictionBendingAndFoldBarrierMatchFiniteDifferences) {
  const OneThread one_thread;
  SceneSpec s = SmallSleeve(ContactModel::kUnilateral);
  for (size_t f = 0; f < s.design.size(); f += 3) s.design[f] = kReinforced;
  auto model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok()) << model.message();
  const GarmentModel& m = *model;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 1);
  {
    SCOPED_TRACE("friction");
    Effects contact = NoEffects(m.effects.relaxation), friction = contact;
    contact.contact = friction.contact = ContactModel::kUnilateral;
    friction.friction = 0.4;
    std::unique_ptr<GarmentSystem> with = Only(m, friction, s.initial), without = Only(m, contact, s.initial);
    with->Lag(s.initial - 1e-3 * OutwardNormals(*with, s));
    Positions x = s.initial;
    for (Eigen::Index v = 0; v < x.rows(); ++v)
      for (int k = 0; k < 3; ++k) x(v, k) += 1e-3 * noise(rng);
    EnergyBreakdown e;
    with->Evaluate(x, nullptr, nullptr, &e);
    EXPECT_GT(e["friction"], 0);
    EXPECT_TRUE(testing::MatchesFiniteDifferences(TermPart(*with, without.get()), Flat(x), {.step = 1e-8, .tolerance = 1e-5}));
  }
  {
    SCOPED_TRACE("bending at the rest angles");
    Effects bending = NoEffects(m.effects.relaxation);
    bending.bending = true;
    std::unique_ptr<GarmentSystem> sys = Only(m, bending, s.initial);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
    Positions x = (1.1 * m.rest * R.transpose()).rowwise() + Eigen::RowVector3d(0.02, -0.01, 0.03);
    Eigen::MatrixXd H;
    Eigen::VectorXd g;
    TermPart(*sys, nullptr)(Flat(x), &g, &H);
    ASSERT_GT(H.norm(), 0);
    EXPECT_TRUE(testing::MatchesFiniteDifferences(TermPart(*sys, nullptr), Flat(x), {.step = 1e-8, .tolerance = 1e-5, .gradient_floor = 1e-9 * H.norm()}));
  }
  {
    SCOPED_TRACE("fold barrier squeezed");
    Effects fold = NoEffects(m.effects.relaxation);
    fold.fold_barrier = true;
    std::unique_ptr<GarmentSystem> sys = Only(m, fold, s.initial);
    // Shrunk to 0.22 of its size about its centre (areas to 5 %), plus 0.1 mm of noise.
    const Eigen::RowVector3d mean = s.initial.colwise().mean();
    Positions x = (0.22 * (s.initial.rowwise() - mean)).rowwise() + mean;
    for (Eigen::Index v = 0; v < x.rows(); ++v)
      for (int k = 0; k < 3; ++k) x(v, k) += 1e-4 * noise(rng);
    EnergyBreakdown e;
    ASSERT_TRUE(std::isfinite(sys->Evaluate(x, nullptr, nullptr, &e)));
    ASSERT_EQ(CountFoldedFaces(s.initial, x, m.faces), 0);
    EXPECT_GT(e["fold_barrier"], 0);
    const testing::TermFunction part = TermPart(*sys, nullptr);
    EXPECT_TRUE(testing::MatchesFiniteDifferences(part, Flat(x), {.step = 1e-9, .tolerance = 1e-5, .check_hessian = false}));
    Eigen::MatrixXd P;
    part(Flat(x), nullptr, &P);
    const Eigen::MatrixXd H = testing::FiniteDifferenceHessian(part, Flat(x), 1e-9);
    double block_error = 0, block_norm = 0;
    for (Eigen::Index v = 0; v < x.rows(); ++v) {
      block_error += (P.block<3, 3>(3 * v, 3 * v) - H.block<3, 3>(3 * v, 3 * v)).squaredNorm();
      block_norm += H.block<3, 3>(3 * v, 3 * v).squaredNorm();
    }
    ASSERT_GT(block_norm, 0);
    EXPECT_LT(std::sqrt(block_error), 1e-5 * std::sqrt(block_norm));
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P).eigenvalues().minCoeff(), -1e-9 * P.norm());
  }
}

// The sparse assembly equals a dense sum of the per-term projected Hessians restricted to free dofs.
TEST(GarmentSystem, SparseAssemblyMatchesDenseAssembly) {
  Fixture fx = MakeSystem(ContactModel::kUnilateral, Relaxation::kExact);
  GarmentSystem& sys = *fx.sys;
  Eigen::SparseMatrix<double> H = sys.hessian_pattern();
  sys.Evaluate(fx.x, nullptr, &H);
  const int n3 = 3 * sys.num_vertices();
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n3, n3);
  const GarmentModel& m = sys.model();
  const double kf = AttachmentFaceStiffness(m.attachments);
  std::vector<char> attached(sys.num_faces(), 0);
  for (int f : m.attachments.faces) attached[f] = 1;
  for (int f = 0; f < sys.num_faces(); ++f) {
    const Material& mat = m.design[f] ? m.reinforced : m.cloth;
    Matrix9d He;
    const MembraneElement el = MakeMembraneElement(m.rest.row(m.faces(f, 0)), m.rest.row(m.faces(f, 1)), m.rest.row(m.faces(f, 2)));
    EXPECT_EQ(el.rest_area_m2, sys.rest_areas_m2()[f]);
    EvaluateMembraneElement(el, fx.x.row(m.faces(f, 0)), fx.x.row(m.faces(f, 1)), fx.x.row(m.faces(f, 2)),
                            LameParameters(mat, m.lame), mat.thickness_m, m.effects.relaxation, nullptr, &He, true);
    if (attached[f])
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) He.block<3, 3>(3 * a, 3 * b) += (2 * kf / 9) * Eigen::Matrix3d::Identity();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) dense.block<3, 3>(3 * m.faces(f, a), 3 * m.faces(f, b)) += He.block<3, 3>(3 * a, 3 * b);
  }
  for (int v = 0; v < sys.num_vertices(); ++v) {
    NeighborCache c;
    Eigen::Matrix3d Hc;
    EvaluateContactVertex(*m.body, fx.x.row(v).transpose(), &c, m.effects.contact, m.contact_stiffness_N_per_m, nullptr, &Hc, true);
    dense.block<3, 3>(3 * v, 3 * v) += Hc;
  }
  const Eigen::SparseMatrix<double> full_sparse = H.selfadjointView<Eigen::Upper>();
  const Eigen::MatrixXd sparse_full = Eigen::MatrixXd(full_sparse);
  const auto& fi = sys.free_index();
  double max_err = 0;
  for (int i = 0; i < n3; ++i)
    for (int j = 0; j < n3; ++j)
      if (fi[i] >= 0 && fi[j] >= 0) max_err = std::max(max_err, std::abs(dense(i, j) - sparse_full(fi[i], fi[j])));
  EXPECT_LT(max_err, 1e-9 * dense.norm());
  EXPECT_EQ(sys.num_free_dofs(), n3 - 4);  // two vertices with x and z clamped
}

// Friction in the assembled system: its lagged data come from the contact forces at a state, and it adds
// to the energy only where the garment presses on the body (its derivatives: the tests above).
TEST(GarmentSystem, FrictionGradientMatchesFiniteDifferencesAndNeedsContactForce) {
  SceneSpec s = SmallSleeve(ContactModel::kUnilateral);
  s.effects.friction = 0.4;
  auto model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok()) << model.message();
  GarmentSystem sys(std::move(model).value(), s.initial);
  // Lag at a state pressed into the body, then evaluate at a displaced one.
  const Positions out = OutwardNormals(sys, s);
  auto inside = [&](const Positions& p) { return (sys.VertexPhi(p).array() < 0).count(); };
  ASSERT_GT(inside(s.initial - 1e-3 * out), s.initial.rows() / 2);
  const Positions pressed = s.initial - 1e-3 * out;
  Positions x = s.initial;
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1e-3);
  for (Eigen::Index v = 0; v < x.rows(); ++v)
    for (int k = 0; k < 3; ++k) x(v, k) += n(rng);
  EnergyBreakdown before;
  sys.Evaluate(x, nullptr, nullptr, &before);
  EXPECT_EQ(before["friction"], 0.0) << "no friction before its data are lagged";
  sys.Lag(pressed);
  Eigen::VectorXd g;
  EnergyBreakdown e;
  sys.Evaluate(x, &g, nullptr, &e);
  EXPECT_GT(e["friction"], 0);
  // Lagged where the garment is off the body: no normal force, no friction.
  sys.Lag(s.initial.rowwise() + Eigen::RowVector3d(1.0, 0, 0));
  sys.Evaluate(x, nullptr, nullptr, &e);
  EXPECT_EQ(e["friction"], 0.0);
  // Friction without contact is refused.
  SceneSpec bad = s;
  bad.effects.contact = ContactModel::kNone;
  const Result<GarmentModel> refused = BuildGarmentModel(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("effects.friction needs contact"), std::string::npos) << refused.message();
}

// The small sleeve with unilateral contact and its first two vertices clamped (*s), and its garment
// system, or null (with a test failure) if the model does not build.
std::unique_ptr<GarmentSystem> PinnedUnilateralSleeve(SceneSpec* s) {
  *s = SmallSleeve(ContactModel::kUnilateral);
  PinFirstTwoVertices(s, {true, true, true});
  auto model = BuildGarmentModel(*s);
  EXPECT_TRUE(model.ok()) << model.message();
  if (!model.ok()) return nullptr;
  return std::make_unique<GarmentSystem>(std::move(model).value(), s->initial);
}

// The line search's projection: a vertex that a trial step carries from off the body into it goes back
// to just inside the surface; vertices in contact that the step leaves at the depth the linear model
// predicts, clamped vertices, and the other contact models are left alone.
// The record of an evaluation at x with a gradient (it holds what the terms' ProjectTrial needs).
EvaluationRecord RecordAt(GarmentSystem& sys, const Positions& x) {
  Eigen::VectorXd g;
  EvaluationRecord r;
  sys.Evaluate(x, &g, nullptr, nullptr, &r);
  return r;
}

// The record of an evaluation with a gradient holds the contact term's Phi and grad Phi per vertex
// (the line search's contact projection starts from them): they must be what sampling the field
// afresh gives.
TEST(GarmentSystem, RecordedPhiMatchesFreshSampling) {
  Fixture a = MakeSystem(ContactModel::kUnilateral, Relaxation::kExact);
  Fixture b = MakeSystem(ContactModel::kUnilateral, Relaxation::kExact);
  Eigen::VectorXd g;
  EvaluationRecord record;
  a.sys->Evaluate(a.x, &g, nullptr, nullptr, &record);
  Positions grad_b;
  const Eigen::VectorXd phi_b = b.sys->VertexPhi(b.x, &grad_b);
  const int contact = a.sys->term_index("contact");
  ASSERT_GE(contact, 0);
  const std::vector<double>& rec = record.recorded[contact];
  ASSERT_EQ(rec.size(), 4 * static_cast<size_t>(phi_b.size()));
  int supported = 0;
  for (Eigen::Index v = 0; v < phi_b.size(); ++v) {
    ASSERT_EQ(std::isnan(rec[4 * v]), std::isnan(phi_b[v])) << "vertex " << v;
    if (std::isnan(phi_b[v])) continue;
    ++supported;
    EXPECT_EQ(rec[4 * v], phi_b[v]) << "vertex " << v;
    EXPECT_EQ(Eigen::RowVector3d(rec[4 * v + 1], rec[4 * v + 2], rec[4 * v + 3]), grad_b.row(v)) << "vertex " << v;
  }
  EXPECT_GT(supported, phi_b.size() / 2);
  // Without a gradient nothing is recorded.
  a.sys->Evaluate(a.x, nullptr, nullptr, nullptr, &record);
  EXPECT_TRUE(record.recorded[contact].empty());
}

// Exact equality of two evaluations' results, NaN-aware for what the terms record.
void ExpectSameEvaluation(const EvaluationRecord& a, const EvaluationRecord& b) {
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.energy_J, b.energy_J);
  ASSERT_EQ(a.recorded.size(), b.recorded.size());
  for (size_t t = 0; t < a.recorded.size(); ++t) {
    ASSERT_EQ(a.recorded[t].size(), b.recorded[t].size()) << "term " << t;
    for (size_t i = 0; i < a.recorded[t].size(); ++i)
      EXPECT_TRUE(a.recorded[t][i] == b.recorded[t][i] || (std::isnan(a.recorded[t][i]) && std::isnan(b.recorded[t][i])))
          << "term " << t << ", value " << i;
  }
}

void ExpectSameBreakdown(const EnergyBreakdown& a, const EnergyBreakdown& b) {
  ASSERT_EQ(a.terms.size(), b.terms.size());
  for (size_t t = 0; t < a.terms.size(); ++t) {
    EXPECT_STREQ(a.terms[t].name, b.terms[t].name);
    EXPECT_EQ(a.terms[t].energy_J, b.terms[t].energy_J) << a.terms[t].name;
  }
}

// EvaluateFrom re-evaluates only what the moved vertices touch, yet must give exactly what a full
// evaluation gives: energy, breakdown, gradient, Hessian and record, with every term on (contact,
// friction, attachments, fold barrier, a clamp, mixed design, regimes mixed), with the outputs in place
// of the base's, energy-only, after a few faces' design changed (with and without moved vertices), and
// after much of the design or the lagged friction changed under the record.
TEST(GarmentSystem, EvaluateFromMatchesAFullEvaluationBitForBit) {
  SceneSpec s = SmallSleeve(ContactModel::kUnilateral);
  s.effects.fold_barrier = true;
  s.effects.friction = 0.4;
  for (size_t f = 0; f < s.design.size(); f += 3) s.design[f] = kReinforced;
  PinFirstTwoVertices(&s, {true, false, true});
  auto model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok()) << model.message();
  ASSERT_TRUE(model.value().effects.attachments && !model.value().attachments.faces.empty());
  GarmentSystem sys(std::move(model).value(), s.initial);
  sys.Lag(s.initial - 1e-3 * OutwardNormals(sys, s));
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0, 1e-3);
  Positions x = s.initial;
  for (Eigen::Index v = 0; v < x.rows(); ++v)
    for (int k = 0; k < 3; ++k) x(v, k) += n(rng);
  sys.ApplyClamps(&x);

  Eigen::VectorXd g0;
  Eigen::SparseMatrix<double> H0 = sys.hessian_pattern();
  EvaluationRecord r0;
  sys.Evaluate(x, &g0, &H0, nullptr, &r0);
  ASSERT_GE(sys.term_index("friction"), 0);
  EXPECT_GT(r0.energy_J[sys.term_index("friction")].size(), 0u);
  // Move a few vertices, among them a clamped one (0) and one in an attachment band.
  const int attached = sys.model().faces(sys.model().attachments.faces[0], 1);
  Positions y = x;
  for (int v : {0, 1, 17, 40, attached}) y.row(v) += Eigen::RowVector3d(n(rng), n(rng), n(rng));
  sys.ApplyClamps(&y);
  ASSERT_LT(3 * 5, sys.num_vertices());

  Eigen::VectorXd g_full;
  Eigen::SparseMatrix<double> H_full = sys.hessian_pattern();
  EvaluationRecord r_full;
  EnergyBreakdown b_full;
  const double E_full = sys.Evaluate(y, &g_full, &H_full, &b_full, &r_full);
  ASSERT_TRUE(std::isfinite(E_full));
  auto expect_full = [&](double E, const Eigen::VectorXd& g, const Eigen::SparseMatrix<double>& H,
                         const EnergyBreakdown& b, const EvaluationRecord& r) {
    EXPECT_EQ(E, E_full);
    ExpectSameBreakdown(b, b_full);
    EXPECT_EQ(g, g_full);
    EXPECT_TRUE(std::equal(H.valuePtr(), H.valuePtr() + H.nonZeros(), H_full.valuePtr()));
    ExpectSameEvaluation(r, r_full);
  };
  {
    SCOPED_TRACE("into new objects");
    Eigen::VectorXd g;
    Eigen::SparseMatrix<double> H = sys.hessian_pattern();
    EvaluationRecord r;
    EnergyBreakdown b;
    const double E = sys.EvaluateFrom(r0, &g0, &H0, y, &g, &H, &b, &r);
    expect_full(E, g, H, b, r);
  }
  {
    SCOPED_TRACE("gradient only, and energy only");
    Eigen::VectorXd g, g_ref;
    EXPECT_EQ(sys.EvaluateFrom(r0, &g0, nullptr, y, &g, nullptr), E_full);
    sys.Evaluate(y, &g_ref, nullptr);
    EXPECT_EQ(g, g_ref);
    EnergyBreakdown b;
    EXPECT_EQ(sys.EvaluateFrom(r0, nullptr, nullptr, y, nullptr, nullptr, &b), E_full);
    ExpectSameBreakdown(b, b_full);
  }
  {
    SCOPED_TRACE("in place of the base");
    Eigen::VectorXd g = g0;
    Eigen::SparseMatrix<double> H = H0;
    EvaluationRecord r = r0;
    EnergyBreakdown b;
    const double E = sys.EvaluateFrom(r, &g, &H, y, &g, &H, &b, &r);
    expect_full(E, g, H, b, r);
  }
  {
    SCOPED_TRACE("the base is used: a face the move does not touch keeps the base's energy");
    EvaluationRecord r = r0;
    int far = -1;
    for (int f = 0; f < sys.num_faces() && far < 0; ++f) {
      bool touched = false;
      for (int k = 0; k < 3; ++k) touched |= (y.row(sys.model().faces(f, k)) != x.row(sys.model().faces(f, k)));
      if (!touched) far = f;
    }
    ASSERT_GE(far, 0);
    r.energy_J[sys.term_index("membrane")][far] += 1.0;
    EXPECT_NEAR(sys.EvaluateFrom(r, nullptr, nullptr, y, nullptr, nullptr), E_full + 1.0, 1e-12);
  }
  {
    SCOPED_TRACE("many moved: a full evaluation");
    Positions z = x;
    z.array() += 1e-4;
    sys.ApplyClamps(&z);
    Eigen::VectorXd g, g_ref;
    EvaluationRecord r = r0;
    r.energy_J[sys.term_index("membrane")][0] += 1.0;  // would show if the base were used
    EXPECT_EQ(sys.EvaluateFrom(r, &g0, nullptr, z, &g, nullptr), sys.Evaluate(z, &g_ref, nullptr));
    EXPECT_EQ(g, g_ref);
  }
  {
    SCOPED_TRACE("a few faces' design changed under the record (a BESO re-solve's first evaluation)");
    std::vector<uint8_t> design = sys.model().design;
    for (int f : {3, 10, 11, sys.num_faces() / 2}) design[f] ^= 1;
    sys.SetDesign(design);
    for (const Positions* at : {&x, &y}) {  // the design alone, and with the moved vertices
      SCOPED_TRACE(at == &x ? "at the base's positions" : "with vertices moved");
      Eigen::VectorXd g_ref;
      Eigen::SparseMatrix<double> H_ref = sys.hessian_pattern();
      EnergyBreakdown b_ref;
      EvaluationRecord r_ref;
      const double E_ref = sys.Evaluate(*at, &g_ref, &H_ref, &b_ref, &r_ref);
      Eigen::VectorXd g = g0;
      Eigen::SparseMatrix<double> H = H0;
      EvaluationRecord r = r0;
      EnergyBreakdown b;
      EXPECT_EQ(sys.EvaluateFrom(r, &g, &H, *at, &g, &H, &b, &r), E_ref);
      ExpectSameBreakdown(b, b_ref);
      EXPECT_EQ(g, g_ref);
      EXPECT_TRUE(std::equal(H.valuePtr(), H.valuePtr() + H.nonZeros(), H_ref.valuePtr()));
      ExpectSameEvaluation(r, r_ref);
      EXPECT_EQ(r.design, design);
      EXPECT_EQ(sys.EvaluateFrom(r0, nullptr, nullptr, *at, nullptr, nullptr), E_ref);
    }
    // The base is used: a face neither redesigned nor near one keeps the base's energy.
    EvaluationRecord r = r0;
    const int far = sys.num_faces() - 1;
    for (int k = 0; k < 3; ++k)
      for (int f : {3, 10, 11, sys.num_faces() / 2})
        for (int l = 0; l < 3; ++l) ASSERT_NE(sys.model().faces(far, k), sys.model().faces(f, l));
    r.energy_J[sys.term_index("membrane")][far] += 1.0;
    EXPECT_NEAR(sys.EvaluateFrom(r, nullptr, nullptr, x, nullptr, nullptr), sys.Evaluate(x, nullptr, nullptr) + 1.0, 1e-12);

    SCOPED_TRACE("half the faces' design changed: a full evaluation");
    for (size_t f = 0; f < design.size(); f += 2) design[f] ^= 1;
    sys.SetDesign(design);
    Eigen::VectorXd g, g_ref;
    r.energy_J[sys.term_index("membrane")][0] += 1.0;  // would show if the base were used
    EXPECT_EQ(sys.EvaluateFrom(r, &g0, nullptr, y, &g, nullptr), sys.Evaluate(y, &g_ref, nullptr));
    EXPECT_EQ(g, g_ref);
  }
  {
    SCOPED_TRACE("the lagged friction changed under the record");
    EvaluationRecord r;
    sys.Evaluate(x, &g0, &H0, nullptr, &r);
    sys.Lag(s.initial - 2e-3 * OutwardNormals(sys, s));
    Eigen::VectorXd g, g_ref;
    EXPECT_EQ(sys.EvaluateFrom(r, &g0, nullptr, y, &g, nullptr), sys.Evaluate(y, &g_ref, nullptr));
    EXPECT_EQ(g, g_ref);
  }
}

TEST(GarmentSystem, ProjectTrialMovesOnlyTheVerticesThatCrossed) {
  SceneSpec s;
  std::unique_ptr<GarmentSystem> system = PinnedUnilateralSleeve(&s);
  ASSERT_TRUE(system);
  GarmentSystem& sys = *system;
  const Positions out = OutwardNormals(sys, s);
  // This sleeve starts 1-3 mm inside the limb. A step from 4 mm further out (every third vertex from
  // where it is, inside) to there.
  Positions from = s.initial + 4e-3 * out;
  for (Eigen::Index v = 0; v < from.rows(); v += 3) from.row(v) = s.initial.row(v);
  const Positions step_end = s.initial;
  Positions grad_from;
  const Eigen::VectorXd phi_from = sys.VertexPhi(from, &grad_from);
  const Eigen::VectorXd phi_end = sys.VertexPhi(step_end);
  Positions trial = step_end;
  const int moved = sys.ProjectTrial(RecordAt(sys, from), &trial);
  const Eigen::VectorXd phi = sys.VertexPhi(trial);
  int expected = 0;
  for (Eigen::Index v = 0; v < trial.rows(); ++v) {
    const bool clamped = v <= 1;
    const bool crossed = phi_from[v] >= 0 && phi_end[v] < -2 * kContactProjectionDepth_m;
    if (crossed && !clamped) {
      ++expected;
      EXPECT_LT(phi[v], 0.0) << "vertex " << v;
      EXPECT_GT(phi[v], -2 * kContactProjectionDepth_m) << "vertex " << v;
      // Moved along the field's normal, by about the depth it had crossed.
      EXPECT_NEAR((trial.row(v) - step_end.row(v)).norm(), -phi_end[v], 0.2 * -phi_end[v]) << "vertex " << v;
    } else {
      EXPECT_EQ(trial.row(v), step_end.row(v)) << "vertex " << v;
    }
  }
  EXPECT_EQ(moved, expected);
  EXPECT_GT(expected, trial.rows() / 3) << "the test must exercise crossings";
  // Bilateral contact keeps vertices on the surface from both sides: nothing to project.
  SceneSpec b = s;
  b.effects.contact = ContactModel::kBilateral;
  auto bmodel = BuildGarmentModel(b);
  ASSERT_TRUE(bmodel.ok());
  GarmentSystem bsys(std::move(bmodel).value(), b.initial);
  Positions btrial = step_end;
  EXPECT_EQ(bsys.ProjectTrial(RecordAt(bsys, from), &btrial), 0);
  EXPECT_EQ(btrial, step_end);
}

// A vertex in contact that a step slides along the curved limb (here: 3 mm in the tangent plane, so the
// linear model predicts no change of depth) ends shallower or deeper; the projection puts it back at its
// depth, moving it along the normal by just the difference.
TEST(GarmentSystem, ProjectTrialKeepsSlidingContactAtThePredictedDepth) {
  SceneSpec s;
  std::unique_ptr<GarmentSystem> system = PinnedUnilateralSleeve(&s);
  ASSERT_TRUE(system);
  GarmentSystem& sys = *system;
  const Positions& from = s.initial;  // 1-3 mm inside the limb: every vertex in contact
  Positions grad_from;
  const Eigen::VectorXd phi_from = sys.VertexPhi(from, &grad_from);
  Positions step_end = from;
  for (Eigen::Index v = 0; v < from.rows(); ++v) {
    const Eigen::Vector3d n = grad_from.row(v).transpose().normalized();
    step_end.row(v) += 3e-3 * n.unitOrthogonal().transpose();
  }
  const Eigen::VectorXd phi_end = sys.VertexPhi(step_end);
  Positions trial = step_end;
  const int moved = sys.ProjectTrial(RecordAt(sys, from), &trial);
  const Eigen::VectorXd phi = sys.VertexPhi(trial);
  int off_prediction = 0, shallower = 0, deeper = 0;
  for (Eigen::Index v = 0; v < trial.rows(); ++v) {
    ASSERT_LT(phi_from[v], 0.0) << "vertex " << v;
    const double miss = phi_end[v] - phi_from[v];  // the linear model predicts phi_from
    if (v <= 1) {
      EXPECT_EQ(trial.row(v), step_end.row(v)) << "clamped vertex " << v;
      continue;
    }
    const double tol = 1e-3 * -phi_from[v] + 0.5 * kContactProjectionDepth_m;
    EXPECT_NEAR(phi[v], phi_from[v], tol) << "vertex " << v;
    if (std::abs(miss) <= tol) {
      EXPECT_EQ(trial.row(v), step_end.row(v)) << "vertex " << v;
      continue;
    }
    ++off_prediction;
    ++(miss > 0 ? shallower : deeper);
    EXPECT_NEAR((trial.row(v) - step_end.row(v)).norm(), std::abs(miss), 0.2 * std::abs(miss)) << "vertex " << v;
  }
  EXPECT_EQ(moved, off_prediction);
  EXPECT_GT(off_prediction, trial.rows() / 2) << "the test must exercise sliding off the predicted depth";
  // The limb is convex round its axis, concave on the inside of its bend: both sides are exercised.
  EXPECT_GT(shallower, 0);
  EXPECT_GT(deeper, 0);
}

TEST(GarmentSystem, WithoutContactNoBodyFieldIsBuilt) {
  const long before = BodyField::BuildCount();
  auto pull = PullTestScene("line");
  ASSERT_TRUE(pull.ok());
  auto model = BuildGarmentModel(*pull);
  ASSERT_TRUE(model.ok());
  GarmentSystem sys(std::move(model).value(), pull->initial);
  Eigen::VectorXd g;
  sys.Evaluate(pull->initial, &g, nullptr);
  EXPECT_EQ(BodyField::BuildCount(), before);
  EXPECT_FALSE(sys.model().body);
  // A scene that does carry a body mesh, with contact off, does not build one either.
  SleeveOptions o;
  o.around = 12;
  SceneSpec sleeve = SleeveOnLimbScene(o);
  sleeve.effects.contact = ContactModel::kNone;
  ASSERT_TRUE(BuildGarmentModel(sleeve).ok());
  EXPECT_EQ(BodyField::BuildCount(), before);
  sleeve.effects.contact = ContactModel::kUnilateral;
  ASSERT_TRUE(BuildGarmentModel(sleeve).ok());
  EXPECT_EQ(BodyField::BuildCount(), before + 1);
}

// Each effect a scene leaves off is neither built nor evaluated: its term is absent from the system and
// from the solve's time account, and the terms that are built account for their evaluations.
TEST(GarmentSystem, AnEffectLeftOffIsNeitherBuiltNorEvaluated) {
  struct Case {
    const char* term;
    void (*on)(SceneSpec*);
    void (*off)(SceneSpec*);
  };
  const Case cases[] = {
      {"attachment", [](SceneSpec* s) { s->effects.attachments = true; }, [](SceneSpec* s) { s->effects.attachments = false; }},
      {"fold_barrier", [](SceneSpec* s) { s->effects.fold_barrier = true; }, [](SceneSpec* s) { s->effects.fold_barrier = false; }},
      {"friction", [](SceneSpec* s) { s->effects.friction = 0.4; }, [](SceneSpec* s) { s->effects.friction = 0; }},
      {"bending", [](SceneSpec* s) { s->effects.bending = true; }, [](SceneSpec* s) { s->effects.bending = false; }},
      {"contact", [](SceneSpec* s) { s->effects.contact = ContactModel::kUnilateral; },
       [](SceneSpec* s) {
         s->effects.contact = ContactModel::kNone;
         s->effects.friction = 0;  // friction needs contact
         PinFirstTwoVertices(s, {true, true, true});
       }},
  };
  for (const Case& c : cases) {
    for (bool on : {false, true}) {
      SCOPED_TRACE(std::string(c.term) + (on ? " on" : " off"));
      SceneSpec s = SmallSleeve(ContactModel::kUnilateral);
      (on ? c.on : c.off)(&s);
      const long fields_before = BodyField::BuildCount();
      auto model = BuildGarmentModel(s);
      ASSERT_TRUE(model.ok()) << model.message();
      if (std::string_view(c.term) == "contact") {
        EXPECT_EQ(BodyField::BuildCount() - fields_before, on ? 1 : 0);
      }
      GarmentSystem sys(std::move(model).value(), s.initial);
      EXPECT_EQ(sys.term_index(c.term) >= 0, on);
      Simulator sim(&sys);
      Positions x = s.initial;
      SolverSettings settings;
      settings.max_iterations = 5;
      const SolveReport r = SolveLagged(sim, sys, &x, settings);
      bool evaluated = false;
      for (const GarmentSystem::TermTime& t : r.term_times) {
        EXPECT_GT(t.elements, 0) << t.name;
        EXPECT_GT(t.seconds, 0.0) << t.name;
        evaluated = evaluated || std::string_view(t.name) == c.term;
      }
      EXPECT_EQ(evaluated, on);
      EXPECT_EQ(r.term_times.size(), sys.term_names().size());
      double terms_s = 0;
      for (const GarmentSystem::TermTime& t : r.term_times) terms_s += t.seconds;
      EXPECT_LE(terms_s, r.seconds);
      if (!on && std::string_view(c.term) == "contact") {
        EXPECT_EQ(r.body_field_query_s, 0.0);
      }
    }
  }
  // Clamps: a scene without them keeps every coordinate free.
  SceneSpec s = SmallSleeve(ContactModel::kUnilateral);
  auto model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok());
  EXPECT_EQ(GarmentSystem(std::move(model).value(), s.initial).num_free_dofs(), 3 * s.initial.rows());
  PinFirstTwoVertices(&s, {true, true, true});
  model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok());
  EXPECT_EQ(GarmentSystem(std::move(model).value(), s.initial).num_free_dofs(), 3 * s.initial.rows() - 6);
}

// The time account splits each stencil's measured loop among its terms: every evaluation counts each
// built term's elements once, and the times add up to no more than the evaluations took.
TEST(GarmentSystem, TermTimesCountEveryElementOfEveryEvaluation) {
  SceneSpec s = SmallSleeve(ContactModel::kUnilateral);
  auto model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok());
  GarmentSystem sys(std::move(model).value(), s.initial);
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> H = sys.hessian_pattern();
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < 3; ++k) sys.Evaluate(s.initial, &g, &H);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  double sum = 0;
  for (const GarmentSystem::TermTime& t : sys.term_times()) {
    const long long per = std::string_view(t.name) == "contact" ? sys.num_vertices() : sys.num_faces();
    EXPECT_EQ(t.elements, 3 * per) << t.name;
    EXPECT_GT(t.seconds, 0.0) << t.name;
    sum += t.seconds;
  }
  EXPECT_LE(sum, wall);
  std::vector<std::string> names(sys.term_names().begin(), sys.term_names().end());
  EXPECT_EQ(names, (std::vector<std::string>{"membrane", "contact", "attachment", "fold_barrier"}));  // the term list's order
}

TEST(GarmentSystem, ValidateModelNamesTheProblem) {
  auto pull = PullTestScene("all_cloth");
  ASSERT_TRUE(pull.ok());
  auto model = BuildGarmentModel(*pull);
  ASSERT_TRUE(model.ok());
  GarmentModel m = *model;
  m.cloth.youngs_modulus_Pa = -1;
  EXPECT_NE(ValidateModel(m).message().find("materials.cloth: youngs_modulus_Pa must be > 0"), std::string::npos);
  m = *model;
  m.clamps[1].vertices.push_back(m.clamps[0].vertices[0]);
  EXPECT_NE(ValidateModel(m).message().find("is already clamped"), std::string::npos);
  m = *model;
  m.design[5] = 7;
  EXPECT_NE(ValidateModel(m).message().find("face 5"), std::string::npos);
}

// One triangle with the membrane, the fold barrier (q 0.05: active) and an attachment: the face sums
// its terms in the term list's sum places, membrane + fold barrier, then the attachment, bit for bit
// (the other order differs in the last bit here, so the check sees the order).
TEST(GarmentSystem, AFaceSumsItsTermsInTheTermListsSumPlaces) {
  GarmentModel m;
  m.faces.resize(1, 3);
  m.faces << 0, 1, 2;
  m.rest.resize(3, 3);
  m.rest << 0, 0, 0, 0.01, 0, 0, 0, 0.01, 0;
  m.design = {kCloth};
  m.attachments.faces = {0};
  m.attachments.anchors.resize(1, 3);
  m.attachments.anchors << 0.004, 0.003, 0.001;
  Positions x = m.rest;
  x.row(1) << 0.0123, 0.0011, 0.0007;
  x.row(2) << 0.0017, 0.00049, 0.0003;
  auto gradient = [&](bool membrane, bool fold, bool attach, Eigen::SparseMatrix<double>* H) {
    GarmentModel one = m;
    one.effects = Effects{};
    one.effects.membrane = membrane;
    one.effects.fold_barrier = fold;
    one.effects.attachments = attach;
    GarmentSystem sys(one, m.rest);
    Eigen::VectorXd g;
    *H = sys.hessian_pattern();
    EXPECT_TRUE(std::isfinite(sys.Evaluate(x, &g, H)));
    return g;
  };
  Eigen::SparseMatrix<double> H, Hm, Hf, Ha;
  const Eigen::VectorXd g = gradient(true, true, true, &H);
  const Eigen::VectorXd gm = gradient(true, false, false, &Hm), gf = gradient(false, true, false, &Hf),
                        ga = gradient(false, false, true, &Ha);
  ASSERT_GT(gf.norm(), 0) << "the fold barrier is active";
  ASSERT_NE((gm + ga) + gf, (gm + gf) + ga) << "the two orders agree here: the check could not see the order";
  for (int i = 0; i < g.size(); ++i) EXPECT_EQ(g[i], (gm[i] + gf[i]) + ga[i]) << "coordinate " << i;
  const Eigen::MatrixXd Hd = H, Hs = (Eigen::MatrixXd(Hm) + Eigen::MatrixXd(Hf)) + Eigen::MatrixXd(Ha);
  EXPECT_TRUE(Hd == Hs);
}

}  // namespace
}  // namespace kgd
