#include "core/fabrication/sew_line.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

namespace kgd {
namespace {

using Point = Eigen::Vector2d;
constexpr double kInf = std::numeric_limits<double>::infinity();

// The turn (radians, absolute) at b between the segments a -> b and b -> c.
double Turn(const Point& a, const Point& b, const Point& c) {
  const Point u = b - a, v = c - b;
  return std::abs(std::atan2(u.x() * v.y() - u.y() * v.x(), u.dot(v)));
}

Point Row(const FlatPositions& p, Eigen::Index i) { return p.row(i).transpose(); }

// Arc length at every vertex of `p`, from its first; closed: one entry more, the whole loop's length.
std::vector<double> ArcLengths(const FlatPositions& p, bool closed) {
  const int n = static_cast<int>(p.rows());
  const int segments = closed ? n : n - 1;
  std::vector<double> s(segments + 1, 0);
  for (int j = 0; j < segments; ++j) s[j + 1] = s[j] + (p.row((j + 1) % n) - p.row(j)).norm();
  return s;
}

double Length(const FlatPositions& p) {
  double l = 0;
  for (Eigen::Index i = 0; i + 1 < p.rows(); ++i) l += (p.row(i + 1) - p.row(i)).norm();
  return l;
}

// `p` at `steps` equal steps of arc length `s` (ArcLengths): steps + 1 points with both ends exact
// (open), or `steps` points from the first vertex around (closed).
FlatPositions Resample(const FlatPositions& p, const std::vector<double>& s, bool closed, int steps) {
  const int n = static_cast<int>(p.rows()), segments = static_cast<int>(s.size()) - 1;
  const int count = closed ? steps : steps + 1;
  FlatPositions out(count, 2);
  int j = 0;
  for (int k = 0; k < count; ++k) {
    const double t = s.back() * k / steps;
    while (j < segments - 1 && s[j + 1] < t) ++j;
    const double length = s[j + 1] - s[j];
    const double f = length > 0 ? std::clamp((t - s[j]) / length, 0.0, 1.0) : 0;
    out.row(k) = (1 - f) * p.row(j) + f * p.row((j + 1) % n);
  }
  if (!closed) out.row(count - 1) = p.row(n - 1);
  return out;
}

// The smoothing spline of points p: the q minimizing sum_i w_i |q_i - p_i|^2 + sum_c alpha_c
// |q_(c-1) - 2 q_c + q_(c+1)|^2; open: the two ends kept and second differences at the inner points only;
// closed: around the loop. Factorized once for many p.
class Spline {
 public:
  Spline(int n, bool closed, const Eigen::VectorXd& w, const Eigen::VectorXd& alpha) : n_(n), unknown_(n) {
    int m = 0;
    for (int i = 0; i < n; ++i) unknown_[i] = !closed && (i == 0 || i == n - 1) ? -1 : m++;
    m_ = m;
    if (m == 0) return;
    std::vector<Eigen::Triplet<double>> triplets;
    w_ = w;
    for (int i = 0; i < n; ++i)
      if (unknown_[i] >= 0) triplets.push_back({unknown_[i], unknown_[i], w[i]});
    const double coefficient[3] = {1, -2, 1};
    for (int c = closed ? 0 : 1; c < (closed ? n : n - 1); ++c) {
      const int stencil[3] = {(c + n - 1) % n, c, (c + 1) % n};
      for (int a = 0; a < 3; ++a) {
        const int ua = unknown_[stencil[a]];
        if (ua < 0) continue;
        for (int b = 0; b < 3; ++b) {
          const double v = alpha[c] * coefficient[a] * coefficient[b];
          if (unknown_[stencil[b]] >= 0) triplets.push_back({ua, unknown_[stencil[b]], v});
          else fixed_.push_back({ua, stencil[b], v});
        }
      }
    }
    Eigen::SparseMatrix<double> A(m, m);
    A.setFromTriplets(triplets.begin(), triplets.end());
    solver_.compute(A);
    ok_ = solver_.info() == Eigen::Success;
  }

  // The spline of `p` (n points; open: its ends kept).
  FlatPositions operator()(const FlatPositions& p) const {
    if (m_ == 0 || !ok_) return p;
    Eigen::MatrixX2d rhs = Eigen::MatrixX2d::Zero(m_, 2);
    for (int i = 0; i < n_; ++i)
      if (unknown_[i] >= 0) rhs.row(unknown_[i]) += w_[i] * p.row(i);
    for (const Fixed& f : fixed_) rhs.row(f.row) -= f.value * p.row(f.point);
    const Eigen::MatrixX2d x = solver_.solve(rhs);
    if (!x.allFinite()) return p;
    FlatPositions out = p;
    for (int i = 0; i < n_; ++i)
      if (unknown_[i] >= 0) out.row(i) = x.row(unknown_[i]);
    return out;
  }

 private:
  struct Fixed {
    int row, point;
    double value;
  };
  int n_, m_ = 0;
  std::vector<int> unknown_;
  Eigen::VectorXd w_;
  std::vector<Fixed> fixed_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver_;
  bool ok_ = false;
};

double Deviation(const FlatPositions& q, const FlatPositions& outline, const Eigen::VectorXd& scale, bool closed) {
  double worst = 0;
  for (Eigen::Index i = 0; i < q.rows(); ++i) worst = std::max(worst, BodyDistance(Row(q, i), outline, scale, closed));
  return worst;
}

using EdgeKey = std::pair<int, int>;
EdgeKey Key(int a, int b) { return a < b ? EdgeKey{a, b} : EdgeKey{b, a}; }

// The smallest singular value of each face's map from its rest triangle to its flat one: a flat
// distance d is at most d / this on the body (to first order).
Eigen::VectorXd SmallestStretch(const PatternPiece& piece) {
  Eigen::VectorXd s = Eigen::VectorXd::Ones(piece.faces.rows());
  for (Eigen::Index f = 0; f < piece.faces.rows(); ++f) {
    const Eigen::Vector3d a = piece.rest.row(piece.faces(f, 0)), b = piece.rest.row(piece.faces(f, 1)), c = piece.rest.row(piece.faces(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    if (!(n.norm() > 0)) continue;
    const Eigen::Vector3d e1 = (b - a).normalized(), e2 = n.cross(b - a).normalized();
    Eigen::Matrix2d rest, flat;
    rest << (b - a).norm(), (c - a).dot(e1), 0, (c - a).dot(e2);
    flat.col(0) = (piece.flat.row(piece.faces(f, 1)) - piece.flat.row(piece.faces(f, 0))).transpose();
    flat.col(1) = (piece.flat.row(piece.faces(f, 2)) - piece.flat.row(piece.faces(f, 0))).transpose();
    const Eigen::Matrix2d J = flat * rest.inverse();
    const double smallest = Eigen::JacobiSVD<Eigen::Matrix2d>(J).singularValues()(1);
    if (smallest > 0 && std::isfinite(smallest)) s[f] = smallest;
  }
  return s;
}

}  // namespace

double MaxTurningDeg(const FlatPositions& closed, const std::vector<int>& corners) {
  const int n = static_cast<int>(closed.rows());
  if (n < 3) return 0;
  std::vector<char> corner(n, 0);
  for (int c : corners)
    if (c >= 0 && c < n) corner[c] = 1;
  double worst = 0;
  for (int i = 0; i < n; ++i)
    if (!corner[i]) worst = std::max(worst, Turn(Row(closed, (i + n - 1) % n), Row(closed, i), Row(closed, (i + 1) % n)));
  return worst * 180 / M_PI;
}

double BodyDistance(const Eigen::Vector2d& q, const FlatPositions& p, const Eigen::VectorXd& scale, bool closed) {
  const int n = static_cast<int>(p.rows());
  if (n == 0) return kInf;
  if (n == 1) return (q - Row(p, 0)).norm() / (scale.size() ? scale[0] : 1.0);
  const int segments = closed ? n : n - 1;
  double best = kInf;
  for (int j = 0; j < segments; ++j) {
    const Point a = Row(p, j), b = Row(p, (j + 1) % n), ab = b - a;
    const double l2 = ab.squaredNorm();
    const double t = l2 > 0 ? std::clamp((q - a).dot(ab) / l2, 0.0, 1.0) : 0;
    best = std::min(best, (q - a - t * ab).norm() / (j < scale.size() ? scale[j] : 1.0));
  }
  return best;
}

FairedSpan FairSpan(const std::vector<FlatPositions>& sides, const std::vector<Eigen::VectorXd>& scale, bool closed, const SewLineOptions& o) {
  FairedSpan out;
  out.sides = sides;
  const int ns = static_cast<int>(sides.size());
  if (ns == 0) return out;
  const int nv = static_cast<int>(sides[0].rows());
  bool same = true;
  for (const FlatPositions& s : sides) same = same && s.rows() == nv;
  out.deviation_m.assign(ns, 0);
  out.at.resize(std::max(nv, 0));
  for (int k = 0; k < nv; ++k) out.at[k] = k;
  out.points = closed ? nv : nv - 1;
  if (!same || nv < 2 || (closed && (ns != 1 || nv < 3))) return out;
  std::vector<Eigen::VectorXd> scales(ns);
  for (int s = 0; s < ns && s < static_cast<int>(scale.size()); ++s) scales[s] = scale[s];
  auto scale_of = [&](int s) -> const Eigen::VectorXd& { return scales[s]; };

  std::vector<std::vector<double>> arc;
  double length = 0;
  for (const FlatPositions& s : sides) arc.push_back(ArcLengths(s, closed)), length += arc.back().back();
  length /= ns;
  if (!(length > 0)) return out;
  const int steps = std::max(closed ? 3 : 1, static_cast<int>(std::ceil(length / o.spacing_m - 1e-9)));
  out.points = steps;
  for (int k = 0; k < nv; ++k) {
    double fraction = 0;
    for (int s = 0; s < ns; ++s) fraction += arc[s].back() > 0 ? arc[s][k] / arc[s].back() : 0;
    out.at[k] = static_cast<int>(std::lround(fraction / ns * steps));
    if (closed) out.at[k] %= steps;
  }
  if (!closed) out.at.front() = 0, out.at.back() = steps;
  std::vector<FlatPositions> p;
  for (int s = 0; s < ns; ++s) p.push_back(Resample(sides[s], arc[s], closed, steps));
  out.sides = p;  // on the outline: within any tolerance, whatever the fairing finds
  const int n = static_cast<int>(p[0].rows());
  if (n < 5) return out;

  const double h = length / steps;
  const double alpha0 = std::pow(o.smoothing_m / h, 4);
  const double target_turn = o.target_turn_deg * M_PI / 180;
  // Each point's candidate segments on its side: those within `reach` of its arc length.
  const double reach = 0.01 + 4 * h;
  std::vector<std::vector<std::vector<int>>> candidates(ns, std::vector<std::vector<int>>(n));
  for (int s = 0; s < ns; ++s) {
    const std::vector<double>& a = arc[s];
    const int segments = static_cast<int>(a.size()) - 1;
    for (int i = 0; i < n; ++i) {
      const double t = a.back() * i / steps;
      for (int j = 0; j < segments; ++j)
        for (const double shift : closed ? std::vector<double>{-a.back(), 0.0, a.back()} : std::vector<double>{0.0})
          if (a[j + 1] + shift >= t - reach && a[j] + shift <= t + reach) {
            candidates[s][i].push_back(j);
            break;
          }
    }
  }
  // The nearest point to v within the tolerance of side s's outline near point i (v itself if it is).
  auto admissible = [&](int s, int i, const Point& v, double limit) -> Point {
    const FlatPositions& P = sides[s];
    const int np = static_cast<int>(P.rows());
    double best = kInf;
    Point out = v;
    for (const int j : candidates[s][i]) {
      const Point a = Row(P, j), b = Row(P, (j + 1) % np), ab = b - a;
      const double l2 = ab.squaredNorm();
      const double t = l2 > 0 ? std::clamp((v - a).dot(ab) / l2, 0.0, 1.0) : 0;
      const Point c = a + t * ab;
      const double room = limit * (j < scales[s].size() ? scales[s][j] : 1.0), d = (v - c).norm();
      if (d <= room) return v;
      if (d - room < best) best = d - room, out = c + (v - c) * (room / d);
    }
    return out;
  };
  auto turns = [&](const std::vector<FlatPositions>& q) {
    Eigen::VectorXd t = Eigen::VectorXd::Zero(n);
    for (const FlatPositions& side : q)
      for (int i = closed ? 0 : 1; i < (closed ? n : n - 1); ++i)
        t[i] = std::max(t[i], Turn(Row(side, (i + n - 1) % n), Row(side, i), Row(side, (i + 1) % n)));
    return t;
  };
  // The smoothing spline of side s, reweighted: where a point strays beyond `fit` times the tolerance,
  // its target becomes the nearest place within it and its weight grows by `growth`; where the curve
  // turns more than the target, the stiffness there rises (Lawson). Fast growth pins a point where it
  // first strayed, slow growth lets the curve find its way around a bend of the outline: each growth of
  // the options is tried and the fit of the smallest largest turn kept. The resampled outline if no fit
  // is within the tolerance.
  auto fair_with = [&](int s, double fit, double growth, double* best_turn) {
    const double limit = fit * o.tolerance_m;
    Eigen::VectorXd w = Eigen::VectorXd::Ones(n), alpha = Eigen::VectorXd::Constant(n, alpha0);
    FlatPositions target = p[s], q = p[s], best = p[s];
    *best_turn = kInf;
    for (int outer = 0; outer < o.iterations; ++outer) {
      q = Spline(n, closed, w, alpha)(target);
      for (int i = 0; i < n; ++i) {
        const Point a = admissible(s, i, Row(q, i), limit);
        if ((a - Row(q, i)).norm() > 0) w[i] *= growth, target.row(i) = a.transpose();
      }
      const bool within = Deviation(q, sides[s], scales[s], closed) <= o.tolerance_m * (1 + fit) / 2;
      const Eigen::VectorXd t = turns({q});
      if (within && t.maxCoeff() < *best_turn) best = q, *best_turn = t.maxCoeff();
      if (within && t.maxCoeff() <= target_turn) break;
      for (int i = 0; i < n; ++i) alpha[i] = std::clamp(alpha[i] * std::clamp(t[i] / target_turn, 0.5, 4.0), alpha0, 1e3 * alpha0);
    }
    return best;
  };
  auto fair = [&](int s, double fit) {
    FlatPositions best = p[s];
    double best_turn = kInf;
    for (const double growth : o.weight_growth) {
      double turn = kInf;
      FlatPositions q = fair_with(s, fit, growth, &turn);
      if (turn < best_turn) best = std::move(q), best_turn = turn;
      if (best_turn <= target_turn) break;
    }
    return best;
  };
  std::vector<FlatPositions> best;
  for (int s = 0; s < ns; ++s) best.push_back(fair(s, o.fit_tolerance));
  if (ns == 2 && !closed) {
    // The two sides of a seam have different shapes in the plane (each flattened with its own piece), so
    // faired alike they come out of different lengths: the shorter is faired again within a narrower
    // tolerance (bisection on it, down to half), which leaves it more of its outline's length.
    const int shorter = Length(best[0]) < Length(best[1]) ? 0 : 1;
    const double goal = Length(best[1 - shorter]);
    double lo = 0.5 * o.fit_tolerance, hi = o.fit_tolerance;
    FlatPositions narrow = fair(shorter, lo);
    if (Length(narrow) >= goal) {
      for (int k = 0; k < 8; ++k) {
        const double mid = 0.5 * (lo + hi);
        FlatPositions q = fair(shorter, mid);
        if (Length(q) >= goal) lo = mid, narrow = std::move(q);
        else hi = mid;
      }
    }
    best[shorter] = narrow;
  }

  // The two sides of a seam to one length: each side's wiggle about a spline four times as long in
  // scale (unweighted, its ends kept) scaled by the factor that gives the mean length (the secant
  // method from 1); kept only if every point stays within the tolerance.
  if (ns == 2 && !closed) {
    const double mean = 0.5 * (Length(best[0]) + Length(best[1]));
    std::vector<FlatPositions> even = best;
    bool ok = true;
    for (int s = 0; s < 2 && ok; ++s) {
      const FlatPositions line = Spline(n, false, Eigen::VectorXd::Ones(n), Eigen::VectorXd::Constant(n, 256 * alpha0))(p[s]);
      const FlatPositions wiggle = best[s] - line;
      auto excess = [&](double t) { return Length(line + t * wiggle) - mean; };
      double t0 = 1, f0 = excess(t0), t1 = 1.001, f1 = excess(t1);
      for (int k = 0; k < 30 && std::abs(f1) > 1e-12; ++k) {
        if (f1 == f0) break;
        const double t2 = t1 - f1 * (t1 - t0) / (f1 - f0);
        t0 = t1, f0 = f1, t1 = t2, f1 = excess(t1);
      }
      ok = std::abs(f1) <= 1e-9 && t1 > 0.5 && t1 < 1.5;
      if (ok) even[s] = line + t1 * wiggle;
      ok = ok && Deviation(even[s], sides[s], scale_of(s), false) <= o.tolerance_m;
    }
    if (ok) best = even;
  }
  out.sides = best;
  for (int s = 0; s < ns; ++s) out.deviation_m[s] = Deviation(best[s], sides[s], scale_of(s), closed);
  return out;
}

void FairSewLines(Pattern* pattern, const SewLineOptions& o) {
  // Seam edges (garment vertex pairs) and the seams' ends.
  std::map<EdgeKey, int> seam_of;
  std::set<int> ends;
  for (size_t s = 0; s < pattern->seams.size(); ++s) {
    const std::vector<int>& v = pattern->seams[s].vertices;
    if (v.empty()) continue;
    for (size_t i = 0; i + 1 < v.size(); ++i) seam_of[Key(v[i], v[i + 1])] = static_cast<int>(s);
    ends.insert(v.front()), ends.insert(v.back());
  }
  // A span: outline positions first .. first + count - 1 (around), between two corners, or a whole
  // loop with none (closed).
  struct Span {
    int piece, first, count;
    bool closed;
    int seam;  // -1: a free edge of the garment
    FlatPositions points;
    Eigen::VectorXd scale;
    std::vector<int> garment;
    FairedSpan faired;  // with `side`: which of faired.sides is this span's
    int side = 0;
    bool reversed = false;
  };
  std::vector<Span> spans;
  std::vector<std::vector<int>> spans_of(pattern->pieces.size());
  for (size_t pi = 0; pi < pattern->pieces.size(); ++pi) {
    PatternPiece& piece = pattern->pieces[pi];
    const int K = static_cast<int>(piece.outline.size());
    piece.sew_line.resize(K, 2);
    for (int k = 0; k < K; ++k) piece.sew_line.row(k) = piece.flat.row(piece.outline[k]);
    piece.sew_at.resize(K);
    for (int k = 0; k < K; ++k) piece.sew_at[k] = k;
    piece.sew_corners.clear();
    if (K < 3) continue;
    std::vector<int> g(K);
    for (int k = 0; k < K; ++k) g[k] = piece.garment_vertex[piece.outline[k]];
    // Each outline edge's seam (or -1) and its face's smallest stretch.
    std::map<EdgeKey, int> face_of;
    for (Eigen::Index f = 0; f < piece.faces.rows(); ++f)
      for (int c = 0; c < 3; ++c) face_of[Key(piece.faces(f, c), piece.faces(f, (c + 1) % 3))] = static_cast<int>(f);
    const Eigen::VectorXd stretch = SmallestStretch(piece);
    std::vector<int> seam(K);
    Eigen::VectorXd scale(K);
    for (int k = 0; k < K; ++k) {
      const auto it = seam_of.find(Key(g[k], g[(k + 1) % K]));
      seam[k] = it == seam_of.end() ? -1 : it->second;
      const auto f = face_of.find(Key(piece.outline[k], piece.outline[(k + 1) % K]));
      scale[k] = f == face_of.end() ? 1.0 : stretch[f->second];
    }
    // Corners: seam ends, where one seam or free edge meets another, and on a free edge a sharp turn
    // between long straight runs (a flat sample's corner): at least 60 degrees, with no turn of a degree
    // within 5 % of the outline's length (at least 20 mm) on either side.
    const std::vector<double> arc = ArcLengths(piece.sew_line, true);
    const double window = std::max(0.02, 0.05 * arc.back());
    auto turn_at = [&](int k) { return Turn(Row(piece.sew_line, (k + K - 1) % K), Row(piece.sew_line, k), Row(piece.sew_line, (k + 1) % K)); };
    auto straight_around = [&](int k) {
      for (int dir : {-1, 1}) {
        double run = 0;
        for (int j = k, steps = 0; steps < K - 1; ++steps) {
          const int next = (j + dir + K) % K;
          run += (piece.sew_line.row(next) - piece.sew_line.row(j)).norm();
          if (run >= window) break;
          if (turn_at(next) > M_PI / 180) return false;
          j = next;
        }
      }
      return true;
    };
    std::vector<int> corners;
    for (int k = 0; k < K; ++k) {
      const int before = seam[(k + K - 1) % K], after = seam[k];
      if (ends.count(g[k]) || before != after || (before < 0 && turn_at(k) >= M_PI / 3 && straight_around(k))) corners.push_back(k);
    }
    auto add = [&](int first, int count, bool closed) {
      Span s{static_cast<int>(pi), first, count, closed, closed ? -1 : seam[first], FlatPositions(count, 2), Eigen::VectorXd(closed ? count : count - 1), {}, {}};
      for (int j = 0; j < count; ++j) {
        const int k = (first + j) % K;
        s.points.row(j) = piece.sew_line.row(k);
        s.garment.push_back(g[k]);
        if (j < s.scale.size()) s.scale[j] = scale[k];
      }
      spans_of[pi].push_back(static_cast<int>(spans.size()));
      spans.push_back(std::move(s));
    };
    if (corners.empty()) add(0, K, true);
    for (size_t c = 0; c < corners.size(); ++c) {
      const int first = corners[c], last = c + 1 < corners.size() ? corners[c + 1] : corners[0] + K;
      add(first, last - first + 1, false);
    }
  }

  // The two sides of every seam span, faired together: the same garment vertices, one side's order
  // reversed (pieces lie on either side of a seam) or not.
  std::map<EdgeKey, std::vector<int>> by_edge;
  for (size_t i = 0; i < spans.size(); ++i)
    if (spans[i].seam >= 0 && spans[i].count >= 2) {
      const std::vector<int>& g = spans[i].garment;
      by_edge[std::min(Key(g[0], g[1]), Key(g[g.size() - 2], g.back()))].push_back(static_cast<int>(i));
    }
  std::vector<char> done(spans.size(), 0);
  for (const auto& [edge, list] : by_edge) {
    if (list.size() != 2) continue;
    Span &a = spans[list[0]], &b = spans[list[1]];
    std::vector<int> reversed(b.garment.rbegin(), b.garment.rend());
    const bool rev = reversed == a.garment;
    if (!rev && b.garment != a.garment) continue;
    FlatPositions bp = rev ? FlatPositions(b.points.colwise().reverse()) : b.points;
    Eigen::VectorXd bs = rev ? Eigen::VectorXd(b.scale.reverse()) : b.scale;
    const FairedSpan f = FairSpan({a.points, bp}, {a.scale, bs}, false, o);
    a.faired = f, a.side = 0;
    b.faired = f, b.side = 1, b.reversed = rev;
    done[list[0]] = done[list[1]] = 1;
  }
  for (size_t i = 0; i < spans.size(); ++i)
    if (!done[i]) spans[i].faired = FairSpan({spans[i].points}, {spans[i].scale}, spans[i].closed, o);

  // Each piece's sew line: its spans' points in order, every span's last point the next one's first.
  for (size_t pi = 0; pi < pattern->pieces.size(); ++pi) {
    PatternPiece& piece = pattern->pieces[pi];
    const int K = static_cast<int>(piece.outline.size());
    if (spans_of[pi].empty()) {
      piece.sew_turning_max_deg = MaxTurningDeg(piece.sew_line);
      piece.sew_deviation_max_mm = 0;
      continue;
    }
    std::vector<Eigen::Vector2d> points;
    double deviation = 0;
    for (int si : spans_of[pi]) {
      const Span& s = spans[si];
      const FairedSpan& f = s.faired;
      const FlatPositions& side = f.sides[s.side];
      const int n = static_cast<int>(side.rows());
      const int offset = static_cast<int>(points.size());
      if (!s.closed) piece.sew_corners.push_back(offset);
      const int kept = s.closed ? n : n - 1;
      for (int i = 0; i < kept; ++i) points.push_back(Row(side, s.reversed ? n - 1 - i : i));
      for (int j = 0; j < s.count; ++j) {
        const int at = s.reversed ? f.points - f.at[s.count - 1 - j] : f.at[j];
        if (s.closed || j + 1 < s.count) piece.sew_at[(s.first + j) % K] = offset + at;
      }
      deviation = std::max(deviation, f.deviation_m[s.side]);
    }
    piece.sew_line.resize(points.size(), 2);
    for (size_t i = 0; i < points.size(); ++i) piece.sew_line.row(i) = points[i].transpose();
    piece.sew_turning_max_deg = MaxTurningDeg(piece.sew_line, piece.sew_corners);
    piece.sew_deviation_max_mm = 1000 * deviation;
  }
}

}  // namespace kgd
