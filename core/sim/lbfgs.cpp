// L-BFGS with a strong Wolfe line search for Simulator (see simulator.h): the paper's method, kept for
// comparison with projected Newton.
#include <cmath>
#include <deque>
#include <limits>

#include "core/sim/simulator.h"

namespace kgd {
namespace {

struct Objective {
  GarmentSystem* sys;
  const Positions* base;
  Positions x;
  Eigen::VectorXd g_full;
  int evaluations = 0;

  // E and free gradient at the free vector xf.
  double operator()(const Eigen::VectorXd& xf, Eigen::VectorXd* g) {
    x = *base;
    double* data = x.data();
    const auto& fi = sys->free_index();
    for (size_t d = 0; d < fi.size(); ++d)
      if (fi[d] >= 0) data[d] = xf[fi[d]];
    ++evaluations;
    const double E = sys->Evaluate(x, &g_full, nullptr);
    g->resize(xf.size());
    for (size_t d = 0; d < fi.size(); ++d)
      if (fi[d] >= 0) (*g)[fi[d]] = g_full[d];
    return E;
  }
};

// Cubic interpolation minimizer of phi on [a, b] from values and slopes; safeguarded into the middle 80 %.
double CubicStep(double a, double fa, double da, double b, double fb, double db) {
  const double lo = std::min(a, b), hi = std::max(a, b), w = hi - lo;
  double t = std::numeric_limits<double>::quiet_NaN();
  if (std::isfinite(fa) && std::isfinite(fb)) {
    const double d1 = da + db - 3.0 * (fa - fb) / (a - b);
    const double disc = d1 * d1 - da * db;
    if (disc >= 0) {
      const double d2 = std::copysign(std::sqrt(disc), b - a);
      t = b - (b - a) * (db + d2 - d1) / (db - da + 2.0 * d2);
    }
  }
  if (!std::isfinite(t)) t = 0.5 * (a + b);
  return std::clamp(t, lo + 0.1 * w, hi - 0.1 * w);
}

}  // namespace

SolveReport Simulator::SolveLbfgs(Positions* x, const SolverSettings& settings) {
  GarmentSystem& sys = *system_;
  const int n = sys.num_free_dofs();
  const int max_it = settings.max_iterations > 0 ? settings.max_iterations : 50000;
  SolveReport rep;
  rep.tolerance_N = settings.grad_tol * sys.force_scale_N() * std::sqrt(std::max(1.0, n / 3.0));
  sys.ApplyClampsSmoothly(x);
  Objective f{&sys, x, Positions(), Eigen::VectorXd()};
  Eigen::VectorXd xf(n);
  {
    const auto& fi = sys.free_index();
    const double* data = x->data();
    for (size_t d = 0; d < fi.size(); ++d)
      if (fi[d] >= 0) xf[fi[d]] = data[d];
  }
  Eigen::VectorXd g, g_new, x_new;
  double E = f(xf, &g);
  auto finish = [&](SolveStatus status, std::string message) {
    f(xf, &g);
    *x = f.x;
    sys.Evaluate(*x, nullptr, nullptr, &rep.energies);
    rep.status = status;
    rep.message = std::move(message);
    rep.energy_J = E;
    rep.grad_norm_N = g.norm();
    rep.energy_evaluations = f.evaluations;
    return rep;
  };
  if (!std::isfinite(E))
    return finish(SolveStatus::kInvalidState, "energy is not finite at the initial state: " + sys.DescribeNonFiniteEnergy(f.x));

  std::deque<Eigen::VectorXd> S, Y;
  std::deque<double> rho;
  const double c1 = 1e-4, c2 = 0.9;
  int resets = 0;
  for (int it = 0;; ++it) {
    rep.iterations = it;
    const double gn = g.norm();
    if (gn <= rep.tolerance_N) return finish(SolveStatus::kConverged, "");
    if (it >= max_it) return finish(SolveStatus::kIterationLimit, "no convergence in " + std::to_string(max_it) + " L-BFGS iterations");

    // Two-loop recursion.
    Eigen::VectorXd q = g;
    std::vector<double> alpha(S.size());
    for (int i = static_cast<int>(S.size()) - 1; i >= 0; --i) {
      alpha[i] = rho[i] * S[i].dot(q);
      q -= alpha[i] * Y[i];
    }
    double gamma;
    if (!S.empty()) gamma = S.back().dot(Y.back()) / Y.back().squaredNorm();
    else gamma = sys.mean_edge_length_m() * 1e-2 / std::max(g.cwiseAbs().maxCoeff(), 1e-300);  // first step: ~1 % of an edge
    q *= gamma;
    for (size_t i = 0; i < S.size(); ++i) {
      const double beta = rho[i] * Y[i].dot(q);
      q += (alpha[i] - beta) * S[i];
    }
    Eigen::VectorXd d = -q;
    double d0 = g.dot(d);
    if (!(d0 < 0)) {
      S.clear(); Y.clear(); rho.clear();
      d = -gamma * g;
      d0 = g.dot(d);
    }

    // Strong Wolfe line search (Nocedal & Wright, Algorithms 3.5 and 3.6).
    auto phi = [&](double a, double* slope) {
      x_new = xf + a * d;
      const double v = f(x_new, &g_new);
      *slope = std::isfinite(v) ? g_new.dot(d) : std::numeric_limits<double>::quiet_NaN();
      return v;
    };
    double a_prev = 0, f_prev = E, s_prev = d0, a = 1.0, found = -1;
    double f_found = 0;
    Eigen::VectorXd g_found;
    auto zoom = [&](double lo, double f_lo, double s_lo, double hi, double f_hi, double s_hi) {
      for (int k = 0; k < 30; ++k) {
        const double aj = CubicStep(lo, f_lo, s_lo, hi, f_hi, s_hi);
        double sj;
        const double fj = phi(aj, &sj);
        if (!(fj <= E + c1 * aj * d0) || fj >= f_lo) {
          hi = aj; f_hi = fj; s_hi = sj;
        } else {
          if (std::abs(sj) <= -c2 * d0) { found = aj; f_found = fj; g_found = g_new; return; }
          if (sj * (hi - lo) >= 0) { hi = lo; f_hi = f_lo; s_hi = s_lo; }
          lo = aj; f_lo = fj; s_lo = sj;
        }
      }
      // Sufficient decrease without curvature: still a usable step.
      if (lo > 0 && f_lo < E) { double s; f_found = phi(lo, &s); found = lo; g_found = g_new; }
    };
    for (int k = 0; k < 30 && found < 0; ++k) {
      double s;
      const double fa = phi(a, &s);
      if (!(fa <= E + c1 * a * d0) || (k > 0 && fa >= f_prev)) { zoom(a_prev, f_prev, s_prev, a, fa, s); break; }
      if (std::abs(s) <= -c2 * d0) { found = a; f_found = fa; g_found = g_new; break; }
      if (s >= 0) { zoom(a, fa, s, a_prev, f_prev, s_prev); break; }
      a_prev = a; f_prev = fa; s_prev = s;
      a *= 2.0;
    }
    if (found < 0) {
      if (!S.empty() && resets < 5) {  // forget the curvature pairs and try a steepest-descent step
        S.clear(); Y.clear(); rho.clear();
        ++resets;
        continue;
      }
      return finish(SolveStatus::kLineSearchFailed, "strong Wolfe line search failed; residual " + std::to_string(gn) + " N");
    }
    const Eigen::VectorXd s_vec = found * d;
    const Eigen::VectorXd y_vec = g_found - g;
    xf += s_vec;
    E = f_found;
    g = g_found;
    if (settings.on_iteration) settings.on_iteration({it + 1, E, g.norm(), found, 0, false, false, {}});
    const double sy = s_vec.dot(y_vec);
    if (sy > 1e-16 * s_vec.norm() * y_vec.norm()) {
      S.push_back(s_vec); Y.push_back(y_vec); rho.push_back(1.0 / sy);
      if (static_cast<int>(S.size()) > settings.lbfgs_history) { S.pop_front(); Y.pop_front(); rho.pop_front(); }
    }
  }
}

}  // namespace kgd
