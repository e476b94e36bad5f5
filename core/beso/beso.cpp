#include "core/beso/beso.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "core/sim/garment_system.h"

namespace kgd {

Status ValidateBesoSettings(const BesoSettings& s) {
  auto bad = [](const char* name, double v, const char* range) {
    char value[32];
    std::snprintf(value, sizeof value, "%.6g", v);
    return Status::Error(std::string("BESO setting ") + name + " = " + value + " must be " + range);
  };
  if (!(s.budget > 0 && s.budget <= 1)) return bad("budget", s.budget, "in (0, 1]");
  if (!(s.evolutionary_ratio > 0 && s.evolutionary_ratio < 1)) return bad("evolutionary_ratio (ER)", s.evolutionary_ratio, "in (0, 1)");
  if (!(s.admission_ratio > 0 && s.admission_ratio < 1)) return bad("admission_ratio (AR_max)", s.admission_ratio, "in (0, 1)");
  if (!(s.penalty >= 1 && std::isfinite(s.penalty))) return bad("penalty (p)", s.penalty, "finite and >= 1");
  if (!(s.d_min > 0 && s.d_min < 1)) return bad("d_min", s.d_min, "in (0, 1)");
  if (!(s.tau > 0 && std::isfinite(s.tau))) return bad("tau", s.tau, "finite and > 0");
  if (s.converge_window < 1) return bad("converge_window", s.converge_window, ">= 1");
  if (s.max_iterations < 1) return bad("max_iterations", s.max_iterations, ">= 1");
  if (!(s.resolve_tolerance_factor >= 1 && std::isfinite(s.resolve_tolerance_factor)))
    return bad("resolve_tolerance_factor", s.resolve_tolerance_factor, "finite and >= 1");
  if (!(s.max_pressure_Pa >= 0 && std::isfinite(s.max_pressure_Pa))) return bad("max_pressure_Pa", s.max_pressure_Pa, "finite and >= 0 (0: no limit)");
  return Status::Ok();
}

Eigen::VectorXd Sensitivities(const Eigen::VectorXd& w, const std::vector<uint8_t>& design, double e1, double e2, double d,
                              double p) {
  const double hard = 0.5 * (1.0 - e2 / e1);
  const double dp = std::pow(d, p);
  const double soft = 0.5 * std::pow(d, p - 1.0) * (e1 - e2) / (dp * e1 + (1.0 - dp) * e2);
  Eigen::VectorXd s(w.size());
  for (Eigen::Index e = 0; e < w.size(); ++e) s[e] = (design[e] == kReinforced ? hard : soft) * w[e];
  return s;
}

Eigen::VectorXd FilterSensitivities(const Eigen::VectorXd& values, const Faces& faces, int nv, const Eigen::VectorXd& area) {
  Eigen::VectorXd num = Eigen::VectorXd::Zero(nv), den = Eigen::VectorXd::Zero(nv);
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      num[faces(f, k)] += area[f] * values[f];
      den[faces(f, k)] += area[f];
    }
  Eigen::VectorXd out(faces.rows());
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    double sum = 0;
    for (int k = 0; k < 3; ++k) sum += num[faces(f, k)] / den[faces(f, k)];
    out[f] = sum / 3.0;
  }
  return out;
}

Eigen::VectorXd AverageSensitivities(const Eigen::VectorXd& current, const Eigen::VectorXd& previous) {
  if (previous.size() != current.size()) return current;
  return 0.5 * (current + previous);
}

double NextTargetArea(double current, double final_area, double er) {
  if (current > final_area) return std::max(final_area, current * (1.0 - er));
  return std::min(final_area, current * (1.0 + er));
}

std::vector<uint8_t> UpdateDesign(const Eigen::VectorXd& s, const Eigen::VectorXd& area, const std::vector<uint8_t>& design,
                                  double target, double max_admitted, const std::vector<uint8_t>* locked) {
  const int n = static_cast<int>(s.size());
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return s[a] > s[b]; });
  std::vector<uint8_t> out(n, kCloth);
  double total = 0;
  auto is_locked = [&](int e) { return locked && (*locked)[e]; };
  for (int e = 0; e < n; ++e)
    if (is_locked(e)) {
      out[e] = kReinforced;
      total += area[e];
    }
  // Take elements in rank order while the total stays nearest to the target.
  auto take = [&](int e) {
    if (out[e] == kReinforced || total + 0.5 * area[e] > target) return false;
    out[e] = kReinforced;
    total += area[e];
    return true;
  };
  // Admission of at most max_admitted of cloth area, best ranked first.
  std::vector<uint8_t> plain = out;
  double plain_total = total, admitted = 0;
  for (int e : order) {
    if (plain[e] == kReinforced || plain_total + 0.5 * area[e] > target) continue;
    plain[e] = kReinforced;
    plain_total += area[e];
    if (design[e] != kReinforced) admitted += area[e];
  }
  if (admitted <= max_admitted) return plain;
  double admitted_now = 0;
  for (int e : order)
    if (design[e] != kReinforced && !is_locked(e) && admitted_now + area[e] <= max_admitted && take(e)) admitted_now += area[e];
  for (int e : order)
    if (design[e] == kReinforced) take(e);
  return out;
}

bool BesoConverged(const std::vector<double>& objective, bool target_reached, double tau, int window) {
  if (!target_reached || static_cast<int>(objective.size()) < window + 1) return false;
  for (int i = 0; i < window; ++i) {
    const double a = objective[objective.size() - 1 - i], b = objective[objective.size() - 2 - i];
    if (std::abs(a - b) > tau * std::abs(a)) return false;
  }
  return true;
}

}  // namespace kgd
