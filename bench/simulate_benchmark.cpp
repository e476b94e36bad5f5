// Simulator benchmarks on a ~7,000-vertex sleeve on a flexing limb (contact + attachments + relaxation):
// cold solve, warm re-solve after flipping 1.5 % of the triangles (what the BESO loop does), and L-BFGS.
// Run: build/bench/simulate_benchmark (or `make bench`); figures go to docs/PERFORMANCE.md.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <utility>

#include "core/beso/beso.h"
#include "core/scene/scene.h"
#include "core/scene/simulate.h"
#include "core/sim/sparse_cholesky.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/paper_scenes.h"

namespace kgd {
namespace {

// Paper-like: the garment's rest shape is the limb surface in the rest pose; flexion strains it.
SceneSpec Sleeve(bool reinforced) {
  SleeveOptions o;
  o.around = 86;  // 7,052 garment vertices, 13,932 triangles
  o.reinforced = reinforced;
  o.rest_on_body = true;
  return SleeveOnLimbScene(o);
}

double GradTol(benchmark::State& state, int arg) { return std::pow(10.0, -static_cast<double>(state.range(arg))); }

void Report(benchmark::State& state, const SolveReport& r) {
  state.counters["iterations"] = r.iterations;
  state.counters["factorizations"] = r.factorizations;
  state.counters["pcg_solves"] = r.pcg_solves;
  state.counters["pcg_iterations"] = r.pcg_iterations;
  state.counters["assembly_ms"] = 1e3 * r.assembly_s;
  state.counters["factor_ms"] = 1e3 * r.factorization_s;
  state.counters["solve_ms"] = 1e3 * r.solve_s;
  state.counters["linesearch_ms"] = 1e3 * r.line_search_s;
  state.counters["converged"] = r.converged();
  state.counters["factor_nnz"] = r.factor_nonzeros;
}

// Per-solve means over `steps` solves accumulated in `total` (AccumulateSolve).
void ReportMeans(benchmark::State& state, const SolveReport& total, int steps) {
  state.counters["iterations"] = double(total.iterations) / steps;
  state.counters["factorizations"] = double(total.factorizations) / steps;
  state.counters["local_steps"] = double(total.local_steps) / steps;
  state.counters["assembly_ms"] = 1e3 * total.assembly_s / steps;
  state.counters["factor_ms"] = 1e3 * total.factorization_s / steps;
  state.counters["solve_ms"] = 1e3 * total.solve_s / steps;
  state.counters["linesearch_ms"] = 1e3 * total.line_search_s / steps;
}

// Cold: a fresh simulator (symbolic analysis included) from the body-surface initial state.
void BM_NewtonCold(benchmark::State& state) {
  const SceneSpec s = Sleeve(state.range(0));
  auto model = BuildGarmentModel(s);
  GarmentSystem sys(std::move(model).value(), s.initial);
  SolverSettings settings;
  settings.grad_tol = GradTol(state, 1);
  settings.project_contact_crossings = state.range(2) != 0;
  SolveReport r;
  for (auto _ : state) {
    Simulator sim(&sys);
    Positions x = s.initial;
    r = sim.Solve(&x, settings);
  }
  Report(state, r);
  state.counters["energy_J"] = r.energy_J;
  state.counters["vertices"] = sys.num_vertices();
}
BENCHMARK(BM_NewtonCold)
    ->ArgsProduct({{0, 1}, {4, 5, 6, 7}, {1, 0}})
    ->ArgNames({"reinforced", "tol_exp", "project"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// The warm benchmarks' design steps: each turns another 1.5 % of the triangles, in a fixed random
// order, to the other material (from fully reinforced: to cloth, and back after the whole garment).
struct DesignSteps {
  explicit DesignSteps(std::vector<uint8_t> start) : design(std::move(start)), order(design.size()) {
    for (size_t f = 0; f < order.size(); ++f) order[f] = static_cast<int>(f);
    std::mt19937 rng(1);
    std::shuffle(order.begin(), order.end(), rng);
  }
  void Next(GarmentSystem* sys) {
    for (size_t k = 0; k < design.size() * 15 / 1000; ++k) design[order[(next++) % order.size()]] ^= 1;
    sys->SetDesign(design);
  }
  std::vector<uint8_t> design;
  std::vector<int> order;
  size_t next = 0;
};

// Warm: starting fully reinforced, each timed step turns another 1.5 % of the triangles to cloth and
// re-solves from the previous equilibrium with the same simulator; per-solve means as counters.
void WarmResolveSteps(benchmark::State& state, GarmentModel model, const SceneSpec& s, const SolverSettings& settings) {
  GarmentSystem sys(std::move(model), s.initial);
  Simulator sim(&sys);
  double energy = 0;
  Positions x = s.initial;
  sim.Solve(&x, settings);
  DesignSteps steps_of_design(s.design);
  SolveReport total;
  int steps = 0, failures = 0;
  for (auto _ : state) {
    state.PauseTiming();
    steps_of_design.Next(&sys);
    state.ResumeTiming();
    const SolveReport r = sim.Solve(&x, settings);
    failures += !r.converged();
    energy = r.energy_J;
    ++steps;
    AccumulateSolve(&total, r);
  }
  ReportMeans(state, total, steps);
  state.counters["pcg_solves"] = double(total.pcg_solves) / steps;
  state.counters["pcg_iterations"] = double(total.pcg_iterations) / steps;
  state.counters["failures"] = failures;
  state.counters["last_energy_J"] = energy;
  state.counters["factor_nnz"] = total.factor_nonzeros;
}

// The warm re-solve on the sleeve (method: see BENCHMARK below).
void BM_WarmResolve(benchmark::State& state) {
  const SceneSpec s = Sleeve(true);
  SolverSettings settings;
  settings.method = state.range(0) == 2 ? SolverMethod::kLbfgs : SolverMethod::kNewton;
  settings.reuse_factorization = state.range(0) == 0;
  settings.project_contact_crossings = state.range(0) != 3;
  settings.local_steps = state.range(0) != 4;
  settings.grad_tol = GradTol(state, 1);
  WarmResolveSteps(state, BuildGarmentModel(s).value(), s, settings);
}
// method: 0 Newton reusing factorizations, 1 Newton factorizing every step (the default), 2 L-BFGS,
// 3 as 1 without the line search's contact projection (SolverSettings::project_contact_crossings),
// 4 as 1 without local steps (SolverSettings::local_steps).
BENCHMARK(BM_WarmResolve)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {4, 6}})
    ->ArgNames({"method", "tol_exp"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(20);

// Warm, with the faces the design loop would flip: from the fully reinforced equilibrium, each step ranks
// the faces by filtered, time-averaged sensitivity at the last equilibrium and moves the design 1.5 % of
// the garment's area towards the paper's budget of 15 % (core/beso/beso.h), then re-solves from the
// default damping, as core/beso/design_loop.cpp does; 126 steps reach the budget. BM_WarmResolve flips
// random faces all over the sleeve; BESO flips the least loaded ones along the design's boundary, and in
// its first steps faces that carry almost nothing (still_steps: re-solves already at the tolerance).
// moving_ms: the mean re-solve over the other steps. The two methods' chains part slightly (each ranks
// on its own equilibria).
void BM_WarmResolveBeso(benchmark::State& state) {
  const SceneSpec s = Sleeve(true);
  GarmentSystem sys(BuildGarmentModel(s).value(), s.initial);
  Simulator sim(&sys);
  SolverSettings settings;
  settings.method = state.range(0) == 2 ? SolverMethod::kLbfgs : SolverMethod::kNewton;
  Positions x = s.initial;
  sim.Solve(&x, settings);
  const BesoSettings beso;
  const int nf = static_cast<int>(s.design.size()), nv = static_cast<int>(s.initial.rows());
  Eigen::VectorXd area(nf);
  for (int f = 0; f < nf; ++f) area[f] = sys.rest_areas_m2()[f];
  const double total_area = area.sum();
  double target = total_area;
  std::vector<uint8_t> design = s.design;
  Eigen::VectorXd previous, density;
  SolveReport total;
  int steps = 0, failures = 0, still = 0;
  double moving_s = 0;
  for (auto _ : state) {
    state.PauseTiming();
    sys.FaceDensities(x, &density, nullptr);
    const Eigen::VectorXd sensitivity = Sensitivities(density, design, s.reinforced.youngs_modulus_Pa,
                                                      s.cloth.youngs_modulus_Pa, beso.d_min, beso.penalty);
    previous = AverageSensitivities(FilterSensitivities(sensitivity, s.garment.faces, nv, area), previous);
    target = NextTargetArea(target, beso.budget * total_area, beso.evolutionary_ratio);
    design = UpdateDesign(previous, area, design, target, beso.admission_ratio * total_area);
    sys.SetDesign(design);
    sim.ResetFactorization();  // as the design loop: each iteration from the default damping
    state.ResumeTiming();
    const auto t = std::chrono::steady_clock::now();
    const SolveReport r = sim.Solve(&x, settings);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    failures += !r.converged();
    still += r.iterations == 0;
    moving_s += r.iterations == 0 ? 0.0 : seconds;
    ++steps;
    AccumulateSolve(&total, r);
  }
  ReportMeans(state, total, steps);
  state.counters["still_steps"] = still;
  state.counters["moving_ms"] = steps > still ? 1e3 * moving_s / (steps - still) : 0.0;
  state.counters["failures"] = failures;
  state.counters["target_share"] = target / total_area;  // of the garment area, reinforced
}
// method: 1 Newton (the default), 2 L-BFGS, as in BM_WarmResolve.
BENCHMARK(BM_WarmResolveBeso)
    ->Arg(1)
    ->Arg(2)
    ->ArgName("method")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(126);

// What the warm re-solve's first Newton iterations cost and leave: the same 20 design steps as
// BM_WarmResolve (default settings), but each timed solve stops after `newton_its` iterations (on a
// second simulator, from the last equilibrium); the untimed chain then solves to the tolerance, so every
// step starts where the BESO loop would. resid_over_tol: the residual left, in units of the tolerance.
// This is the floor under BM_WarmResolve's time: what one or two iterations cost is more than what a
// re-solve may take, unless they alone reach the tolerance (docs/PERFORMANCE.md).
// The timed loop of BM_WarmFirstIterations and BM_SceneNewtonStep: from the equilibrium of `s`'s design
// (solved first), each step flips DesignSteps' next 1.5 % of the faces and times a solve of at most
// `newton_its` iterations from the last equilibrium; the untimed chain then solves to the tolerance.
void TruncatedWarmSolves(benchmark::State& state, GarmentModel model, const SceneSpec& s, const SolverSettings& settings,
                         int newton_its) {
  GarmentSystem sys(std::move(model), s.initial);
  Simulator chain(&sys), truncated(&sys);
  SolverSettings first = settings;
  first.max_iterations = newton_its;
  Positions x = s.initial;
  chain.Solve(&x, settings);
  {
    Positions y = x;
    truncated.Solve(&y, settings);  // its analysis and warm-start damping, as the chain's
  }
  DesignSteps steps_of_design(s.design);
  SolveReport total;
  double resid_over_tol = 0;
  int steps = 0;
  for (auto _ : state) {
    state.PauseTiming();
    steps_of_design.Next(&sys);
    Positions y = x;
    state.ResumeTiming();
    const SolveReport r = truncated.Solve(&y, first);
    state.PauseTiming();
    resid_over_tol += r.grad_norm_N / r.tolerance_N;
    AccumulateSolve(&total, r);
    ++steps;
    chain.Solve(&x, settings);
    state.ResumeTiming();
  }
  state.counters["resid_over_tol"] = resid_over_tol / steps;
  state.counters["vertices"] = sys.num_vertices();
  ReportMeans(state, total, steps);
}

void BM_WarmFirstIterations(benchmark::State& state) {
  const SceneSpec s = Sleeve(true);
  TruncatedWarmSolves(state, BuildGarmentModel(s).value(), s, SolverSettings{}, static_cast<int>(state.range(0)));
}
BENCHMARK(BM_WarmFirstIterations)
    ->DenseRange(1, 3)
    ->ArgName("newton_its")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(20);

// One full warm Newton step (assembly, factorization, solve, line search) on a built-in scene's garment
// (the scene cache), as BM_WarmFirstIterations/newton_its:1 on the sleeve: from the fully reinforced
// equilibrium, 20 steps of 1.5 % random flips, each timed solve stopped after one iteration, with the
// scene's own solver settings. What a design iteration of that scene is measured against
// (bench/iteration_cost.py). scene: 0 arm_flexion, 1 knee_flexion, 2 slouch.
void BM_SceneNewtonStep(benchmark::State& state) {
  static const char* const kScenes[] = {"arm_flexion", "knee_flexion", "slouch"};
  Result<SceneSpec> s = BuiltinScene(kScenes[state.range(0)]);
  if (!s.ok()) {
    state.SkipWithError(s.message().c_str());
    return;
  }
  Result<GarmentModel> model = BuildGarmentModel(*s);
  if (!model.ok()) {
    state.SkipWithError(model.message().c_str());
    return;
  }
  TruncatedWarmSolves(state, std::move(model).value(), *s, s->solver, 1);
}
BENCHMARK(BM_SceneNewtonStep)
    ->DenseRange(0, 2)
    ->ArgName("scene")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(20);

// The same sleeve with a smooth energy: no tension-field relaxation (compression resisted) and
// bilateral contact, so no element changes regime under a step. Not the product's model (the sleeve's
// equilibrium energy is 3x the relaxed one): what the warm re-solve and the Newton/L-BFGS ratio would be
// without the relaxation's and the unilateral penalty's Hessian jumps (docs/PERFORMANCE.md).
GarmentModel SmoothSleeveModel(const SceneSpec& s) {
  GarmentModel model = BuildGarmentModel(s).value();
  model.effects.relaxation = Relaxation::kNone;
  model.effects.contact = ContactModel::kBilateral;
  return model;
}

// Cold on the smooth model: method 1 Newton, 2 L-BFGS.
void BM_SmoothCold(benchmark::State& state) {
  const SceneSpec s = Sleeve(true);
  GarmentSystem sys(SmoothSleeveModel(s), s.initial);
  SolverSettings settings;
  settings.method = state.range(0) == 2 ? SolverMethod::kLbfgs : SolverMethod::kNewton;
  settings.grad_tol = GradTol(state, 1);
  SolveReport r;
  for (auto _ : state) {
    Simulator sim(&sys);
    Positions x = s.initial;
    r = sim.Solve(&x, settings);
  }
  Report(state, r);
  state.counters["energy_J"] = r.energy_J;
}
BENCHMARK(BM_SmoothCold)
    ->ArgsProduct({{1, 2}, {4, 6}})
    ->ArgNames({"method", "tol_exp"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// BM_WarmResolve's 20 random design steps on the smooth model. method: 0 Newton with PCG on the
// solve's first factorization (SolverSettings::reuse_factorization), 1 Newton (the default), 2 L-BFGS.
void BM_WarmResolveSmooth(benchmark::State& state) {
  const SceneSpec s = Sleeve(true);
  SolverSettings settings;
  settings.method = state.range(0) == 2 ? SolverMethod::kLbfgs : SolverMethod::kNewton;
  settings.reuse_factorization = state.range(0) == 0;
  WarmResolveSteps(state, SmoothSleeveModel(s), s, settings);
}
BENCHMARK(BM_WarmResolveSmooth)
    ->DenseRange(0, 2)
    ->ArgName("method")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(20);

// The paper's method to the same tolerance, cold, on the cloth or the fully reinforced sleeve (the
// design loop's first solve).
void BM_LbfgsCold(benchmark::State& state) {
  const SceneSpec s = Sleeve(state.range(0) == 1);
  auto model = BuildGarmentModel(s);
  GarmentSystem sys(std::move(model).value(), s.initial);
  SolverSettings settings;
  settings.method = SolverMethod::kLbfgs;
  settings.grad_tol = GradTol(state, 1);
  settings.max_iterations = 20000;
  SolveReport r;
  for (auto _ : state) {
    Simulator sim(&sys);
    Positions x = s.initial;
    r = sim.Solve(&x, settings);
  }
  state.counters["iterations"] = r.iterations;
  state.counters["evaluations"] = r.energy_evaluations;
  state.counters["converged"] = r.converged();
  state.counters["energy_J"] = r.energy_J;
}
BENCHMARK(BM_LbfgsCold)
    ->ArgsProduct({{0, 1}, {4, 5, 6, 7}})
    ->ArgNames({"reinforced", "tol_exp"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// The reinforced sleeve's equilibrium from `start`, solved with the default settings.
Positions SolvedSleeve(GarmentSystem& sys, const Positions& start, benchmark::State& state) {
  Positions x = start;
  Simulator sim(&sys);
  const SolveReport r = sim.Solve(&x, SolverSettings{});
  if (!r.converged()) state.SkipWithError(r.message.c_str());
  return x;
}

// One evaluation of the sleeve's energy at its equilibrium, the unit every Newton step and line-search
// trial pays: what 0 energy only, 1 with gradient, 2 with gradient and Hessian, 3 the body field's
// value alone at every garment vertex (GarmentSystem::VertexPhi).
void BM_Evaluate(benchmark::State& state) {
  const SceneSpec s = Sleeve(true);
  GarmentSystem sys(BuildGarmentModel(s).value(), s.initial);
  const Positions x = SolvedSleeve(sys, s.initial, state);
  Eigen::SparseMatrix<double> H = sys.hessian_pattern();
  Eigen::VectorXd g;
  const int what = static_cast<int>(state.range(0));
  for (auto _ : state) {
    if (what == 3) {
      benchmark::DoNotOptimize(sys.VertexPhi(x, nullptr));
    } else {
      benchmark::DoNotOptimize(sys.Evaluate(x, what >= 1 ? &g : nullptr, what == 2 ? &H : nullptr));
    }
  }
  state.counters["vertices"] = sys.num_vertices();
}
BENCHMARK(BM_Evaluate)->DenseRange(0, 3)->ArgName("what")->Unit(benchmark::kMillisecond);

// One factorization of the sleeve's Hessian at its equilibrium (the damping of a warm re-solve's first
// step, 0.2 N/m) and one solve with it: split 0 the whole factorization, 1 two domains on two threads
// (core/sim/sparse_cholesky.h; on one thread with OMP_NUM_THREADS=1).
void BM_Factorize(benchmark::State& state) {
  const SceneSpec s = Sleeve(true);
  GarmentSystem sys(BuildGarmentModel(s).value(), s.initial);
  const Positions x = SolvedSleeve(sys, s.initial, state);
  Eigen::SparseMatrix<double> H = sys.hessian_pattern();
  Eigen::VectorXd g;
  sys.Evaluate(x, &g, &H);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(H.rows());
  SparseCholesky cholesky;
  cholesky.Analyze(H, state.range(0) == 1);
  double solve_s = 0;
  for (auto _ : state) {
    if (!cholesky.Factorize(H, 0.2)) state.SkipWithError("not positive definite");
    const auto t = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(cholesky.Solve(b));
    solve_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  }
  state.counters["separator"] = static_cast<double>(cholesky.separator().size());
  state.counters["factor_nnz"] = cholesky.factor_nonzeros();
  state.counters["solve_ms"] = 1e3 * solve_s / static_cast<double>(state.iterations());
}
BENCHMARK(BM_Factorize)->Arg(0)->Arg(1)->ArgName("split")->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace kgd

BENCHMARK_MAIN();
