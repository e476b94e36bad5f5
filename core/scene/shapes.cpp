#include "core/scene/shapes.h"

#include <algorithm>
#include <cmath>

namespace kgd {

TriMesh BoxSurface(double x, double y, double z) {
  TriMesh m;
  m.vertices.resize(8, 3);
  for (int v = 0; v < 8; ++v) m.vertices.row(v) << x * (v & 1), y * ((v >> 1) & 1), z * ((v >> 2) & 1);
  m.faces.resize(12, 3);
  m.faces << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5;
  return m;
}

TriMesh RectangleSheet(double width, double length, double spacing) {
  const int nx = static_cast<int>(std::lround(width / spacing)) + 1;
  const int nz = static_cast<int>(std::lround(length / spacing)) + 1;
  TriMesh m;
  m.vertices.resize(nx * nz, 3);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) m.vertices.row(j * nx + i) << width * i / (nx - 1), 0.0, length * j / (nz - 1);
  m.faces.resize(2 * (nx - 1) * (nz - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < nz; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
      // Normal along -y for both ("/" diagonal from a to d).
      m.faces.row(f++) << a, d, b;
      m.faces.row(f++) << a, c, d;
    }
  return m;
}

namespace {
double ProfileRadius(const LimbShape& s, double y) {
  const double u = y / s.waist_halfwidth_m;
  if (std::abs(u) >= 1.0) return s.radius_m;
  const double bump = (1.0 - u * u) * (1.0 - u * u);  // C1 at the ends of the waist
  return s.radius_m * (1.0 - s.waist_depth * bump);
}
}  // namespace

TriMesh LimbRest(const LimbShape& s, std::vector<double>* axial) {
  const double pi = std::acos(-1.0);
  const double arc = 2.0 * pi * s.radius_m / s.around;
  const double dy = s.spacing_m > 0 ? s.spacing_m : arc;
  const int n_cyl = std::max(2, static_cast<int>(std::lround(s.length_m / dy)));
  const int n_cap = std::max(2, static_cast<int>(std::lround(0.5 * pi * s.radius_m / arc)));
  // Profile (y, r) from the bottom pole to the top pole, excluding the poles.
  std::vector<std::pair<double, double>> rings;
  for (int j = 1; j < n_cap; ++j) {
    const double phi = 0.5 * pi * j / n_cap;
    rings.emplace_back(-0.5 * s.length_m - s.radius_m * std::cos(phi), s.radius_m * std::sin(phi));
  }
  for (int j = 0; j <= n_cyl; ++j) {
    const double y = -0.5 * s.length_m + s.length_m * j / n_cyl;
    rings.emplace_back(y, ProfileRadius(s, y));
  }
  for (int j = n_cap - 1; j >= 1; --j) {
    const double phi = 0.5 * pi * j / n_cap;
    rings.emplace_back(0.5 * s.length_m + s.radius_m * std::cos(phi), s.radius_m * std::sin(phi));
  }
  const int nr = static_cast<int>(rings.size()), na = s.around;
  TriMesh m;
  m.vertices.resize(2 + nr * na, 3);
  m.vertices.row(0) << 0.0, -0.5 * s.length_m - s.radius_m, 0.0;
  for (int j = 0; j < nr; ++j)
    for (int i = 0; i < na; ++i) {
      const double t = 2.0 * pi * i / na;
      m.vertices.row(1 + j * na + i) << rings[j].second * std::cos(t), rings[j].first, rings[j].second * std::sin(t);
    }
  const int top = 1 + nr * na;
  m.vertices.row(top) << 0.0, 0.5 * s.length_m + s.radius_m, 0.0;
  std::vector<Eigen::Vector3i> tris;
  auto ring = [&](int j, int i) { return 1 + j * na + (i % na); };
  // Outward orientation: with the ring parametrized by (cos t, sin t) in (x, z) and y up, the
  // outward normal of (a, c, b) below is +radial.
  for (int i = 0; i < na; ++i) tris.emplace_back(0, ring(0, i), ring(0, i + 1));
  for (int j = 0; j + 1 < nr; ++j)
    for (int i = 0; i < na; ++i) {
      const int a = ring(j, i), b = ring(j, i + 1), c = ring(j + 1, i), d = ring(j + 1, i + 1);
      tris.emplace_back(a, c, d);
      tris.emplace_back(a, d, b);
    }
  for (int i = 0; i < na; ++i) tris.emplace_back(top, ring(nr - 1, i + 1), ring(nr - 1, i));
  m.faces.resize(tris.size(), 3);
  for (size_t f = 0; f < tris.size(); ++f) m.faces.row(f) = tris[f].transpose();
  if (axial) {
    axial->resize(m.vertices.rows());
    for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) (*axial)[v] = m.vertices(v, 1);
  }
  return m;
}

Positions LimbPosed(const LimbShape& s, const Positions& rest, double angle) {
  // Bend angle grows linearly through the joint: phi(y) = angle * clamp((y + l/2) / l, 0, 1).
  const double l = s.joint_length_m;
  auto phi = [&](double y) { return angle * std::clamp((y + 0.5 * l) / l, 0.0, 1.0); };
  // Centreline c(y) = integral of (0, cos phi, sin phi), with c(-l/2) = (0, -l/2, 0); exact per piece.
  auto centre = [&](double y) -> Eigen::Vector3d {
    if (y <= -0.5 * l || angle == 0.0) return {0.0, y, 0.0};
    const double k = angle / l;  // curvature in the joint
    const double yj = std::min(y, 0.5 * l) + 0.5 * l;  // arc length travelled in the joint
    const double p = k * yj;
    Eigen::Vector3d c(0.0, -0.5 * l + std::sin(p) / k, (1.0 - std::cos(p)) / k);
    if (y > 0.5 * l) c += (y - 0.5 * l) * Eigen::Vector3d(0.0, std::cos(angle), std::sin(angle));
    return c;
  };
  Positions out(rest.rows(), 3);
  for (Eigen::Index v = 0; v < rest.rows(); ++v) {
    const double y = rest(v, 1);
    const double p = phi(y);
    const Eigen::Vector3d n(0.0, -std::sin(p), std::cos(p));  // rest +z direction, rotated with the section
    out.row(v) = (centre(y) + rest(v, 0) * Eigen::Vector3d::UnitX() + rest(v, 2) * n).transpose();
  }
  return out;
}

}  // namespace kgd
