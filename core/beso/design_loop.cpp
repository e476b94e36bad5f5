#include "core/beso/design_loop.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <cstdio>
#include <optional>
#include <memory>

#include "core/beso/design_constraints.h"
#include "core/beso/pressure_limit.h"
#include "core/scene/simulate.h"

namespace kgd {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

bool TargetReached(double target_m2, double final_m2) { return target_m2 <= final_m2 * (1 + 1e-12); }

std::vector<double> Objective(const std::vector<BesoIteration>& history) {
  std::vector<double> e;
  e.reserve(history.size());
  for (const BesoIteration& it : history) e.push_back(it.energy_J);
  return e;
}

// The paper's stop rule on the energy of every motion in the objective (weight > 0): each flat over the
// window. One such motion (the scene's own): its energy_J, as with one motion.
bool ObjectiveFlat(const std::vector<BesoIteration>& history, bool target_reached, double tau, int window) {
  const std::vector<MotionMetrics>& motions = history.back().motions;
  int active = 0;
  for (const MotionMetrics& m : motions) active += m.weight > 0;
  if (active <= 1) return BesoConverged(Objective(history), target_reached, tau, window);
  for (size_t k = 0; k < motions.size(); ++k) {
    if (!(motions[k].weight > 0)) continue;
    std::vector<double> e;
    for (const BesoIteration& it : history)
      if (it.motions.size() == motions.size()) e.push_back(it.motions[k].energy_J);
    if (!BesoConverged(e, target_reached, tau, window)) return false;
  }
  return true;
}

// An allowed motion's re-solves (iterations after 0) stop at no less than this many times the scene's
// gradient tolerance (BesoSettings::resolve_tolerance_factor, when larger, for it as for every motion).
// The allowed poses compress the garment (a sleeve bent to 120 degrees): its warm re-solves spend
// half their Newton iterations between 3x the tolerance and the tolerance, local steps over
// membrane faces going slack and taut and vertices touching and leaving the body, and their figures
// wander as much there as between two solves to the tolerance on different paths (docs/MODEL.md,
// "Motions with roles"; DECISIONS.md).
constexpr double kAllowedMotionTolerance = 3.0;

// A motion beyond the scene's own, simulated beside it every iteration on a system of its own (built
// once), warm-started from its own last equilibrium.
struct MotionState {
  SceneMotion motion;
  SceneSpec scene;
  std::unique_ptr<GarmentSystem> sys;
  std::unique_ptr<Simulator> sim;
  Positions x;
  Eigen::VectorXd density;   // W at x
  double full_density = 0;   // reinforced density of iteration 0 (J/m^2)
  double simulation_s = 0;   // the last solve (wall s)
};

// Solves `m` at its current design from its last equilibrium (from the body when that fails, or when
// `cold`), after iteration 0 to `tolerance_factor` times the scene's tolerance (the loop's: BesoSettings::
// resolve_tolerance_factor while the target shrinks, else 1; an allowed motion's at least
// kAllowedMotionTolerance); errors name the motion.
Result<SimulationResult> SolveMotion(MotionState* m, int iteration, bool cold, double tolerance_factor) {
  const auto t0 = Clock::now();
  if (cold) m->x = m->scene.initial;
  SolverSettings solver = m->scene.solver;
  if (iteration > 0)
    solver.grad_tol *= m->motion.role == MotionRole::kAllow ? std::max(tolerance_factor, kAllowedMotionTolerance) : tolerance_factor;
  m->sim->ResetFactorization();
  SolveReport report = SolveLagged(*m->sim, *m->sys, &m->x, solver);
  if (!report.at_equilibrium() && !cold) {
    m->x = m->scene.initial;
    m->sim->ResetFactorization();
    AccumulateSolve(&report, SolveLagged(*m->sim, *m->sys, &m->x, solver));
  }
  if (!report.at_equilibrium())
    return Status::Error("BESO iteration " + std::to_string(iteration) + ", motion '" + m->motion.name + "': the simulation did not converge (" +
                         ToString(report.status) + (report.message.empty() ? "" : ": " + report.message) + ")");
  SimulationResult r = Summarize(*m->sys, m->x, m->scene.on_body, report);
  m->density = r.face_density_Pa;
  m->simulation_s = Since(t0);
  return r;
}

MotionMetrics MetricsOfMotion(const SceneMotion& motion, const SimulationResult& r, double full_density) {
  MotionMetrics out;
  out.name = motion.name;
  out.role = motion.role;
  out.weight = motion.weight;
  out.energy_J = r.solve.energy_J;
  out.reinforced_energy_J = r.reinforced_energy_J;
  out.reinforced_density_J_per_m2 = r.reinforced_density_J_per_m2;
  out.density_ratio = full_density > 0 ? r.reinforced_density_J_per_m2 / full_density : 0.0;
  out.solver_iterations = r.solve.iterations;
  return out;
}

// What a pressure limit did to the last design, for DescribeBesoEnd: "" without a limit, or when it
// holds and the budget is met.
std::string PressureLimitNote(const BesoIteration& last, const BesoSettings& settings) {
  if (!(settings.max_pressure_Pa > 0)) return "";
  char buf[256];
  if (last.peak_pressure_Pa > settings.max_pressure_Pa) {
    std::snprintf(buf, sizeof buf, ": the last design still presses the skin %.3g kPa, above max_pressure_kPa %.4g", 1e-3 * last.peak_pressure_Pa,
                  1e-3 * settings.max_pressure_Pa);
    return buf;
  }
  if (last.area_fraction < 0.99 * settings.budget) {
    std::snprintf(buf, sizeof buf, " at %.1f %% of the garment, below the budget of %.1f %%: max_pressure_kPa %.4g keeps %.1f %% of it cloth",
                  100 * last.area_fraction, 100 * settings.budget, 1e-3 * settings.max_pressure_Pa, 100 * last.pressure_kept_out_fraction);
    return buf;
  }
  return "";
}

}  // namespace

std::vector<double> CaseWeights(const SceneSpec& scene, const std::vector<SceneMotion>& motions, const BesoIteration& before) {
  std::vector<double> w;
  for (const SceneMotion& m : motions) w.push_back(m.weight);
  if (scene.bodies.empty() || scene.body_objective != BodyObjective::kWorst || before.motions.size() != motions.size()) return w;
  double lowest = std::numeric_limits<double>::infinity(), sum = 0, soft = 0;
  for (size_t k = 0; k < w.size(); ++k)
    if (w[k] > 0) lowest = std::min(lowest, before.motions[k].density_ratio), sum += w[k];
  for (size_t k = 0; k < w.size(); ++k)
    if (w[k] > 0) w[k] *= std::exp(-(before.motions[k].density_ratio - lowest) / kWorstBodyTemperature), soft += w[k];
  for (double& v : w) v *= sum / soft;
  return w;
}

double BesoIteration::*TermTimeMetric(std::string_view term) {
#define KGD_TERM_TIME_ENTRY(Y, Class, key, sum_place, Type, effect, value, effect_what, time_what) {#key, &BesoIteration::key##_s},
  static const std::pair<std::string_view, double BesoIteration::*> metrics[] = {KGD_ENERGY_TERMS(KGD_TERM_TIME_ENTRY, )};
#undef KGD_TERM_TIME_ENTRY
  for (const auto& [name, member] : metrics)
    if (name == term) return member;
  return nullptr;
}

void RecordSolveProfile(const SolveReport& report, BesoIteration* it) {
  it->assembly_s = report.assembly_s;
  it->factorization_s = report.factorization_s;
  it->linear_solve_s = report.solve_s;
  it->line_search_s = report.line_search_s;
  it->body_field_query_s = report.body_field_query_s;
  for (const GarmentSystem::TermTime& t : report.term_times)
    if (double BesoIteration::*m = TermTimeMetric(t.name)) it->*m = t.seconds;
}

BesoIteration MetricsOnly(BesoIteration it) {
  it.positions.resize(0, 3);
  it.energy_density_Pa.resize(0);
  it.sensitivity.resize(0);
  it.design.clear();
  it.motion_positions.clear();
  return it;
}

bool NothingToResist(const BesoIteration& it) { return it.iteration == 0 && !(it.reinforced_energy_J > kNothingToResist_J); }

BesoEnd BesoEndOf(const std::vector<BesoIteration>& history, const BesoSettings& settings, double garment_area_m2) {
  if (history.empty()) return BesoEnd::kRunning;
  if (NothingToResist(history.front())) return BesoEnd::kNothingToResist;
  if (history.back().iteration >= settings.max_iterations) return BesoEnd::kIterationLimit;
  // With a pressure limit the last design must also keep it.
  if (settings.max_pressure_Pa > 0 && history.back().peak_pressure_Pa > settings.max_pressure_Pa) return BesoEnd::kRunning;
  if (ObjectiveFlat(history, TargetReached(history.back().target_area_m2, settings.budget * garment_area_m2), settings.tau,
                    settings.converge_window))
    return BesoEnd::kConverged;
  return BesoEnd::kRunning;
}

bool BesoFinished(const std::vector<BesoIteration>& history, const BesoSettings& settings, double garment_area_m2) {
  return BesoEndOf(history, settings, garment_area_m2) != BesoEnd::kRunning;
}

std::string DescribeBesoEnd(BesoEnd end, const std::vector<BesoIteration>& history, const BesoSettings& settings) {
  switch (end) {
    case BesoEnd::kRunning: return "running";
    case BesoEnd::kConverged: return "converged" + PressureLimitNote(history.back(), settings);
    case BesoEnd::kIterationLimit: return "iteration limit (" + std::to_string(settings.max_iterations) + ")" + PressureLimitNote(history.back(), settings);
    case BesoEnd::kNothingToResist: {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "nothing to resist: the motion puts %.3g J into the fully reinforced garment (at most %.0e J: the body does not "
                    "move, or moves rigidly), so no design can resist it",
                    history.front().reinforced_energy_J, kNothingToResist_J);
      return buf;
    }
  }
  return "";
}

std::vector<MotionMetrics> MotionsOfJob(const SceneSpec& scene, const BesoSettings& settings) {
  std::vector<MotionMetrics> out;
  for (const SceneMotion& m : MotionsOf(scene)) {
    MotionMetrics mm;
    mm.name = m.name;
    mm.role = m.role;
    mm.weight = settings.resist_only && m.role == MotionRole::kAllow ? 0.0 : m.weight;
    out.push_back(std::move(mm));
  }
  return out;
}

Result<std::vector<BesoIteration>> RunBeso(const SceneSpec& scene_in, const BesoSettings& settings,
                                           const std::function<bool(const BesoIteration&)>& on_iteration,
                                           const std::vector<BesoIteration>* resume) {
  if (Status st = ValidateBesoSettings(settings); !st.ok()) return st;
  KGD_RETURN_IF_ERROR(ValidateSceneMotions(scene_in));
  KGD_RETURN_IF_ERROR(ValidateSceneBodies(scene_in));
  SceneSpec scene = scene_in;
  if (settings.resist_only)
    for (SceneMotion& m : scene.motions)
      if (m.role == MotionRole::kAllow) m.weight = 0;
  const int nf = static_cast<int>(scene.garment.faces.rows());
  const int nv = static_cast<int>(scene.garment.vertices.rows());
  scene.design.assign(nf, kReinforced);
  std::vector<BesoIteration> past;  // energies of earlier iterations (for the stop rule)
  const BesoIteration* last = nullptr;
  if (resume && !resume->empty()) {
    past = *resume;
    last = &resume->back();
    if (static_cast<int>(last->design.size()) != nf || last->positions.rows() != nv ||
        (last->iteration > 0 && last->sensitivity.size() != nf))
      return Status::Error("cannot resume: the stored iteration " + std::to_string(last->iteration) + " has " +
                           std::to_string(last->design.size()) + " faces and " + std::to_string(last->positions.rows()) +
                           " vertices, the scene " + std::to_string(nf) + " and " + std::to_string(nv));
    if (last->iteration != static_cast<int>(resume->size()) - 1)
      return Status::Error("cannot resume: the stored iterations are not contiguous from 0");
    scene.design = last->design;
  }
  Result<GarmentModel> model = BuildGarmentModel(scene);
  if (!model.ok()) return model.status();
  GarmentSystem sys(std::move(model).value(), scene.initial);
  Simulator sim(&sys);
  const Positions& reference = scene.on_body.rows() ? scene.on_body : scene.initial;
  Eigen::VectorXd area(nf);
  for (int f = 0; f < nf; ++f) area[f] = sys.rest_areas_m2()[f];
  const double total_area = area.sum(), final_area = settings.budget * total_area;
  // Keep-out, keep-in and symmetry: BESO then decides on units (design_constraints.h). Without them
  // the loop is the plain one below, unchanged.
  const std::optional<SymmetryPlane> plane = scene.symmetry ? scene.symmetry : settings.symmetric ? std::optional(SymmetryPlane{}) : std::nullopt;
  // A pressure limit keeps faces out as the run goes (pressure_limit.h): it decides on units too.
  const double limit_Pa = settings.max_pressure_Pa;
  const bool constrained = plane || !scene.keep_out_faces.empty() || !scene.keep_in_faces.empty() || limit_Pa > 0;
  std::optional<MirrorPairing> pairing;
  std::optional<DesignUnits> units;
  if (constrained) {
    if (plane) {
      Result<MirrorPairing> p = PairMirrorFaces(scene.garment, *plane);
      if (!p.ok()) return p.status();
      pairing = std::move(p).value();
    }
    Result<DesignUnits> u = MakeDesignUnits(nf, scene.keep_out_faces, scene.keep_in_faces,
                                            settings.keep_attachments ? scene.attachment_faces : std::vector<int>{},
                                            pairing ? &*pairing : nullptr);
    if (!u.ok()) return u.status();
    units = std::move(u).value();
    const double kept_in = LockedArea(*units, area);
    if (kept_in > final_area)
      return Status::Error(std::string(settings.keep_attachments ? "garment.keep_in and the kept attachments" : "garment.keep_in") + " cover " +
                           std::to_string(100 * kept_in / total_area) + " % of the garment" + (pairing ? " (with their mirror images)" : "") +
                           ", more than the budget of " + std::to_string(100 * settings.budget) + " %");
    if (!last) scene.design = FullDesign(*units);
    else if (Status st = CheckDesignConstraints(*units, last->design); !st.ok())
      return Status::Error("cannot resume: the stored iteration " + std::to_string(last->iteration) + " breaks the design constraints: " +
                           st.message());
  }
  std::vector<uint8_t> locked;
  if (settings.keep_attachments && !constrained) {
    locked.assign(nf, 0);
    double locked_area = 0;
    for (int f : scene.attachment_faces) {
      locked_area += locked[f] ? 0.0 : area[f];
      locked[f] = 1;
    }
    if (locked_area > final_area)
      return Status::Error("keep_attachments: the attachment bands cover " + std::to_string(100 * locked_area / total_area) +
                           " % of the garment, more than the budget of " + std::to_string(100 * settings.budget) + " %");
  }

  std::vector<BesoIteration> out;
  std::vector<uint8_t> design = scene.design;
  Positions x = last ? last->positions : scene.initial;
  Eigen::VectorXd previous = last ? last->sensitivity : Eigen::VectorXd();
  Eigen::VectorXd density = last ? last->energy_density_Pa : Eigen::VectorXd();  // W at x
  double target = last ? last->target_area_m2 : units ? total_area - KeptOutArea(*units, area) : total_area;
  if (units && !last) sys.SetDesign(design);
  double full_density = past.empty() ? 0.0 : past.front().reinforced_density_J_per_m2;
  if (last && BesoFinished(past, settings, total_area)) return out;
  // The scene's own motion is motions[0] (simulated by `sys`); the others get systems of their own.
  // A scene of several bodies: one motion per body, the others on their own garment rest shapes.
  const std::vector<SceneMotion> motions = MotionsOf(scene);
  std::vector<MotionState> others;
  int active = 0;  // motions in the objective
  for (const SceneMotion& m : motions) active += m.weight > 0;
  for (size_t k = 1; k < motions.size(); ++k) {
    MotionState& st = others.emplace_back();
    st.motion = motions[k];
    Result<SceneSpec> posed = scene.bodies.empty() ? SceneInMotion(scene, static_cast<int>(k)) : SceneOnBody(scene, static_cast<int>(k));
    if (!posed.ok()) return posed.status();
    st.scene = std::move(posed).value();
    Result<GarmentModel> mk = BuildGarmentModel(st.scene);
    if (!mk.ok()) return mk.status().WithContext("motion '" + st.motion.name + "': ");
    st.sys = std::make_unique<GarmentSystem>(std::move(mk).value(), st.scene.initial);
    st.sim = std::make_unique<Simulator>(st.sys.get());
    st.x = st.scene.initial;
    if (!past.empty() && past.front().motions.size() == motions.size()) st.full_density = past.front().motions[k].reinforced_density_J_per_m2;
  }
  // Resumed: the other motions (at the stored design: scene.design) continue from their stored
  // equilibria, as the uninterrupted run left them; records without them solve them again from the body.
  if (last) {
    const bool stored = last->motion_positions.size() == others.size();
    for (size_t k = 0; k < others.size(); ++k) {
      MotionState& st = others[k];
      if (stored && last->motion_positions[k].rows() == st.x.rows() && last->motion_positions[k].allFinite()) {
        st.x = last->motion_positions[k];
        st.density = Summarize(*st.sys, st.x, st.scene.on_body, SolveReport{}).face_density_Pa;
      } else if (Result<SimulationResult> r = SolveMotion(&st, last->iteration, true, 1.0); !r.ok()) {
        return r.status();
      }
    }
  }
  // The pressure limit: every resisted motion's pressures at its last equilibrium, the peak over them,
  // the area the limit keeps cloth. A resumed run starts its kept-out set from the stored design's
  // equilibrium (the set is not stored), so it keeps the limit but may part from the uninterrupted run.
  std::vector<Eigen::VectorXd> garment_pressure;
  double peak_pressure = 0;
  const double scene_kept_out_area = units ? KeptOutArea(*units, area) : 0.0;
  auto measure_pressure = [&] {
    garment_pressure.clear();
    peak_pressure = 0;
    auto add = [&](const SceneSpec& posed, const GarmentModel& model, const Positions& at) {
      if (!posed.body) return;
      PosePressure p = PressureInPose(*posed.body, model, at);
      peak_pressure = std::max(peak_pressure, p.skin.peak_Pa);
      garment_pressure.push_back(std::move(p.garment_Pa));
    };
    if (motions[0].role == MotionRole::kResist) add(scene, sys.model(), x);
    for (const MotionState& st : others)
      if (st.motion.role == MotionRole::kResist) add(st.scene, st.sys->model(), st.x);
  };
  if (limit_Pa > 0) {
    std::vector<PressurePose> poses;
    if (motions[0].role == MotionRole::kResist) poses.push_back({motions[0].name, &scene});
    for (const MotionState& st : others)
      if (st.motion.role == MotionRole::kResist) poses.push_back({st.motion.name, &st.scene});
    if (!last) KGD_RETURN_IF_ERROR(CheckClothUnderPressureLimit(poses, limit_Pa));
    else measure_pressure();
  }
  for (int it = last ? last->iteration + 1 : 0; it <= settings.max_iterations; ++it) {
    BesoIteration b;
    const auto t_iteration = Clock::now();
    if (it > 0) {
      // Rank on the last equilibrium and move the design towards the next target area.
      auto t0 = Clock::now();
      if (density.size() != nf) sys.FaceDensities(x, &density, nullptr);
      Eigen::VectorXd s = Sensitivities(density, design, scene.reinforced.youngs_modulus_Pa, scene.cloth.youngs_modulus_Pa,
                                        settings.d_min, settings.penalty);
      if (active > 1) {
        // docs/MODEL.md, "Motions with roles": each motion's sensitivities over its fully reinforced
        // density, weighted, added for resisted motions and subtracted for allowed ones. With one motion
        // in the objective its sensitivities rank as they are (a scale does not change the ranking).
        // A range of bodies: the same, each body a resisted motion (weighed by the worst: CaseWeights).
        const std::vector<double> w = CaseWeights(scene, motions, past.back());
        if (full_density > 0) s *= w[0] / full_density;
        for (size_t k = 1; k < motions.size(); ++k) {
          MotionState& st = others[k - 1];
          if (!(st.motion.weight > 0) || !(st.full_density > 0)) continue;
          if (st.density.size() != nf) st.sys->FaceDensities(st.x, &st.density, nullptr);
          const double c = (st.motion.role == MotionRole::kAllow ? -1.0 : 1.0) * w[k] / st.full_density;
          s += c * Sensitivities(st.density, design, scene.reinforced.youngs_modulus_Pa, scene.cloth.youngs_modulus_Pa, settings.d_min,
                                 settings.penalty);
        }
      }
      b.sensitivity_s = Since(t0);
      t0 = Clock::now();
      Eigen::VectorXd filtered = FilterSensitivities(s, scene.garment.faces, nv, area);
      if (pairing) filtered = SymmetrizeOverGroups(filtered, area, *units);
      const Eigen::VectorXd raw = filtered;
      if (settings.temporal_averaging) filtered = AverageSensitivities(filtered, previous);
      previous = settings.average_with_raw ? raw : filtered;
      b.filter_s = Since(t0);
      t0 = Clock::now();
      target = NextTargetArea(target, final_area, settings.evolutionary_ratio);
      if (limit_Pa > 0 && peak_pressure > limit_Pa && TargetReached(target, final_area)) {
        // The last design pressed the skin above the limit: keep out the faces where it did.
        std::vector<uint8_t> may_keep_out(nf, 0);
        for (int f = 0; f < nf; ++f) may_keep_out[f] = units->unit_of[f] >= 0 && !units->locked[units->unit_of[f]];
        const std::vector<int> more = FacesToKeepOut(scene.garment.faces, nv, garment_pressure, limit_Pa, design, may_keep_out);
        if (!more.empty()) {
          scene.keep_out_faces.insert(scene.keep_out_faces.end(), more.begin(), more.end());
          Result<DesignUnits> u = MakeDesignUnits(nf, scene.keep_out_faces, scene.keep_in_faces,
                                                  settings.keep_attachments ? scene.attachment_faces : std::vector<int>{},
                                                  pairing ? &*pairing : nullptr);
          if (!u.ok()) return u.status();
          units = std::move(u).value();
        }
      }
      design = units ? UpdateDesignOnUnits(*units, filtered, area, design, target, settings.admission_ratio * total_area)
                     : UpdateDesign(filtered, area, design, target, settings.admission_ratio * total_area,
                                    settings.keep_attachments ? &locked : nullptr);
      sys.SetDesign(design);
      for (MotionState& st : others) st.sys->SetDesign(design);
      b.update_s = Since(t0);
      b.sensitivity = previous;
    }
    // A fresh factorization per iteration keeps each iteration a function of the previous record only
    // (resumable bit for bit); within the iteration the factorization is reused as usual.
    sim.ResetFactorization();
    const auto t0 = Clock::now();
    // While the target area shrinks the re-solves need only the ranking near the threshold; from the
    // budget on the stop rule compares the objectives, at the scene's tolerance.
    const double tolerance_factor = it > 0 && !TargetReached(target, final_area) ? settings.resolve_tolerance_factor : 1.0;
    SolverSettings solver = scene.solver;
    solver.grad_tol *= tolerance_factor;
    SolveReport report = SolveLagged(sim, sys, &x, solver);
    if (!report.at_equilibrium() && it > 0) {
      // From the last equilibrium the solver can wander into a path it cannot finish (a pleat pressed
      // against the fold barrier); the garment on the body is the start the scene was made for.
      x = scene.initial;
      sim.ResetFactorization();
      AccumulateSolve(&report, SolveLagged(sim, sys, &x, solver));
      b.cold_restart = 1;
    }
    const SimulationResult r = Summarize(sys, x, reference, report);
    // Every other motion at the same design, each from its own last equilibrium.
    std::vector<MotionMetrics> motion_metrics;
    motion_metrics.reserve(motions.size());
    if (it == 0) full_density = r.reinforced_density_J_per_m2;
    motion_metrics.push_back(MetricsOfMotion(motions[0], r, full_density));
    motion_metrics.back().simulation_s = Since(t0);
    if (report.at_equilibrium())
      for (MotionState& st : others) {
        Result<SimulationResult> rk = SolveMotion(&st, it, false, tolerance_factor);
        if (!rk.ok()) return rk.status();
        if (it == 0) st.full_density = rk->reinforced_density_J_per_m2;
        motion_metrics.push_back(MetricsOfMotion(st.motion, *rk, st.full_density));
        motion_metrics.back().simulation_s = st.simulation_s;
      }
    b.simulation_s = Since(t0);
    RecordSolveProfile(report, &b);
    b.iteration = it;
    b.target_area_m2 = target;
    b.area_fraction = r.reinforced_area_m2 / total_area;
    b.energy_J = report.energy_J;
    b.reinforced_energy_J = r.reinforced_energy_J;
    b.reinforced_density_J_per_m2 = r.reinforced_density_J_per_m2;
    b.density_ratio = full_density > 0 ? r.reinforced_density_J_per_m2 / full_density : 0.0;
    b.status = report.status;
    b.solver_iterations = report.iterations;
    b.design = design;
    b.positions = x;
    b.energy_density_Pa = r.face_density_Pa;
    b.motions = std::move(motion_metrics);
    b.motion_positions.clear();
    for (const MotionState& st : others) b.motion_positions.push_back(st.x);
    density = r.face_density_Pa;
    if (limit_Pa > 0 && report.at_equilibrium()) {
      measure_pressure();
      b.peak_pressure_Pa = peak_pressure;
      b.pressure_kept_out_fraction = (KeptOutArea(*units, area) - scene_kept_out_area) / total_area;
    }
    b.total_s = Since(t_iteration);
    if (!report.at_equilibrium())
      return Status::Error("BESO iteration " + std::to_string(it) + ": the simulation did not converge (" + ToString(report.status) +
                           (report.message.empty() ? "" : ": " + report.message) + ")");
    past.push_back(b);
    out.push_back(std::move(b));
    if (on_iteration && !on_iteration(out.back())) break;
    if (BesoFinished(past, settings, total_area)) break;
    // Only the energies of earlier iterations are needed from here on.
    past.back() = MetricsOnly(std::move(past.back()));
  }
  return out;
}

}  // namespace kgd
