// Sew lines: staircases of known shape faired within the tolerance and below 10 degrees of turn, their
// ends kept; the two sides of a seam brought to one length; the turning measure itself.
#include "core/fabrication/sew_line.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace kgd {
namespace {

// The plane distance from q to the polyline p (closed or open), computed here from scratch.
double Distance(const Eigen::Vector2d& q, const FlatPositions& p, bool closed) {
  double best = 1e300;
  const Eigen::Index segments = closed ? p.rows() : p.rows() - 1;
  for (Eigen::Index j = 0; j < segments; ++j) {
    const Eigen::Vector2d a = p.row(j), b = p.row((j + 1) % p.rows());
    const double t = std::clamp((q - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    best = std::min(best, (q - a - t * (b - a)).norm());
  }
  return best;
}

double Farthest(const FlatPositions& q, const FlatPositions& p, bool closed) {
  double worst = 0;
  for (Eigen::Index i = 0; i < q.rows(); ++i) worst = std::max(worst, Distance(q.row(i).transpose(), p, closed));
  return worst;
}

double Length(const FlatPositions& p) {
  double l = 0;
  for (Eigen::Index i = 0; i + 1 < p.rows(); ++i) l += (p.row(i + 1) - p.row(i)).norm();
  return l;
}

// The largest turn (degrees) at the inner points of an open polyline.
double InnerTurningDeg(const FlatPositions& p) {
  double worst = 0;
  for (Eigen::Index i = 1; i + 1 < p.rows(); ++i) {
    const Eigen::Vector2d u = p.row(i) - p.row(i - 1), v = p.row(i + 1) - p.row(i);
    worst = std::max(worst, std::abs(std::atan2(u.x() * v.y() - u.y() * v.x(), u.dot(v))));
  }
  return worst * 180 / M_PI;
}

TEST(SewLine, TheTurningAngleOfARegularPolygonIsItsExteriorAngleAndCornersAreLeftOut) {
  FlatPositions hexagon(6, 2);
  for (int i = 0; i < 6; ++i) hexagon.row(i) << std::cos(i * M_PI / 3), std::sin(i * M_PI / 3);
  EXPECT_NEAR(MaxTurningDeg(hexagon), 60, 1e-9);
  // A square with its top bent outward by 10 degrees each way at its middle: 90 at the lower corners,
  // 80 at the upper ones, 20 at the bend.
  FlatPositions square(5, 2);
  square << 0, 0, 1, 0, 1, 1, 0.5, 1 + 0.5 * std::tan(10 * M_PI / 180), 0, 1;
  EXPECT_NEAR(MaxTurningDeg(square), 90, 1e-9);
  EXPECT_NEAR(MaxTurningDeg(square, {0, 1}), 80, 1e-9);
  EXPECT_NEAR(MaxTurningDeg(square, {0, 1, 2, 4}), 20, 1e-9);
}

// A circle of radius 60 mm traced by the cells of a 3 mm grid whose centres lie inside it: a staircase
// turning by 90 degrees at every vertex, within 2.2 mm (a cell's half diagonal) of the circle. Faired
// as one closed span (no corners): every point within 1 mm of the staircase, turning less than 10
// degrees between consecutive points about a millimetre apart, so within 3.2 mm of the circle.
TEST(SewLine, AStaircaseCircleIsFairedWithinAMillimetreAndTurnsLessThanTenDegrees) {
  const double r = 0.06, c = 0.003;
  // Column i (x from i c to (i + 1) c) holds the cells j with |(j + 0.5) c| < its half chord at the
  // column's middle: from -h[i] c to h[i] c. The loop: along the bottoms left to right, the tops back.
  const int n = static_cast<int>(std::ceil(r / c));
  std::vector<Eigen::Vector2d> loop;
  auto height = [&](int i) {
    const double xm = (i + 0.5) * c;
    return xm * xm < r * r ? static_cast<int>(std::ceil(std::sqrt(r * r - xm * xm) / c - 0.5)) : 0;
  };
  for (int i = -n; i < n; ++i)
    if (height(i) > 0) loop.push_back(Eigen::Vector2d(i * c, -height(i) * c)), loop.push_back(Eigen::Vector2d((i + 1) * c, -height(i) * c));
  for (int i = n - 1; i >= -n; --i)
    if (height(i) > 0) loop.push_back(Eigen::Vector2d((i + 1) * c, height(i) * c)), loop.push_back(Eigen::Vector2d(i * c, height(i) * c));
  // The staircase's vertices are its turns: repeated points and points inside straight runs go.
  std::vector<Eigen::Vector2d> distinct;
  for (const Eigen::Vector2d& v : loop)
    if (distinct.empty() || (v - distinct.back()).norm() > 1e-12) distinct.push_back(v);
  if ((distinct.front() - distinct.back()).norm() < 1e-12) distinct.pop_back();
  std::vector<Eigen::Vector2d> turns;
  for (size_t i = 0; i < distinct.size(); ++i) {
    const Eigen::Vector2d a = distinct[(i + distinct.size() - 1) % distinct.size()], b = distinct[i], d = distinct[(i + 1) % distinct.size()];
    if (std::abs((b - a).x() * (d - b).y() - (b - a).y() * (d - b).x()) > 1e-15) turns.push_back(b);
  }
  FlatPositions stair(turns.size(), 2);
  for (size_t i = 0; i < turns.size(); ++i) stair.row(i) = turns[i].transpose();
  ASSERT_GT(SignedArea(stair), 0) << "counter-clockwise";
  double from_circle = 0;
  for (Eigen::Index i = 0; i < stair.rows(); ++i) from_circle = std::max(from_circle, std::abs(stair.row(i).norm() - r));
  EXPECT_LE(from_circle, c / std::sqrt(2.0) + 1e-12);
  EXPECT_NEAR(MaxTurningDeg(stair), 90, 1e-9);

  const FairedSpan f = FairSpan({stair}, {}, /*closed=*/true);
  ASSERT_EQ(f.sides.size(), 1u);
  const FlatPositions& q = f.sides[0];
  const double deviation = Farthest(q, stair, true), turning = MaxTurningDeg(q);
  double spacing = 0, off_circle = 0;
  for (Eigen::Index i = 0; i < q.rows(); ++i) {
    spacing = std::max(spacing, (q.row((i + 1) % q.rows()) - q.row(i)).norm());
    off_circle = std::max(off_circle, std::abs(q.row(i).norm() - r));
  }
  std::printf("staircase circle: %zd vertices, %zd sew points; deviation %.3f mm (reported %.3f); turning %.2f deg; %.3f mm off the circle\n",
              stair.rows(), q.rows(), 1000 * deviation, 1000 * f.deviation_m[0], turning, 1000 * off_circle);
  EXPECT_LE(deviation, 0.001);
  EXPECT_NEAR(f.deviation_m[0], deviation, 1e-12) << "no scale given: the plane distance";
  EXPECT_LT(turning, 10);
  EXPECT_LE(spacing, 0.0011);
  EXPECT_LE(off_circle, from_circle + 0.001);
  EXPECT_FALSE(f.sides.empty());
}

// A seam of 15 coarse edges of 12 mm (each in four 3 mm pieces) zig-zagging by +-30 degrees about its
// line, as a shortest path over a triangle mesh does. Side a is that path; side b has the same edge
// lengths, the zig-zag turned the other way and the whole bent by 0.4 degrees at every vertex (the two
// sides of a seam are flattened on either side of it). Faired alone, they differ in length; faired as
// a seam: both within 1 mm of their staircase, under 10 degrees of turn, their ends exactly where they
// were, and their lengths equal within 0.5 mm (to round-off).
TEST(SewLine, TheTwoSidesOfASeamAreFairedToOneLengthWithTheirEndsKept) {
  const int coarse = 15, fine = 4;
  const double edge = 0.003;
  auto side = [&](double zig, double bend_deg) {
    FlatPositions p(coarse * fine + 1, 2);
    p.row(0) << 0, 0;
    double heading = 0;
    for (int k = 0; k < coarse * fine; ++k) {
      if (k % fine == 0) heading = (k / fine % 2 ? -1 : 1) * zig;
      heading += bend_deg * M_PI / 180;
      p.row(k + 1) = p.row(k) + edge * Eigen::RowVector2d(std::cos(heading), std::sin(heading));
    }
    return p;
  };
  const FlatPositions a = side(M_PI / 6, 0), b = side(-M_PI / 6, 0.4);
  EXPECT_NEAR(Length(a), Length(b), 1e-12);
  EXPECT_GT(InnerTurningDeg(a), 59);
  const FairedSpan f = FairSpan({a, b}, {}, /*closed=*/false);
  ASSERT_EQ(f.sides.size(), 2u);
  ASSERT_EQ(f.sides[0].rows(), f.sides[1].rows());
  const double la = Length(f.sides[0]), lb = Length(f.sides[1]);
  // Each side faired alone shortens by a different amount.
  const double alone_a = Length(FairSpan({a}, {}, false).sides[0]), alone_b = Length(FairSpan({b}, {}, false).sides[0]);
  std::printf("seam sides: staircase %.3f mm; faired as a seam %.4f and %.4f mm; alone %.4f and %.4f mm; turning %.2f and %.2f deg; "
              "deviation %.3f and %.3f mm\n",
              1000 * Length(a), 1000 * la, 1000 * lb, 1000 * alone_a, 1000 * alone_b, InnerTurningDeg(f.sides[0]), InnerTurningDeg(f.sides[1]),
              1000 * Farthest(f.sides[0], a, false), 1000 * Farthest(f.sides[1], b, false));
  EXPECT_NEAR(la, lb, 0.0005);
  EXPECT_NEAR(la, lb, 1e-8) << "brought to one length";
  EXPECT_GT(std::abs(alone_a - alone_b), 1e-4) << "alone, the sides differ";
  EXPECT_LT(la, Length(a) - 0.001) << "the zig-zag is cut";
  for (int s = 0; s < 2; ++s) {
    const FlatPositions& q = f.sides[s];
    const FlatPositions& p = s ? b : a;
    EXPECT_TRUE(q.row(0) == p.row(0)) << "side " << s << ": its first end kept exactly";
    EXPECT_TRUE(q.row(q.rows() - 1) == p.row(p.rows() - 1)) << "side " << s << ": its last end kept exactly";
    EXPECT_LE(Farthest(q, p, false), 0.001) << "side " << s;
    EXPECT_LT(InnerTurningDeg(q), 10) << "side " << s;
  }
  // Every staircase vertex has its sew point, in order, the ends at the ends.
  ASSERT_EQ(f.at.size(), static_cast<size_t>(a.rows()));
  EXPECT_EQ(f.at.front(), 0);
  EXPECT_EQ(f.at.back(), f.points);
  for (size_t k = 1; k < f.at.size(); ++k) EXPECT_LE(f.at[k - 1], f.at[k]);
}

// A flat map that shrinks by half across the staircase: a plane distance d is 2 d on the body, so the
// fairing keeps within half a millimetre in the plane.
TEST(SewLine, TheToleranceIsMeasuredOnTheBodyThroughTheFlatMapsStretch) {
  FlatPositions p(41, 2);
  for (int k = 0; k <= 40; ++k) p.row(k) << 0.003 * k, (k % 2 ? 0.0015 : 0.0);
  const Eigen::VectorXd half = Eigen::VectorXd::Constant(40, 0.5);
  const FairedSpan f = FairSpan({p}, {half}, false);
  const double plane = Farthest(f.sides[0], p, false);
  std::printf("stretch 0.5: plane deviation %.3f mm, on the body %.3f mm\n", 1000 * plane, 1000 * f.deviation_m[0]);
  EXPECT_LE(plane, 0.0005 + 1e-12);
  EXPECT_NEAR(f.deviation_m[0], 2 * plane, 1e-12);
  EXPECT_GT(plane, 0.0003) << "it uses the tolerance it has";
}

}  // namespace
}  // namespace kgd
