// Projected Newton for Simulator (see simulator.h).
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string_view>

#include "core/sim/simulator.h"
#include "core/sim/sparse_cholesky.h"

namespace kgd {
namespace {

constexpr double kTightGradTol = 1e-5;

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

Eigen::VectorXd GatherFree(const Eigen::VectorXd& full, const std::vector<int>& free_index, int n_free) {
  Eigen::VectorXd out(n_free);
  for (size_t d = 0; d < free_index.size(); ++d)
    if (free_index[d] >= 0) out[free_index[d]] = full[d];
  return out;
}

void AddFree(const Eigen::VectorXd& step, double alpha, const std::vector<int>& free_index, const Positions& from,
             Positions* to) {
  *to = from;
  double* data = to->data();
  for (size_t d = 0; d < free_index.size(); ++d)
    if (free_index[d] >= 0) data[d] += alpha * step[free_index[d]];
}

// A Newton step on the region that holds the residual (SolverSettings::local_steps), or false when the
// residual is spread out or the region's block is not positive definite. `H` is the upper triangle of
// the Hessian over the free coordinates, `delta` the damping, `vertex_of` each free coordinate's vertex
// (non-decreasing).
bool LocalStep(const Eigen::SparseMatrix<double>& H, const Eigen::VectorXd& g, double delta, const std::vector<int>& vertex_of,
               Eigen::VectorXd* p) {
  const int n = static_cast<int>(g.size());
  const double g_max = g.cwiseAbs().maxCoeff();
  std::vector<char> in(n, 0);
  double core2 = 0;
  for (int i = 0; i < n; ++i)
    if (std::abs(g[i]) >= 0.01 * g_max) {
      in[i] = 1;
      core2 += g[i] * g[i];
    }
  if (core2 < 0.99 * g.squaredNorm()) return false;
  // Two rings of neighbours through the Hessian's pattern: the coordinates the core pulls on, and theirs.
  for (int ring = 0; ring < 2; ++ring) {
    std::vector<char> next = in;
    for (int j = 0; j < n; ++j)
      for (Eigen::SparseMatrix<double>::InnerIterator e(H, j); e; ++e) {
        if (in[e.index()]) next[j] = 1;
        if (in[j]) next[e.index()] = 1;
      }
    in.swap(next);
  }
  int m = 0;
  for (int i = 0; i < n; ++i) m += in[i];
  if (m > n / 3) return false;
  // The region's vertices, ordered by minimum degree on their graph: AMD on the coordinates costs twice
  // the numeric factorization, on the vertices (a ninth of the entries) a fraction of it. The graph
  // comes from each vertex's first coordinate's column: the upper triangle holds its lower neighbours.
  std::vector<int> node(n, -1), node_first;  // each region coordinate's vertex node; each node's first coordinate
  {
    std::vector<int> vertex_node(vertex_of.empty() ? 0 : vertex_of.back() + 1, -1);
    for (int i = 0; i < n; ++i) {
      if (!in[i]) continue;
      int& v = vertex_node[vertex_of[i]];
      if (v < 0) {
        v = static_cast<int>(node_first.size());
        node_first.push_back(i);
      }
      node[i] = v;
    }
  }
  const int nodes = static_cast<int>(node_first.size());
  std::vector<Eigen::Triplet<double>> entries;
  for (int v = 0; v < nodes; ++v)
    for (Eigen::SparseMatrix<double>::InnerIterator e(H, node_first[v]); e; ++e) {
      const int u = node[e.index()];
      if (u >= 0) entries.emplace_back(std::min(u, v), std::max(u, v), 1.0);  // Eigen's AMD wants the diagonal
    }
  Eigen::SparseMatrix<double> graph(nodes, nodes);
  graph.setFromTriplets(entries.begin(), entries.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> elimination;
  Eigen::AMDOrdering<int>()(graph.selfadjointView<Eigen::Upper>(), elimination);
  // Local numbering: the vertices in elimination order, each one's coordinates together.
  std::vector<int> count(nodes, 0);  // region coordinates per vertex
  for (int i = 0; i < n; ++i)
    if (node[i] >= 0) ++count[node[i]];
  std::vector<int> offset(nodes);  // first local index of each vertex
  for (int k = 0, next = 0; k < nodes; ++k) {
    const int v = elimination.indices()[k];
    offset[v] = next;
    next += count[v];
  }
  std::vector<int> local(n, -1);
  for (int i = 0; i < n; ++i)
    if (node[i] >= 0) local[i] = offset[node[i]]++;
  entries.clear();
  for (int j = 0; j < n; ++j) {
    if (local[j] < 0) continue;
    for (Eigen::SparseMatrix<double>::InnerIterator e(H, j); e; ++e)
      if (local[e.index()] >= 0)
        entries.emplace_back(std::min(local[e.index()], local[j]), std::max(local[e.index()], local[j]), e.value());
    entries.emplace_back(local[j], local[j], delta);
  }
  Eigen::SparseMatrix<double> A(m, m);
  A.setFromTriplets(entries.begin(), entries.end());
  const Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Upper, Eigen::NaturalOrdering<int>> llt(A);
  if (llt.info() != Eigen::Success) return false;
  Eigen::VectorXd g_local(m);
  for (int i = 0; i < n; ++i)
    if (local[i] >= 0) g_local[local[i]] = g[i];
  const Eigen::VectorXd p_local = llt.solve(-g_local);
  *p = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; ++i)
    if (local[i] >= 0) (*p)[i] = p_local[local[i]];
  return true;
}

// Per term, the elements whose energy is zero in one of `before` and `after` and positive in the other.
std::vector<int> SwitchedElements(const std::vector<std::vector<double>>& before, const std::vector<std::vector<double>>& after) {
  std::vector<int> out(after.size(), 0);
  if (before.size() != after.size()) return out;
  for (size_t t = 0; t < after.size(); ++t) {
    if (before[t].size() != after[t].size()) continue;
    for (size_t e = 0; e < after[t].size(); ++e) out[t] += (before[t][e] > 0) != (after[t][e] > 0);
  }
  return out;
}

}  // namespace

std::string DescribeIteration(const IterationInfo& info) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "E %.12g J  |g| %.3e N  alpha %.3g  delta %.3g%s", info.energy_J, info.grad_norm_N,
                info.step_length, info.regularization, info.used_pcg ? "  (pcg)" : info.local ? "  (local)" : "");
  std::string out = buf;
  const StepDiagnostics& d = info.diagnostics;
  if (std::isfinite(d.model_ratio)) {
    std::snprintf(buf, sizeof buf, "  model %.3g", d.model_ratio);
    out += buf;
  }
  bool first = true;
  for (size_t t = 0; t < d.switched_elements.size(); ++t) {
    if (d.switched_elements[t] == 0) continue;
    const char* name = d.term_names && t < d.term_names->size() ? (*d.term_names)[t] : "term";
    out += (first ? "  switched " : ", ") + std::string(name) + " " + std::to_string(d.switched_elements[t]);
    first = false;
  }
  return out;
}

const char* ToString(SolveStatus s) {
  switch (s) {
    case SolveStatus::kConverged: return "converged";
    case SolveStatus::kLineSearchFailed: return "line_search_failed";
    case SolveStatus::kNotPositiveDefinite: return "not_positive_definite";
    case SolveStatus::kIterationLimit: return "iteration_limit";
    case SolveStatus::kInvalidState: return "invalid_state";
    case SolveStatus::kStalled: return "stalled";
  }
  return "unknown";
}

struct Simulator::Newton {
  SparseCholesky cholesky;  // analyzed at the first factorization, once per Simulator
  bool have_factor = false;
  double mu = 0;  // largest damping with which the last solve took a full step: a warm re-solve starts there
  // PCG on an old factorization pays only while the Hessian changes little between steps; on scenes
  // where it keeps failing (relaxed cloth with contact switching) the attempts are pure cost. After two
  // failures in a row it is skipped, and probed again every eighth solve.
  int pcg_failures_in_row = 0;
  int solves_since_probe = 0;
  Eigen::SparseMatrix<double> H;
  Eigen::SparseMatrix<double> H_trial;  // the Hessian at a line search's first trial (see SolveNewton)
  // What the evaluations at the current state and at the first trial leave for evaluations near them
  // (GarmentSystem::EvaluateFrom): a local step's trials re-evaluate only the region it moved, and a
  // warm re-solve's first evaluation only the faces whose design changed. `gradient` and H are the
  // evaluation's at record.x, also between solves.
  EvaluationRecord record, record_trial;
  Eigen::VectorXd gradient;
  std::vector<int> vertex_of;           // each free coordinate's vertex (for LocalStep)
};

Simulator::Simulator(GarmentSystem* system) : system_(system), newton_(std::make_unique<Newton>()) {
  newton_->H = system_->hessian_pattern();
  newton_->H_trial = newton_->H;
  const std::vector<int>& free_index = system_->free_index();
  newton_->vertex_of.resize(system_->num_free_dofs());
  for (size_t d = 0; d < free_index.size(); ++d)
    if (free_index[d] >= 0) newton_->vertex_of[free_index[d]] = static_cast<int>(d / 3);
}

Simulator::~Simulator() = default;

void Simulator::ResetFactorization() {
  newton_->have_factor = false;
  newton_->mu = 0;
  newton_->pcg_failures_in_row = 0;
  newton_->solves_since_probe = 0;
}

SolveReport Simulator::Solve(Positions* x, const SolverSettings& settings) {
  const auto t0 = Clock::now();
  const std::vector<GarmentSystem::TermTime> terms_before = system_->term_times();
  const double queries_before = system_->body_field_query_s();
  SolveReport r = settings.method == SolverMethod::kNewton ? SolveNewton(x, settings) : SolveLbfgs(x, settings);
  r.seconds = Seconds(t0, Clock::now());
  r.accept_iteration_limit = settings.accept_iteration_limit;
  r.term_times = system_->term_times();
  for (size_t t = 0; t < r.term_times.size(); ++t) {
    r.term_times[t].seconds -= terms_before[t].seconds;
    r.term_times[t].elements -= terms_before[t].elements;
  }
  r.body_field_query_s = system_->body_field_query_s() - queries_before;
  return r;
}

// One Newton solve, step by step: the state a solve carries from iteration to iteration, and the
// parts of an iteration (stop tests, the three ways to a step, the line search, the damping update).
struct Simulator::NewtonSolve {
  NewtonSolve(GarmentSystem& system, Newton& newton, const SolverSettings& settings, Positions* x)
      : sys(system),
        nt(newton),
        settings(settings),
        x(x),
        free_index(system.free_index()),
        n(system.num_free_dofs()),
        max_it(settings.max_iterations > 0 ? settings.max_iterations : 200),
        k_ref(system.stiffness_scale_N_per_m()),
        project_crossings(settings.project_contact_crossings && system.model().effects.contact == ContactModel::kUnilateral),
        g_full(newton.gradient) {}

  GarmentSystem& sys;
  Newton& nt;
  const SolverSettings& settings;
  Positions* x;
  const std::vector<int>& free_index;
  const int n, max_it;
  const double k_ref;
  const bool project_crossings;
  SolveReport rep;
  Eigen::VectorXd& g_full;  // the gradient at *x over all coordinates (kept in nt between solves)
  Eigen::VectorXd g;        // ... over the free ones
  double E = 0, g0 = 0;
  // Levenberg-Marquardt damping delta (N/m), adapted to how well the last step's quadratic model held:
  // shrinks after full steps (so it vanishes at convergence), grows after short ones. It bounds the steps
  // along the model's singular modes (slack cloth, sliding on the body, free translations). A warm
  // re-solve starts from the largest damping with which the last solve took full steps: the soft modes
  // are still there, and the new design moves the state more than the last converging steps did.
  double mu = 0, mu_full_max = 0;
  bool pcg_allowed = false, skip_pcg = false;
  // At tight tolerances (grad_tol < kTightGradTol) region steps stop for the rest of the solve after two
  // in a row that leave most of the residual: the residual is then spread thin over many small regions,
  // where steps on one region at a time make slow progress and global steps converge (the arm, fully
  // reinforced, cold, to 1e-8: no convergence in 2000 iterations with region steps throughout, 164 with
  // the rule). At the design loop's tolerances the rule costs more global factorizations than it saves
  // (docs/ACCURACY.md), so it stays off there.
  bool local_allowed = true;
  int local_failures_in_row = 0;
  Positions trial;
  Eigen::VectorXd g_trial_full;
  // The last line-search trial's energy; with trial_derivatives, g_trial_full, nt.H_trial and
  // trial_energies hold its gradient, Hessian and breakdown.
  double E_new = 0;
  bool trial_derivatives = false;
  EnergyBreakdown trial_energies;
  // Cut steps that no longer lower the energy beyond round-off, in a row. On a C0 energy (the authors'
  // relaxation) Newton ends up straddling the gradient jump: the residual cannot fall, the energy has
  // converged, and without this count the solve would spend its whole iteration budget there.
  int stalled_steps = 0;
  static constexpr int kStallSteps = 8;
  // The current iteration: its damping, how its step was found, and the line search's step length.
  double delta = 0, alpha = 1.0;
  double model_ratio = 0;  // the accepted step's energy change over its quadratic model's (progress report only)
  bool fresh_factor = false, used_pcg = false, used_local = false;

  // Evaluates at the start; false when the solve ends there (rep says how).
  bool Start() {
    rep.energy_c0 = sys.model().effects.relaxation == Relaxation::kAuthors;
    rep.factor_nonzeros = nt.cholesky.factor_nonzeros();
    rep.tolerance_N = settings.grad_tol * sys.force_scale_N() * std::sqrt(std::max(1.0, n / 3.0));
    sys.ApplyClampsSmoothly(x);
    const auto t = Clock::now();
    E = sys.EvaluateFrom(nt.record, &g_full, &nt.H, *x, &g_full, &nt.H, &rep.energies, &nt.record);
    rep.assembly_s += Seconds(t, Clock::now());
    ++rep.energy_evaluations;
    if (!std::isfinite(E)) {
      rep.status = SolveStatus::kInvalidState;
      rep.message = "energy is not finite at the initial state: " + sys.DescribeNonFiniteEnergy(*x);
      rep.energy_J = E;
      return false;
    }
    if (n == 0) {
      rep.status = SolveStatus::kConverged;
      rep.energy_J = E;
      return false;
    }
    g = GatherFree(g_full, free_index, n);
    g0 = g.norm();
    mu = nt.mu > 0 ? nt.mu : 1e-4 * k_ref;
    pcg_allowed = nt.pcg_failures_in_row < 2;
    if (!pcg_allowed && ++nt.solves_since_probe >= 8) {
      pcg_allowed = true;
      nt.solves_since_probe = 0;
    }
    return true;
  }

  // Converged, stalled or out of iterations at iteration `it` (rep says which).
  bool Finished(int it) {
    rep.iterations = it;
    rep.energy_J = E;
    rep.grad_norm_N = g.norm();
    if (rep.grad_norm_N <= rep.tolerance_N) {
      rep.status = SolveStatus::kConverged;
      return true;
    }
    if (stalled_steps >= kStallSteps) {
      rep.status = SolveStatus::kStalled;
      char buf[320];
      std::snprintf(buf, sizeof buf,
                    "%d cut steps in a row lowered the energy (%.12g J) by less than round-off, residual %.3g N "
                    "above the tolerance %.3g N; a minimum on a gradient jump (relaxation \"authors\") or a tolerance "
                    "below what double precision resolves",
                    kStallSteps, E, rep.grad_norm_N, rep.tolerance_N);
      rep.message = buf;
      return true;
    }
    if (it >= max_it) {
      rep.status = SolveStatus::kIterationLimit;
      rep.message = "no convergence in " + std::to_string(max_it) + " Newton iterations";
      return true;
    }
    return false;
  }

  // Conjugate gradients preconditioned by this solve's last factorization. Not for a solve's first step:
  // the caller's change (a design flip turns faces' stiffness 11x) makes the last solve's factorization
  // a poor preconditioner, and on smooth scenes one fresh factorization and PCG on it for the later
  // steps beat PCG from the old one.
  bool PcgStep(int it, int attempt, Eigen::VectorXd* p) {
    if (!(settings.reuse_factorization && pcg_allowed && nt.have_factor && !fresh_factor && attempt == 0 && !skip_pcg && it > 0))
      return false;
    const auto t = Clock::now();
    const double eta = std::min(0.1, std::sqrt(rep.grad_norm_N / std::max(g0, 1e-300)));
    Eigen::VectorXd rvec = -g, z = nt.cholesky.Solve(rvec), d = z, Ad;
    *p = Eigen::VectorXd::Zero(n);
    double rz = rvec.dot(z);
    const double target = eta * rep.grad_norm_N;
    bool have_step = false;
    int k = 0;
    for (; k < settings.max_pcg_iterations; ++k) {
      Ad = nt.H.selfadjointView<Eigen::Upper>() * d + delta * d;
      const double dAd = d.dot(Ad);
      if (!(dAd > 0)) break;
      const double a = rz / dAd;
      *p += a * d;
      rvec -= a * Ad;
      if (rvec.norm() <= target) { have_step = true; ++k; break; }
      z = nt.cholesky.Solve(rvec);
      const double rz_new = rvec.dot(z);
      d = z + (rz_new / rz) * d;
      rz = rz_new;
    }
    rep.pcg_iterations += k;
    rep.solve_s += Seconds(t, Clock::now());
    if (have_step) ++rep.pcg_solves;
    used_pcg = have_step;
    // PCG pays off while the Hessian stays close to the factorized one (warm re-solves, the last
    // Newton iterations). Once it fails, the Hessian is moving: factorize for the rest of this solve.
    skip_pcg = !have_step;
    nt.pcg_failures_in_row = have_step ? 0 : nt.pcg_failures_in_row + 1;
    if (nt.pcg_failures_in_row >= 2) pcg_allowed = false;
    return have_step;
  }

  // A step on the region that holds the residual. Not for a solve's first step: that one meets whatever
  // the caller changed (a new design, a new pose), which moves the whole garment.
  bool RegionStep(int it, int attempt, Eigen::VectorXd* p) {
    if (!(settings.local_steps && local_allowed && attempt == 0 && it > 0)) return false;
    const auto t = Clock::now();
    used_local = LocalStep(nt.H, g, delta, nt.vertex_of, p);
    rep.solve_s += Seconds(t, Clock::now());
    return used_local;
  }

  // A fresh factorization of H + delta I (raising delta until CHOLMOD succeeds) and its step; false
  // when even the largest damping fails (rep says so).
  bool FactorizedStep(Eigen::VectorXd* p) {
    auto t = Clock::now();
    if (!nt.cholesky.analyzed()) {
      nt.cholesky.Analyze(nt.H);
      rep.factor_nonzeros = nt.cholesky.factor_nonzeros();
    }
    bool ok = false;
    for (int tries = 0; tries < 12; ++tries) {
      ++rep.factorizations;
      if (nt.cholesky.Factorize(nt.H, delta)) { ok = true; break; }
      delta *= 10.0;
    }
    rep.factorization_s += Seconds(t, Clock::now());
    if (!ok) {
      nt.have_factor = false;
      rep.status = SolveStatus::kNotPositiveDefinite;
      rep.message = "Hessian not positive definite even with regularization " + std::to_string(delta) + " N/m";
      return false;
    }
    nt.have_factor = true;
    fresh_factor = true;
    t = Clock::now();
    *p = nt.cholesky.Solve(-g);
    rep.solve_s += Seconds(t, Clock::now());
    return true;
  }

  // Backtracking Armijo line search on the total energy along `p` (slope g.p < 0); true when a trial
  // was accepted (then `trial`, E_new and alpha are its).
  bool LineSearch(const Eigen::VectorXd& p, double slope) {
    const auto t = Clock::now();
    double derivatives_s = 0;  // of the line search's time, the evaluation of a trial's gradient and Hessian
    bool accepted = false;
    AddFree(p, 1.0, free_index, *x, &trial);
    trial -= *x;
    alpha = sys.MaxSafeStep(*x, trial);
    for (int ls = 0; ls < 40; ++ls, alpha *= 0.5) {
      AddFree(p, alpha, free_index, *x, &trial);
      // nt.record is the evaluation at *x, with a gradient: it holds what the terms' projections need.
      if (project_crossings) sys.ProjectTrial(nt.record, &trial);
      // The first trial is nearly always taken (the fold-safe length, or a full step), and the next
      // iteration needs the gradient and Hessian there: evaluating them with the energy saves an
      // energy-only pass per iteration and costs one Hessian when the trial is refused.
      trial_derivatives = ls == 0;
      if (trial_derivatives) {
        const auto ta = Clock::now();
        E_new = sys.EvaluateFrom(nt.record, &g_full, &nt.H, trial, &g_trial_full, &nt.H_trial, &trial_energies, &nt.record_trial);
        derivatives_s += Seconds(ta, Clock::now());
      } else {
        E_new = sys.EvaluateFrom(nt.record, nullptr, nullptr, trial, nullptr, nullptr);
      }
      ++rep.energy_evaluations;
      if (E_new <= E + 1e-4 * alpha * slope) { accepted = true; break; }
      // Near the solution energy differences drown in round-off; a full step that does not raise E
      // beyond round-off is still taken when it reduces the residual.
      if (ls == 0 && std::isfinite(E_new) && E_new - E <= 1e-12 * std::abs(E) &&
          GatherFree(g_trial_full, free_index, n).norm() < rep.grad_norm_N) {
        accepted = true;
        break;
      }
    }
    rep.line_search_s += Seconds(t, Clock::now()) - derivatives_s;
    rep.assembly_s += derivatives_s;
    return accepted;
  }

  // Finds and takes one step from iteration `it`'s state: PCG, a region step or a factorization, each
  // line-searched; refused steps retry with more damping. False when no step was found (rep says why).
  bool Step(int it) {
    delta = std::max(mu, 1e-12 * k_ref);
    bool accepted = false;
    fresh_factor = used_pcg = used_local = false;
    alpha = 1.0;
    for (int attempt = 0; attempt < 8 && !accepted; ++attempt) {
      Eigen::VectorXd p;
      if (!PcgStep(it, attempt, &p) && !RegionStep(it, attempt, &p) && !FactorizedStep(&p)) return false;
      const double slope = g.dot(p);
      if (!(slope < 0) || !p.allFinite()) {
        if (used_local) {
          used_local = false;
          continue;
        }
        delta *= 100.0;
        fresh_factor = false;
        nt.have_factor = false;
        continue;
      }
      accepted = LineSearch(p, slope);
      if (accepted && settings.on_iteration && settings.diagnose_steps) {
        // The step's quadratic model g.s + s.H.s / 2 (H as factorized, without the damping) against
        // the energy's actual change: the trust-region ratio, for the progress report.
        const double pHp = p.dot(nt.H.selfadjointView<Eigen::Upper>() * p);
        const double predicted = alpha * slope + 0.5 * alpha * alpha * pHp;
        model_ratio = predicted < 0 ? (E_new - E) / predicted : std::numeric_limits<double>::quiet_NaN();
      }
      if (!accepted && used_local) {
        used_local = false;  // the global step next, at the same regularization
        continue;
      }
      if (!accepted) {
        // Retry with a fresh factorization and a larger regularization (a shorter, more gradient-like step).
        if (fresh_factor) delta *= 100.0;
        fresh_factor = false;
        nt.have_factor = false;
      }
    }
    if (!accepted) {
      rep.status = SolveStatus::kLineSearchFailed;
      rep.message = "line search found no energy decrease; residual " + std::to_string(rep.grad_norm_N) + " N";
      return false;
    }
    UpdateDamping();
    Accept(it);
    return true;
  }

  void UpdateDamping() {
    if (alpha == 1.0) {
      mu = std::max(delta / 4.0, 1e-12 * k_ref);
      mu_full_max = std::max(mu_full_max, delta);
      nt.mu = mu_full_max;
    } else if (alpha < 0.25) {
      mu = std::min(delta * 8.0, 1e3 * k_ref);
    } else {
      mu = delta;
    }
  }

  // Moves to the accepted trial, with its gradient and Hessian (evaluated there now if the line search
  // did not).
  void Accept(int it) {
    x->swap(trial);
    const double E_before = E;
    // The energies per element before the step, for the switch counts of the progress report: the
    // record at the old state is swapped aside below, or overwritten when the trial had no derivatives.
    std::vector<std::vector<double>> energies_before;
    if (settings.on_iteration && settings.diagnose_steps && !trial_derivatives) energies_before = nt.record.energy_J;
    if (trial_derivatives) {
      E = E_new;
      g_full.swap(g_trial_full);
      nt.H.swap(nt.H_trial);
      std::swap(nt.record, nt.record_trial);
      rep.energies = trial_energies;
    } else {
      const auto t = Clock::now();
      E = sys.EvaluateFrom(nt.record, &g_full, &nt.H, *x, &g_full, &nt.H, &rep.energies, &nt.record);
      rep.assembly_s += Seconds(t, Clock::now());
      ++rep.energy_evaluations;
    }
    const double g_before = g.norm();
    g = GatherFree(g_full, free_index, n);
    if (used_local) {
      ++rep.local_steps;
      // The region held 99 % of the squared residual: a step that solved it leaves a tenth of the norm.
      local_failures_in_row = g.norm() > 0.5 * g_before ? local_failures_in_row + 1 : 0;
      if (local_failures_in_row >= 2 && settings.grad_tol < kTightGradTol) local_allowed = false;
    }
    if (settings.on_iteration) {
      IterationInfo info{it + 1, E, g.norm(), alpha, delta, used_pcg, used_local, {}};
      if (settings.diagnose_steps)
        info.diagnostics = {model_ratio, SwitchedElements(trial_derivatives ? nt.record_trial.energy_J : energies_before, nt.record.energy_J),
                            &sys.term_names()};
      settings.on_iteration(info);
    }
    stalled_steps = (alpha < 1.0 && E_before - E <= 1e-12 * std::abs(E_before)) ? stalled_steps + 1 : 0;
  }
};

SolveReport Simulator::SolveNewton(Positions* x, const SolverSettings& settings) {
  NewtonSolve solve(*system_, *newton_, settings, x);
  if (!solve.Start()) return solve.rep;
  for (int it = 0; !solve.Finished(it) && solve.Step(it); ++it) {
  }
  return solve.rep;
}

void AccumulateSolve(SolveReport* total, const SolveReport& later) {
  SolveReport sum = later;
  sum.iterations += total->iterations;
  sum.seconds += total->seconds;
  sum.assembly_s += total->assembly_s;
  sum.factorization_s += total->factorization_s;
  sum.solve_s += total->solve_s;
  sum.line_search_s += total->line_search_s;
  sum.factorizations += total->factorizations;
  sum.pcg_solves += total->pcg_solves;
  sum.pcg_iterations += total->pcg_iterations;
  sum.local_steps += total->local_steps;
  sum.energy_evaluations += total->energy_evaluations;
  sum.body_field_query_s += total->body_field_query_s;
  for (const GarmentSystem::TermTime& t : total->term_times) {
    auto same = std::find_if(sum.term_times.begin(), sum.term_times.end(),
                             [&](const GarmentSystem::TermTime& u) { return std::string_view(u.name) == t.name; });
    if (same == sum.term_times.end()) {
      sum.term_times.push_back(t);
    } else {
      same->seconds += t.seconds;
      same->elements += t.elements;
    }
  }
  *total = sum;
}

SolveReport SolveLagged(Simulator& sim, GarmentSystem& system, Positions* x, const SolverSettings& settings) {
  if (!system.lagged()) return sim.Solve(x, settings);
  SolveReport total;
  for (int pass = 0; pass < 2; ++pass) {
    system.Lag(*x);
    AccumulateSolve(&total, sim.Solve(x, settings));
    if (!total.at_equilibrium()) break;
  }
  return total;
}

}  // namespace kgd
