// Sew lines: staircases of known shape faired within the tolerance and below 10 degrees of turn, their
// ends kept; the two sides of a seam brought to one length; the turning measure itself.
#include "core/fabrication/sew_line.h"

#include "core/fabrication/pattern.h"

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

// The two free edges (cuffs) of the knee_flexion export's first piece, between their corners, as the
// export fairs them (`kgd design knee_flexion`, `kgd export`): flat positions (mm) and each segment's
// smallest stretch (the last row's is unused). A staircase turning by 30 to 75 degrees every 5 to 8 mm
// around a bend of the cuff. The weights of straying points grown by 4 alone pin the curve where it
// first strayed and leave a turn over 10 degrees; the default growths find a fit under 10 degrees
// within 1 mm on the body.
const double kKneeCuffTop[][3] = {
    {131.8220, 369.4007, 0.9926}, {125.2664, 364.4234, 0.9965}, {118.8094, 359.3972, 0.9970}, {115.7955, 354.4373, 0.9944},
    {112.8501, 349.5212, 0.9928}, {109.6151, 344.2308, 0.9870}, {106.4163, 338.9121, 0.9804}, {102.4013, 333.1521, 0.9780},
    {98.4018, 327.4200, 0.9744}, {98.6624, 322.2185, 0.9549}, {99.0391, 317.0412, 0.9471}, {94.1351, 315.3860, 0.9717},
    {89.1879, 313.5575, 0.9723}, {89.2269, 309.1126, 0.9498}, {89.3790, 304.7490, 0.9456}, {85.6916, 301.3494, 0.9534},
    {81.9361, 297.9093, 0.9523}, {80.7724, 291.5635, 0.9270}, {79.6562, 285.3594, 0.9430}, {73.4508, 282.8716, 0.9690},
    {67.2108, 280.1567, 0.9696}, {67.3658, 273.9027, 0.9493}, {67.6410, 267.7555, 0.9443}, {63.6901, 265.7736, 0.9673},
    {59.7377, 263.6614, 0.9691}, {58.6702, 258.9556, 0.9577}, {57.6400, 254.2867, 0.9713}, {53.1683, 250.6327, 0.9791},
    {48.6707, 246.9454, 0.9837}, {44.1401, 243.9057, 0.9894}, {39.6087, 240.8309, 0.9877}, {41.4673, 234.4509, 0.9728},
    {43.3142, 228.1582, 1.0000}};
const double kKneeCuffBottom[][3] = {
    {215.8376, 88.4432, 0.9937}, {222.4485, 92.1698, 0.9956}, {229.0230, 95.9141, 0.9951}, {228.8151, 102.3837, 0.9962},
    {228.5830, 108.8565, 0.9978}, {234.2251, 111.2847, 0.9986}, {239.8650, 113.7007, 0.9986}, {240.1945, 119.1649, 0.9982},
    {240.5301, 124.6317, 0.9980}, {246.6715, 126.6014, 0.9987}, {252.8092, 128.5674, 0.9988}, {253.3382, 134.3852, 0.9981},
    {253.8770, 140.2114, 0.9978}, {259.4946, 143.2452, 0.9985}, {265.1088, 146.2731, 0.9985}, {264.7552, 153.2003, 0.9975},
    {264.4100, 160.1389, 0.9974}, {269.1077, 163.7818, 0.9979}, {273.8012, 167.4202, 0.9984}, {278.0565, 170.9003, 0.9989},
    {282.3065, 174.3729, 0.9988}, {281.0242, 180.8818, 0.9979}, {279.7459, 187.4038, 0.9980}, {284.2805, 189.9670, 0.9987},
    {288.8147, 192.5196, 0.9986}, {288.7089, 198.6685, 0.9981}, {288.6044, 204.8287, 0.9988}, {294.5361, 207.5060, 0.9993},
    {300.4661, 210.1738, 0.9993}, {300.7287, 218.0394, 0.9991}, {300.9927, 225.8998, 0.9993}, {304.2129, 231.1574, 0.9991},
    {307.4236, 236.3908, 0.9985}, {311.4402, 237.5583, 0.9988}, {315.4594, 238.7274, 0.9986}, {315.9476, 241.5916, 0.9981},
    {316.4335, 244.4574, 0.9981}, {318.1156, 246.9181, 0.9984}, {319.7910, 249.3821, 0.9990}, {322.9074, 253.3557, 0.9988},
    {326.0245, 257.3265, 0.9988}, {322.1002, 263.2063, 0.9977}, {318.1785, 269.1176, 1.0000}};

FlatPositions Millimetres(const double (*rows)[3], int n, Eigen::VectorXd* scale) {
  FlatPositions p(n, 2);
  *scale = Eigen::VectorXd(n - 1);
  for (int i = 0; i < n; ++i) {
    p.row(i) << 1e-3 * rows[i][0], 1e-3 * rows[i][1];
    if (i + 1 < n) (*scale)[i] = rows[i][2];
  }
  return p;
}

TEST(SewLine, TheKneeExportsCuffsAreFairedUnderTenDegreesWithinAMillimetreOnTheBody) {
  const std::vector<std::pair<const double(*)[3], int>> cuffs = {
      {kKneeCuffTop, static_cast<int>(std::size(kKneeCuffTop))}, {kKneeCuffBottom, static_cast<int>(std::size(kKneeCuffBottom))}};
  SewLineOptions pinned;
  pinned.weight_growth = {4};
  double pinned_worst = 0;
  for (const auto& [rows, count] : cuffs) {
    Eigen::VectorXd scale;
    const FlatPositions outline = Millimetres(rows, count, &scale);
    const FairedSpan f = FairSpan({outline}, {scale}, /*closed=*/false);
    const FairedSpan g = FairSpan({outline}, {scale}, /*closed=*/false, pinned);
    const FlatPositions& q = f.sides[0];
    double on_body = 0;
    for (Eigen::Index i = 0; i < q.rows(); ++i) on_body = std::max(on_body, BodyDistance(q.row(i).transpose(), outline, scale, false));
    std::printf("knee cuff: %d vertices, %zd sew points; turning %.2f deg (growth 4 alone: %.2f), %.3f mm from the outline on the body\n",
                count, q.rows(), InnerTurningDeg(q), InnerTurningDeg(g.sides[0]), 1000 * on_body);
    EXPECT_LT(InnerTurningDeg(q), 10);
    EXPECT_LE(on_body, 0.001);
    EXPECT_NEAR(f.deviation_m[0], on_body, 1e-12);
    EXPECT_EQ((q.row(0) - outline.row(0)).norm(), 0) << "the corners kept";
    EXPECT_EQ((q.row(q.rows() - 1) - outline.row(count - 1)).norm(), 0) << "the corners kept";
    pinned_worst = std::max(pinned_worst, InnerTurningDeg(g.sides[0]));
  }
  EXPECT_GT(pinned_worst, 10) << "the cuffs are a case the fastest growth alone does not fair";
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
  EXPECT_GT(std::abs(alone_a - alone_b), 2e-5) << "alone, the sides differ (by 2000 times what they differ by sewn)";
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
