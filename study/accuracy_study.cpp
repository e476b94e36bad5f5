#include "study/accuracy_study.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>

#include "core/beso/design_compare.h"
#include "core/beso/design_loop.h"
#include "core/beso/quality.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/paper_scenes.h"
#include "core/scene/simulate.h"

namespace kgd::study {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
constexpr double kNaN = kStudyNaN;

std::string Fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// A design run with what the study needs of it beyond its row.
struct Run : StudyRun {
  TriMesh garment;
  // The run's own scene when it is not the study's (another garment or body resolution): its tight
  // ratio is against its own fully reinforced garment.
  std::shared_ptr<const SceneSpec> own_scene;
  std::vector<uint8_t> final_design;
  std::vector<std::vector<uint8_t>> designs;  // per iteration (kept for the reference run)
  std::vector<Positions> positions;           // per iteration (reference run)
};

}  // namespace

void MoveStartByANanometre(SceneSpec* scene) {
  std::mt19937_64 random(1);
  std::uniform_real_distribution<double> nm(-1e-9, 1e-9);
  for (Eigen::Index i = 0; i < scene->initial.size(); ++i) scene->initial.data()[i] += nm(random);
}

// kTightGradTol; NaN when that solve does not reach equilibrium.
double TightDensity(SceneSpec scene, const std::vector<uint8_t>& design) {
  scene.design = design;
  scene.solver.method = SolverMethod::kNewton;
  scene.solver.grad_tol = kTightGradTol;
  scene.solver.max_iterations = 2000;
  scene.solver.accept_iteration_limit = false;
  Result<SimulationResult> r = SimulateScene(scene);
  if (!r.ok() || !r->solve.at_equilibrium()) return kNaN;
  return r->reinforced_density_J_per_m2;
}

namespace {

Run DesignRun(const std::string& knob, const std::string& value, const SceneSpec& scene, const BesoSettings& settings,
              bool keep_history) {
  Run run;
  run.knob = knob;
  run.value = value;
  run.garment = scene.garment;
  run.vertices = static_cast<int>(scene.garment.vertices.rows());
  run.faces = static_cast<int>(scene.garment.faces.rows());
  std::fprintf(stderr, "study: %s = %s (%d vertices) ...\n", knob.c_str(), value.c_str(), run.vertices);
  const auto t0 = Clock::now();
  Result<std::vector<BesoIteration>> h = RunBeso(scene, settings, [&](const BesoIteration& it) {
    if (keep_history) {
      run.designs.push_back(it.design);
      run.positions.push_back(it.positions);
    }
    return true;
  });
  run.loop_s = Since(t0);
  if (!h.ok()) {
    run.end = h.message();
    std::fprintf(stderr, "study:   failed: %s\n", run.end.c_str());
    return run;
  }
  const std::vector<BesoIteration>& its = *h;
  run.iterations = static_cast<int>(its.size()) - 1;
  const Eigen::VectorXd area = FaceAreas(scene.garment.vertices, scene.garment.faces);
  run.end = DescribeBesoEnd(BesoEndOf(its, settings, area.sum()), its, settings);
  run.iteration0_s = its[0].total_s;
  double sum = 0;
  for (size_t k = 1; k < its.size(); ++k) sum += its[k].total_s;
  run.per_iteration_s = its.size() > 1 ? sum / (its.size() - 1) : kNaN;
  run.ratio_run = its.back().density_ratio;
  run.final_design = its.back().design;
  run.designed = !run.final_design.empty();
  std::fprintf(stderr, "study:   %d iterations, %.4f s each, ratio %.4f\n", run.iterations, run.per_iteration_s, run.ratio_run);
  return run;
}

double JaccardAgainst(const Run& run, const std::vector<uint8_t>& design, const Run& reference, const std::vector<uint8_t>& reference_design) {
  if (design.empty() || reference_design.empty()) return kNaN;
  const Eigen::VectorXd area = FaceAreas(reference.garment.vertices, reference.garment.faces);
  if (run.faces == reference.faces) return DesignJaccard(design, reference_design, area);
  return DesignJaccard(TransferDesign(run.garment, design, reference.garment), reference_design, area);
}

EnergyTrace TraceSolve(const std::string& name, const SceneSpec& scene, const std::vector<uint8_t>& design, const Positions& start,
                       SolverSettings settings) {
  EnergyTrace t;
  t.name = name;
  GarmentModel model;
  {
    SceneSpec s = scene;
    s.design = design;
    Result<GarmentModel> m = BuildGarmentModel(s);
    if (!m.ok()) {
      t.status = m.message();
      return t;
    }
    model = std::move(m).value();
  }
  GarmentSystem sys(std::move(model), scene.initial);
  Simulator sim(&sys);
  Positions x = start;
  sys.ApplyClamps(&x);
  t.start_energy_J = sys.Evaluate(x, nullptr, nullptr);
  const auto t0 = Clock::now();
  settings.on_iteration = [&](const IterationInfo& i) { t.time_energy.emplace_back(Since(t0), i.energy_J); };
  const SolveReport r = sim.Solve(&x, settings);
  t.status = ToString(r.status);
  std::fprintf(stderr, "study:   trace %s: %d iterations, %.2f s, %s, E = %.10f J\n", name.c_str(), r.iterations, r.seconds,
               t.status.c_str(), r.energy_J);
  return t;
}

// The scene's paper motion and the default body; no motion for a scene that is not a paper scene. The
// resolutions and the frames evaluated re-make the scene from it.
struct PaperSource {
  std::optional<PaperMotion> motion;
  const ParametricBody* body = nullptr;
};

PaperSource PaperSourceOf(const std::string& scene) {
  const std::vector<PaperMotion> motions = PaperMotions();
  const auto m = std::find_if(motions.begin(), motions.end(), [&](const PaperMotion& p) { return p.name == scene; });
  const Result<const ParametricBody*> body = DefaultParametricBody();
  if (m == motions.end() || !body.ok()) return {};
  return {*m, *body};
}

// 1. Newton's tolerance per BESO iteration; the tightest keeps its history (the reference run).
std::vector<Run> ToleranceSweep(const SceneSpec& base, const BesoSettings& settings, bool quick) {
  const std::vector<double> tolerances =
      quick ? std::vector<double>{1e-3, 1e-4, 1e-6} : std::vector<double>{1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8};
  std::vector<Run> sweep;
  for (double tol : tolerances) {
    SceneSpec s = base;
    s.solver.grad_tol = tol;
    // The reference run solves every iteration at its tolerance; the others re-solve as users' jobs do.
    BesoSettings run = settings;
    if (tol == tolerances.back()) run.resolve_tolerance_factor = 1;
    sweep.push_back(DesignRun("grad_tol", Fmt("%.0e", tol), s, run, tol == tolerances.back()));
  }
  return sweep;
}

// 2. Variants at the default tolerance, and (not quick) `precise` again from a start moved by at most
// 1 nm: as accurate as `precise`, with another round-off path. How far the two designs agree bounds
// what any tolerance can reach against it.
void AddVariants(const SceneSpec& base, const BesoSettings& settings, bool quick, std::vector<Run>* runs) {
  SceneSpec s = base;
  s.effects.relaxation = Relaxation::kAuthors;
  runs->push_back(DesignRun("relaxation", "authors'", s, settings, false));
  s = base;
  s.effects.fold_barrier = false;
  runs->push_back(DesignRun("fold_barrier", "off", s, settings, false));
  if (quick) return;
  s = base;
  s.solver.grad_tol = PresetOf(Quality::kPrecise).grad_tol;
  MoveStartByANanometre(&s);
  runs->push_back(DesignRun(kRepeatKnob, Fmt("%.0e", s.solver.grad_tol) + ", start moved <= 1 nm", s, settings, false));
}

// 3. Mesh resolution: garment subdivisions (the scene's own is the paper's size), and the body's
// surface mesh at the scene's subdivisions (the garment, cut from it, refines with it).
void AddResolutions(const PaperSource& paper, const BesoSettings& settings, std::vector<Run>* runs) {
  auto add = [&](const std::string& knob, const std::string& value, const ParametricBody& b, const PaperMotion& motion) {
    Result<SceneSpec> s = PaperScene(b, motion);
    if (!s.ok()) {
      std::fprintf(stderr, "study: %s = %s: %s\n", knob.c_str(), value.c_str(), s.message().c_str());
      return;
    }
    runs->push_back(DesignRun(knob, value, *s, settings, false));
    runs->back().own_scene = std::make_shared<const SceneSpec>(std::move(s).value());
  };
  for (int sub = 0; sub <= 2; ++sub) {
    if (sub == paper.motion->subdivisions) continue;
    PaperMotion motion = *paper.motion;
    motion.subdivisions = sub;
    add("subdivisions", std::to_string(sub), *paper.body, motion);
  }
  for (double r : {0.010, 0.008}) {
    BodyMeasurements measurements;
    measurements.resolution_m = r;
    Result<ParametricBody> finer = BuildParametricBody(measurements);
    if (finer.ok()) add("body resolution", Fmt("%.0f mm", 1e3 * r), *finer, *paper.motion);
  }
}

// 4. Method, over the first k iterations (L-BFGS to a whole design takes hours).
std::vector<Run> MethodRuns(const SceneSpec& base, const BesoSettings& settings, int k) {
  const double standard_tol = base.solver.grad_tol;
  BesoSettings short_run = settings;
  short_run.max_iterations = k;
  SceneSpec s = base;
  std::vector<Run> methods;
  methods.push_back(DesignRun("method", "newton " + Fmt("%.0e", standard_tol), s, short_run, true));
  s.solver.method = SolverMethod::kLbfgs;
  methods.push_back(DesignRun("method", "lbfgs " + Fmt("%.0e", standard_tol), s, short_run, true));
  s.solver.max_iterations = 800;
  s.solver.accept_iteration_limit = true;
  methods.push_back(DesignRun("method", "lbfgs 800 iterations", s, short_run, true));
  return methods;
}

// Every run judged alike: its final design re-solved tight, its agreement with the reference run and
// with `precise`; the methods' designs of iteration k against the reference run's.
void Judge(const SceneSpec& base, const Run& reference, int k, std::vector<Run>* runs, std::vector<Run>* methods) {
  const double full_density_tight = TightDensity(base, std::vector<uint8_t>(base.garment.faces.rows(), kReinforced));
  for (Run& r : *runs) {
    if (r.final_design.empty()) continue;
    if (!r.own_scene) {
      r.ratio_tight = TightDensity(base, r.final_design) / full_density_tight;
    } else {
      const SceneSpec& s = *r.own_scene;
      r.ratio_tight = TightDensity(s, r.final_design) / TightDensity(s, std::vector<uint8_t>(s.garment.faces.rows(), kReinforced));
    }
    r.jaccard = JaccardAgainst(r, r.final_design, reference, reference.final_design);
  }
  const std::string precise_value = Fmt("%.0e", PresetOf(Quality::kPrecise).grad_tol);
  const Run* precise = nullptr;
  for (const Run& r : *runs)
    if (r.knob == "grad_tol" && r.value == precise_value && !r.final_design.empty()) precise = &r;
  if (precise)
    for (Run& r : *runs)
      if (!r.final_design.empty()) r.jaccard_precise = JaccardAgainst(r, r.final_design, *precise, precise->final_design);
  for (Run& r : *methods) {
    if (static_cast<int>(r.designs.size()) <= k) continue;
    r.jaccard = JaccardAgainst(r, r.designs[k], reference, reference.designs[k]);
    r.ratio_tight = TightDensity(base, r.designs[k]) / full_density_tight;
  }
}

// 5. Newton against L-BFGS on one solve: the fully reinforced garment from the garment put on the body
// (cold), and a re-solve in the middle of the reference run, where a design update moves the
// equilibrium most (warm).
void TraceNewtonAgainstLbfgs(const SceneSpec& base, const Run& reference, int lbfgs_iterations, AccuracyStudy* st) {
  std::vector<EnergyTrace>& traces = st->traces;
  const std::vector<uint8_t> full(base.garment.faces.rows(), kReinforced);
  SolverSettings newton = base.solver, lbfgs = base.solver;
  newton.method = SolverMethod::kNewton;
  newton.grad_tol = 1e-10;
  newton.max_iterations = 1000;
  lbfgs.method = SolverMethod::kLbfgs;
  lbfgs.grad_tol = 1e-10;
  lbfgs.max_iterations = lbfgs_iterations;
  traces.push_back(TraceSolve("Newton, cold", base, full, base.initial, newton));
  traces.push_back(TraceSolve("L-BFGS, cold", base, full, base.initial, lbfgs));
  const int warm_k = std::min<int>(60, static_cast<int>(reference.designs.size()) - 2);
  st->warm_k = warm_k;
  if (warm_k >= 0) {
    traces.push_back(TraceSolve("Newton, warm", base, reference.designs[warm_k + 1], reference.positions[warm_k], newton));
    traces.push_back(TraceSolve("L-BFGS, warm", base, reference.designs[warm_k + 1], reference.positions[warm_k], lbfgs));
  }
  auto reference_energy = [&](size_t first) {
    double e = std::numeric_limits<double>::infinity();
    for (size_t i = first; i < std::min(first + 2, traces.size()); ++i)
      for (const auto& p : traces[i].time_energy) e = std::min(e, p.second);
    return e;
  };
  st->e_cold = reference_energy(0);
  st->e_warm = traces.size() > 2 ? reference_energy(2) : kNaN;
  // Errors relative to the energy (cold), or to the excess energy of the warm start over the
  // equilibrium (warm: a small design change moves the energy by a small fraction of itself).
  st->scale_cold = std::abs(st->e_cold);
  st->scale_warm = traces.size() > 2 ? traces[2].start_energy_J - st->e_warm : kNaN;
}

// 6. The pull test's force at each tolerance against its converged value.
std::vector<PullRow> PullTestForces() {
  std::vector<PullRow> pull;
  Result<SceneSpec> p = PullTestScene("line");
  auto force = [&](double tol, double* seconds, int* iterations) {
    SceneSpec s = *p;
    s.solver.grad_tol = tol;
    s.solver.max_iterations = 2000;
    Result<SimulationResult> r = SimulateScene(s);
    if (!r.ok()) return kNaN;
    *seconds = r->solve.seconds;
    *iterations = r->solve.iterations;
    double f = 0;
    for (const ClampForce& c : r->clamp_forces) f = std::max(f, c.force_N.norm());
    return f;
  };
  double s0 = 0;
  int i0 = 0;
  const double f_ref = force(1e-11, &s0, &i0);
  for (double tol : {1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8}) {
    PullRow row{tol, kNaN, kNaN, kNaN, 0};
    row.force_N = force(tol, &row.seconds, &row.iterations);
    row.error = std::abs(row.force_N - f_ref) / f_ref;
    pull.push_back(row);
  }
  return pull;
}

// 7. The frames a design is evaluated over (kgd evaluate): the reference run's final design over the
// motion posed in kEvaluationFrames frames, simulated at every stride-th frame (the last always),
// each frame warm-started from the last one simulated. The energy between simulated frames is read
// off a straight line through them (the rest pose stores nothing).
void EvaluateOverFrames(const PaperSource& paper, const Run& reference, AccuracyStudy* st) {
  constexpr int kEvaluationFrames = 16;
  st->evaluation_frames = kEvaluationFrames;
  Result<SceneSpec> moving = Status::Error("not a paper scene");
  if (paper.motion) {
    PaperMotion motion = *paper.motion;
    motion.frames = kEvaluationFrames;
    moving = PaperScene(*paper.body, motion);
  }
  if (moving.ok() && moving->garment.faces.rows() == reference.faces) {
    moving->design = reference.final_design;
    std::vector<double> all_frames;  // energy per frame with every frame simulated
    for (int stride : {1, 2, 4, 8, 16}) {
      FramesRow row;
      row.stride = stride;
      SceneSpec thinned = *moving;
      std::vector<int> kept;  // 1-based frame numbers
      for (int k = kEvaluationFrames; k >= 1; k -= stride) kept.insert(kept.begin(), k);
      thinned.motion->frames.clear();
      for (int k : kept) thinned.motion->frames.push_back(moving->motion->frames[k - 1]);
      row.frames = static_cast<int>(kept.size());
      std::fprintf(stderr, "study: evaluating over %d of %d frames ...\n", row.frames, kEvaluationFrames);
      const auto t = Clock::now();
      Result<std::vector<SimulationResult>> r = SimulateFrames(thinned);
      row.seconds = Since(t);
      if (!r.ok()) {
        row.status = r.message();
        st->frame_rows.push_back(row);
        continue;
      }
      bool all_converged = true;
      for (const SimulationResult& f : *r) all_converged &= f.solve.at_equilibrium();
      row.status = all_converged ? "converged" : "not converged";
      row.last_energy_J = r->back().solve.energy_J;
      if (stride == 1)
        for (const SimulationResult& f : *r) all_frames.push_back(f.solve.energy_J);
      if (static_cast<int>(all_frames.size()) == kEvaluationFrames) {
        const double peak = *std::max_element(all_frames.begin(), all_frames.end());
        row.last_error = std::abs(row.last_energy_J - all_frames.back()) / peak;
        double worst = 0;
        for (int k = 1; k <= kEvaluationFrames; ++k) {
          // The simulated frames around k (frame 0: the rest pose, energy 0).
          const auto next = std::lower_bound(kept.begin(), kept.end(), k);
          const int hi = *next, lo = next == kept.begin() ? 0 : *(next - 1);
          const double e_hi = (*r)[next - kept.begin()].solve.energy_J;
          const double e_lo = lo == 0 ? 0.0 : (*r)[next - kept.begin() - 1].solve.energy_J;
          const double e = hi == lo ? e_hi : e_lo + (e_hi - e_lo) * (k - lo) / (hi - lo);
          worst = std::max(worst, std::abs(e - all_frames[k - 1]));
        }
        row.curve_error = worst / peak;
      }
      st->frame_rows.push_back(row);
    }
  } else {
    st->frames_skipped = moving.ok() ? "the garment differs from the reference run's" : moving.message();
    std::fprintf(stderr, "study: no evaluation over frames: %s\n", st->frames_skipped.c_str());
  }
}

}  // namespace

Result<AccuracyStudy> RunAccuracyStudy(const AccuracyStudyOptions& o) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(o.work_dir, ec);
  if (ec) return Status::Error("cannot create " + o.work_dir + ": " + ec.message());
  AccuracyStudy st;
  st.options = o;
  // Cold: a first build into an empty scene cache (the study's own, under the work folder); warm: the
  // same scene again, as a new job on a warm machine finds it in the cache.
  const fs::path study_cache = fs::path(o.work_dir) / "scene-cache";
  fs::remove_all(study_cache, ec);
  auto t0 = Clock::now();
  Result<SceneSpec> scene = ResolveScene(o.scene, {}, study_cache.string());
  st.setup_cold_s = Since(t0);
  t0 = Clock::now();
  if (scene.ok()) (void)ResolveScene(o.scene, {}, study_cache.string());
  st.setup_warm_s = Since(t0);
  fs::remove_all(study_cache, ec);
  if (!scene.ok()) return scene.status();
  const SceneSpec& base = *scene;
  BesoSettings settings;
  settings.budget = base.budget < 1 ? base.budget : settings.budget;
  st.budget = settings.budget;
  st.garment_vertices = static_cast<long>(base.garment.vertices.rows());
  std::fprintf(stderr, "study: %s, %ld vertices; set-up %.2f s built, %.2f s from the scene cache\n", o.scene.c_str(), st.garment_vertices,
               st.setup_cold_s, st.setup_warm_s);

  std::vector<Run> runs = ToleranceSweep(base, settings, o.quick);
  auto last_designed = std::find_if(runs.rbegin(), runs.rend(), [](const Run& r) { return r.designed; });
  if (last_designed == runs.rend()) return st;
  const Run reference = *last_designed;  // the tightest tolerance that finished, with its history
  st.finished = true;
  st.reference_value = reference.value;
  AddVariants(base, settings, o.quick, &runs);
  const PaperSource paper = PaperSourceOf(o.scene);
  if (!o.quick && paper.motion) AddResolutions(paper, settings, &runs);
  st.method_iterations = std::min<int>(o.method_iterations, static_cast<int>(reference.designs.size()) - 1);
  std::vector<Run> methods = MethodRuns(base, settings, st.method_iterations);
  Judge(base, reference, st.method_iterations, &runs, &methods);
  for (const Run& r : runs) st.runs.push_back(r);
  for (const Run& r : methods) st.methods.push_back(r);
  TraceNewtonAgainstLbfgs(base, reference, o.lbfgs_trace_iterations, &st);
  st.pull = PullTestForces();
  EvaluateOverFrames(paper, reference, &st);
  return st;
}

}  // namespace kgd::study
