#include "core/sim/simulator.h"

#include <gtest/gtest.h>

#include <Eigen/CholmodSupport>
#include <limits>
#include <numeric>

#include "core/scene/scene.h"
#include "core/scene/simulate.h"
#include "core/sim/sparse_cholesky.h"
#include "core/scene/builtin_scenes.h"

namespace kgd {
namespace {

SceneSpec SmallSleeve() {
  SleeveOptions o;
  o.around = 16;
  o.sleeve_halflength_m = 0.08;
  return SleeveOnLimbScene(o);
}

// A fully reinforced sleeve whose rest shape is the limb's surface, as the design loop starts.
SceneSpec ReinforcedSleeveOnItsRestShape() {
  SleeveOptions o;
  o.around = 32;
  o.sleeve_halflength_m = 0.10;
  o.rest_on_body = true;
  o.reinforced = true;
  return SleeveOnLimbScene(o);
}

TEST(Simulator, NewtonConvergesAndEnergyDecreases) {
  SceneSpec s = SmallSleeve();
  auto model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok());
  GarmentSystem sys(std::move(model).value(), s.initial);
  Simulator sim(&sys);
  Positions x = s.initial;
  const double e0 = sys.Evaluate(x, nullptr, nullptr);
  SolverSettings tight;
  tight.grad_tol = 1e-7;
  const SolveReport r = sim.Solve(&x, tight);
  EXPECT_TRUE(r.converged()) << ToString(r.status) << " " << r.message;
  EXPECT_LT(r.energy_J, e0);
  EXPECT_LE(r.grad_norm_N, r.tolerance_N);
  EXPECT_LT(r.iterations, 60);
  // A warm re-solve from the solution needs no iteration.
  const SolveReport again = sim.Solve(&x, tight);
  EXPECT_TRUE(again.converged());
  EXPECT_EQ(again.iterations, 0);
}

TEST(Simulator, WarmResolveAfterADesignChangeReusesTheFactorization) {
  SceneSpec s = SmallSleeve();
  auto model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok());
  GarmentSystem sys(std::move(model).value(), s.initial);
  Simulator sim(&sys);
  Positions x = s.initial;
  SolverSettings tight;
  tight.grad_tol = 1e-8;
  tight.reuse_factorization = true;  // off by default (it does not pay on relaxed garments on bodies)
  ASSERT_TRUE(sim.Solve(&x, tight).converged());
  // Reinforce 1.5 % of the faces and re-solve from the previous equilibrium.
  std::vector<uint8_t> design = sys.model().design;
  for (size_t f = 0; f < design.size(); f += 67) design[f] = kReinforced;
  sys.SetDesign(design);
  Positions x_reuse = x, x_fresh = x;
  std::vector<IterationInfo> trace;
  SolverSettings traced = tight;
  traced.on_iteration = [&trace](const IterationInfo& i) { trace.push_back(i); };
  const SolveReport reuse = sim.Solve(&x_reuse, traced);
  EXPECT_TRUE(reuse.converged()) << reuse.message;
  EXPECT_GT(reuse.pcg_solves, 0);
  // The first step meets the new design with a fresh factorization; PCG serves the later steps.
  ASSERT_FALSE(trace.empty());
  EXPECT_FALSE(trace.front().used_pcg);
  EXPECT_GE(reuse.factorizations, 1);
  SolverSettings no_reuse = tight;
  no_reuse.reuse_factorization = false;
  Simulator fresh(&sys);
  const SolveReport direct = fresh.Solve(&x_fresh, no_reuse);
  EXPECT_TRUE(direct.converged());
  EXPECT_NEAR(reuse.energy_J, direct.energy_J, 1e-9 * std::abs(direct.energy_J));
}

// Where the energy is smooth (no relaxation, bilateral contact) the Hessian changes little between a
// re-solve's steps: one factorization at its first step, and PCG on it for every later step.
TEST(Simulator, OnASmoothSceneAReSolveFactorizesOnceAndReusesItWithinTheSolve) {
  const SceneSpec s = ReinforcedSleeveOnItsRestShape();
  auto model = BuildGarmentModel(s);
  ASSERT_TRUE(model.ok());
  model.value().effects.relaxation = Relaxation::kNone;
  model.value().effects.contact = ContactModel::kBilateral;
  GarmentSystem sys(std::move(model).value(), s.initial);
  SolverSettings reuse;
  reuse.grad_tol = 1e-7;
  reuse.reuse_factorization = true;
  SolverSettings direct = reuse;
  direct.reuse_factorization = false;
  Simulator sim(&sys), fresh(&sys);
  Positions x = s.initial;
  ASSERT_TRUE(sim.Solve(&x, reuse).converged());
  Positions y = x;
  ASSERT_TRUE(fresh.Solve(&y, direct).converged());
  std::vector<uint8_t> design = sys.model().design;
  int pcg_steps = 0;
  for (int step = 0; step < 4; ++step) {
    for (size_t f = step; f < design.size(); f += 67) design[f] = kCloth;
    sys.SetDesign(design);
    const SolveReport r = sim.Solve(&x, reuse);
    const SolveReport d = fresh.Solve(&y, direct);
    ASSERT_TRUE(r.converged()) << r.message;
    ASSERT_TRUE(d.converged()) << d.message;
    EXPECT_GE(r.iterations, 2);
    EXPECT_EQ(r.factorizations, 1) << "step " << step;
    EXPECT_EQ(r.pcg_solves, r.iterations - 1) << "step " << step;
    EXPECT_EQ(d.pcg_solves, 0);
    EXPECT_NEAR(r.energy_J, d.energy_J, 1e-8 * std::abs(d.energy_J)) << "step " << step;
    pcg_steps += r.pcg_solves;
  }
  EXPECT_GT(pcg_steps, 0);
}

// BESO-like warm re-solves on a fully reinforced sleeve: a cold solve, then 8 times 1.5 % of the faces
// turned to cloth and re-solved from the last equilibrium.
struct BesoLikeRun {
  SolveReport total;                  // all solves accumulated
  int warm_iterations = 0;            // Newton iterations of the re-solves
  std::vector<double> warm_energies;  // J, after each re-solve
};
BesoLikeRun BesoLikeResolves(const SolverSettings& settings) {
  const SceneSpec s = ReinforcedSleeveOnItsRestShape();
  auto model = BuildGarmentModel(s);
  EXPECT_TRUE(model.ok());
  GarmentSystem sys(std::move(model).value(), s.initial);
  Simulator sim(&sys);
  Positions x = s.initial;
  BesoLikeRun run;
  run.total = sim.Solve(&x, settings);
  EXPECT_TRUE(run.total.converged()) << run.total.message;
  std::vector<uint8_t> design = sys.model().design;
  int flipped = 0;
  for (int step = 0; step < 8; ++step) {
    for (size_t f = 0; f < design.size() && flipped < static_cast<int>((step + 1) * 0.015 * design.size()); f += 7)
      if (design[f] == kReinforced) {
        design[f] = kCloth;
        ++flipped;
      }
    sys.SetDesign(design);
    const SolveReport r = sim.Solve(&x, settings);
    EXPECT_TRUE(r.converged()) << r.message;
    EXPECT_LE(r.grad_norm_N, r.tolerance_N);
    run.warm_iterations += r.iterations;
    run.warm_energies.push_back(r.energy_J);
    AccumulateSolve(&run.total, r);
  }
  return run;
}

// Unilateral contact: Newton's model has no contact stiffness for a vertex off the body, so a step can
// press such vertices deep into it and the penalty cuts the step short. Projecting them back onto the
// surface in the line search saves Newton iterations on BESO-like warm re-solves and reaches the same
// equilibrium.
TEST(Simulator, ProjectingContactCrossingsSavesNewtonIterations) {
  auto run = [](bool project) {
    SolverSettings settings;
    settings.project_contact_crossings = project;
    const BesoLikeRun r = BesoLikeResolves(settings);
    std::printf("project %d: %d Newton iterations in all, %d warm, energy %.9g J\n", project, r.total.iterations,
                r.warm_iterations, r.total.energy_J);
    return r;
  };
  const BesoLikeRun on = run(true);
  const BesoLikeRun off = run(false);
  EXPECT_LT(on.warm_iterations, off.warm_iterations);
  EXPECT_NEAR(on.total.energy_J, off.total.energy_J, 1e-4 * off.total.energy_J);
}

// Local steps: where the residual of a warm re-solve has gathered in a small region, Newton steps on that
// region alone replace global factorizations. Same equilibria (the tolerance is on the whole residual),
// fewer global factorizations.
TEST(Simulator, LocalStepsReplaceGlobalFactorizationsAndReachTheSameEquilibria) {
  auto run = [](bool local) {
    SolverSettings settings;
    settings.grad_tol = 1e-6;
    settings.local_steps = local;
    const BesoLikeRun r = BesoLikeResolves(settings);
    std::printf("local %d: %d Newton iterations, %d factorizations, %d local steps\n", local, r.total.iterations,
                r.total.factorizations, r.total.local_steps);
    return r;
  };
  const BesoLikeRun with = run(true);
  const BesoLikeRun without = run(false);
  EXPECT_GT(with.total.local_steps, 0);
  EXPECT_EQ(without.total.local_steps, 0);
  EXPECT_LT(with.total.factorizations, without.total.factorizations);
  ASSERT_EQ(with.warm_energies.size(), without.warm_energies.size());
  for (size_t k = 0; k < with.warm_energies.size(); ++k)
    EXPECT_NEAR(with.warm_energies[k], without.warm_energies[k], 1e-6 * without.warm_energies[k]) << "step " << k;
}

// Entries of the Cholesky factor of a Hessian pattern under one fill-reducing ordering, as counted by
// CHOLMOD's analysis.
double FactorNonzeros(const Eigen::SparseMatrix<double>& pattern, int ordering) {
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Upper> llt;
  llt.cholmod().print = 0;
  llt.cholmod().nmethods = 1;
  llt.cholmod().method[0].ordering = ordering;
  llt.analyzePattern(pattern);
  return llt.cholmod().lnz;
}

// The factorization is most of a Newton iteration and its analysis runs once per mesh: it tries AMD
// and METIS and keeps the sparser factor. Nested dissection wins on a sleeve, minimum degree on the
// flat pull-test sample; the analysis must pick the winner on both. The sleeve is then factored in two
// domains (core/sim/sparse_cholesky.h), and the simulator reports that factorization's entries.
TEST(Simulator, TheAnalysisKeepsTheSparserOfTwoOrderings) {
  SleeveOptions o;
  o.around = 86;  // the benchmark's 7k-vertex sleeve
  o.rest_on_body = true;
  auto pull = PullTestScene("all_cloth");
  ASSERT_TRUE(pull.ok());
  bool amd_won = false, metis_won = false;
  for (const SceneSpec& s : {SleeveOnLimbScene(o), *pull}) {
    auto model = BuildGarmentModel(s);
    ASSERT_TRUE(model.ok()) << model.message();
    GarmentSystem sys(std::move(model).value(), s.initial);
    const double amd = FactorNonzeros(sys.hessian_pattern(), CHOLMOD_AMD);
    const double metis = FactorNonzeros(sys.hessian_pattern(), CHOLMOD_METIS);
    SparseCholesky whole, as_simulated;
    whole.Analyze(sys.hessian_pattern(), /*allow_split=*/false);
    as_simulated.Analyze(sys.hessian_pattern());
    Simulator sim(&sys);
    Positions x = s.initial;
    SolverSettings one_step;
    one_step.max_iterations = 1;  // the analysis comes with the first factorization
    const SolveReport r = sim.Solve(&x, one_step);
    std::printf("%s: factor entries AMD %.0f, METIS %.0f, whole %.0f, simulator %.0f (separator %zu)\n",
                s.name.c_str(), amd, metis, whole.factor_nonzeros(), r.factor_nonzeros,
                as_simulated.separator().size());
    EXPECT_EQ(whole.factor_nonzeros(), std::min(amd, metis)) << s.name;
    EXPECT_EQ(r.factor_nonzeros, as_simulated.factor_nonzeros()) << s.name;
    amd_won |= amd < metis;
    metis_won |= metis < amd;
  }
  EXPECT_TRUE(amd_won && metis_won) << "each ordering should win on one of the two garments";
}

TEST(Simulator, ReportsAnInvalidInitialState) {
  auto pull = PullTestScene("all_cloth");
  ASSERT_TRUE(pull.ok());
  pull->effects.relaxation = Relaxation::kNone;
  // Collapse one interior triangle onto a line: plain neo-Hookean energy is infinite there.
  const int f = 1000;
  pull->initial.row(pull->garment.faces(f, 2)) = pull->initial.row(pull->garment.faces(f, 0));
  auto model = BuildGarmentModel(*pull);
  ASSERT_FALSE(model.ok());  // a degenerate start is rejected up front with the face named
  EXPECT_NE(model.message().find("zero area"), std::string::npos) << model.message();
}

// A start the model accepts but where the energy is infinite (a triangle turned over, neither relaxation
// nor fold barrier on) ends both solvers with a typed invalid state that names the term and the face.
TEST(Simulator, AnInfiniteStartNamesTheTermAndTheFace) {
  auto pull = PullTestScene("all_cloth");
  ASSERT_TRUE(pull.ok());
  pull->effects.relaxation = Relaxation::kNone;
  pull->effects.fold_barrier = false;
  GarmentSystem sys(BuildGarmentModel(*pull).value(), pull->initial);
  const Faces& faces = pull->garment.faces;
  const int a = faces(1000, 0), b = faces(1000, 1), c = faces(1000, 2);
  Positions start = pull->initial;
  start.row(c) = start.row(a) + start.row(b) - start.row(c);  // c mirrored across the edge ab
  EXPECT_EQ(sys.DescribeNonFiniteEnergy(pull->initial), "");
  for (SolverMethod method : {SolverMethod::kNewton, SolverMethod::kLbfgs}) {
    Simulator sim(&sys);
    Positions x = start;
    SolverSettings settings;
    settings.method = method;
    const SolveReport r = sim.Solve(&x, settings);
    EXPECT_EQ(r.status, SolveStatus::kInvalidState);
    const std::string key = "membrane energy not finite at face ";
    const size_t at = r.message.find(key);
    ASSERT_NE(at, std::string::npos) << r.message;
    const int face = std::stoi(r.message.substr(at + key.size()));
    ASSERT_GE(face, 0);
    ASSERT_LT(face, faces.rows());
    EXPECT_TRUE(faces(face, 0) == c || faces(face, 1) == c || faces(face, 2) == c)
        << "face " << face << " does not hold the moved vertex " << c << ": " << r.message;
    EXPECT_NE(r.message.find("the relaxation is off"), std::string::npos) << r.message;
  }
  start(c, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(sys.DescribeNonFiniteEnergy(start), "vertex " + std::to_string(c) + " has a non-finite coordinate");
}

// The pull-test Line sits in uniaxial tension, on the gradient jump of the authors' relaxation: the
// residual cannot fall below tolerance there. The solve ends early with a typed stall, at the same
// equilibrium as the smooth (exact) relaxation, instead of running to its iteration limit.
TEST(Simulator, AStallOnTheAuthorsGradientJumpEndsTheSolveEarly) {
  auto exact = PullTestScene("line");
  ASSERT_TRUE(exact.ok());
  exact->solver.grad_tol = 1e-7;  // as the example scene: far below the size of the jump
  SceneSpec authors = *exact;
  authors.effects.relaxation = Relaxation::kAuthors;
  auto re = SimulateScene(*exact);
  auto ra = SimulateScene(authors);
  ASSERT_TRUE(re.ok() && ra.ok());
  EXPECT_TRUE(re->solve.converged()) << re->solve.message;
  EXPECT_EQ(ra->solve.status, SolveStatus::kStalled) << ToString(ra->solve.status) << ": " << ra->solve.message;
  EXPECT_LT(ra->solve.iterations, 150);  // the default limit is 200
  EXPECT_GT(ra->solve.grad_norm_N, ra->solve.tolerance_N);
  EXPECT_NE(ra->solve.message.find("gradient jump"), std::string::npos) << ra->solve.message;
  const double fe = re->clamp_forces[1].force_N.norm(), fa = ra->clamp_forces[1].force_N.norm();
  EXPECT_NEAR(fa / fe, 1.0, 1e-3) << "authors " << fa << " N, exact " << fe << " N";
}

// The progress report counts, per term, the elements a step switched on or off: here checked against
// the energies per element at the iterates themselves (each re-made by a solve stopped after k steps).
TEST(Simulator, TheProgressReportCountsTheElementsEachStepSwitched) {
  const SceneSpec s = SmallSleeve();
  auto build = [&s] {
    auto model = BuildGarmentModel(s);
    EXPECT_TRUE(model.ok());
    return std::make_unique<GarmentSystem>(std::move(model).value(), s.initial);
  };
  SolverSettings settings;
  settings.grad_tol = 1e-7;
  std::vector<IterationInfo> trace;
  SolverSettings traced = settings;
  traced.on_iteration = [&trace](const IterationInfo& i) { trace.push_back(i); };
  traced.diagnose_steps = true;
  auto sys = build();
  Positions x = s.initial;
  ASSERT_TRUE(Simulator(sys.get()).Solve(&x, traced).converged());
  ASSERT_GE(trace.size(), 3u);
  const int membrane = sys->term_index("membrane"), contact = sys->term_index("contact");
  ASSERT_GE(membrane, 0);
  ASSERT_GE(contact, 0);
  int total = 0;
  EvaluationRecord before;
  sys->Evaluate(s.initial, nullptr, nullptr, nullptr, &before);
  for (size_t k = 1; k <= trace.size(); ++k) {
    auto fresh = build();
    Positions xk = s.initial;
    SolverSettings stop = settings;
    stop.max_iterations = static_cast<int>(k);
    Simulator(fresh.get()).Solve(&xk, stop);
    EvaluationRecord after;
    fresh->Evaluate(xk, nullptr, nullptr, nullptr, &after);
    const IterationInfo& info = trace[k - 1];
    ASSERT_EQ(info.diagnostics.switched_elements.size(), after.energy_J.size());
    ASSERT_NE(info.diagnostics.term_names, nullptr);
    EXPECT_STREQ((*info.diagnostics.term_names)[membrane], "membrane");
    for (size_t t = 0; t < after.energy_J.size(); ++t) {
      int expected = 0;
      for (size_t e = 0; e < after.energy_J[t].size(); ++e) expected += (before.energy_J[t][e] > 0) != (after.energy_J[t][e] > 0);
      EXPECT_EQ(info.diagnostics.switched_elements[t], expected) << "step " << k << ", term " << (*info.diagnostics.term_names)[t];
      total += info.diagnostics.switched_elements[t];
    }
    const int switched_here = std::accumulate(info.diagnostics.switched_elements.begin(), info.diagnostics.switched_elements.end(), 0);
    EXPECT_EQ(DescribeIteration(info).find("switched") != std::string::npos, switched_here > 0) << DescribeIteration(info);
    before = std::move(after);
  }
  // The sleeve starts off the limb and slack in places: its first steps switch faces and vertices.
  EXPECT_GT(total, 0);
  // Every accepted step lowered the energy and its model predicted a decrease; the last, at the
  // solution, where the energy is locally quadratic, does what its model predicts.
  for (const IterationInfo& i : trace) EXPECT_TRUE(std::isfinite(i.diagnostics.model_ratio) && i.diagnostics.model_ratio > 0) << DescribeIteration(i);
  EXPECT_NEAR(trace.back().diagnostics.model_ratio, 1.0, 0.1) << DescribeIteration(trace.back());
  EXPECT_GT(trace.front().diagnostics.switched_elements[membrane] + trace.front().diagnostics.switched_elements[contact], 0);
}

TEST(Simulator, IterationLimitIsReportedWithTheResidual) {
  auto pull = PullTestScene("x");
  ASSERT_TRUE(pull.ok());
  pull->solver.max_iterations = 1;
  auto r = SimulateScene(*pull);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->solve.status, SolveStatus::kIterationLimit);
  EXPECT_GT(r->solve.grad_norm_N, r->solve.tolerance_N);
}

}  // namespace
}  // namespace kgd
