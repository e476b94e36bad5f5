#include "core/testing/self_intersection.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace kgd {
namespace {

using V3 = Eigen::Vector3d;

// Does segment [p, q] cross triangle (a, b, c)? Moller-Trumbore on the segment's parameter range.
bool SegmentCrossesTriangle(const V3& p, const V3& q, const V3& a, const V3& b, const V3& c) {
  const V3 d = q - p, e1 = b - a, e2 = c - a;
  const V3 h = d.cross(e2);
  const double det = e1.dot(h);
  const double scale = e1.norm() * e2.norm() * d.norm();
  if (std::abs(det) <= 1e-12 * scale) return false;  // parallel: coplanar overlaps are not counted
  const double inv = 1.0 / det;
  const V3 s = p - a;
  const double u = s.dot(h) * inv;
  if (u < -1e-12 || u > 1 + 1e-12) return false;
  const V3 qq = s.cross(e1);
  const double v = d.dot(qq) * inv;
  if (v < -1e-12 || u + v > 1 + 1e-12) return false;
  const double t = e2.dot(qq) * inv;
  return t >= -1e-12 && t <= 1 + 1e-12;
}

bool TrianglesCross(const Positions& x, const Faces& faces, int f, int g) {
  V3 a[3], b[3];
  for (int k = 0; k < 3; ++k) {
    a[k] = x.row(faces(f, k));
    b[k] = x.row(faces(g, k));
  }
  for (int k = 0; k < 3; ++k) {
    if (SegmentCrossesTriangle(a[k], a[(k + 1) % 3], b[0], b[1], b[2])) return true;
    if (SegmentCrossesTriangle(b[k], b[(k + 1) % 3], a[0], a[1], a[2])) return true;
  }
  return false;
}

}  // namespace

std::vector<std::pair<int, int>> SelfIntersections(const Positions& x, const Faces& faces, int max_pairs) {
  std::vector<std::pair<int, int>> out;
  const int nf = static_cast<int>(faces.rows());
  if (nf == 0) return out;
  const double cell = 2.0 * MeanEdgeLength(x, faces);
  const V3 origin = x.colwise().minCoeff().transpose();
  auto cell_of = [&](const V3& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor((p[0] - origin[0]) / cell)),
                           static_cast<int>(std::floor((p[1] - origin[1]) / cell)),
                           static_cast<int>(std::floor((p[2] - origin[2]) / cell)));
  };
  auto key = [](int i, int j, int k) {
    return (static_cast<uint64_t>(i & 0x1fffff) << 42) | (static_cast<uint64_t>(j & 0x1fffff) << 21) |
           static_cast<uint64_t>(k & 0x1fffff);
  };
  std::unordered_map<uint64_t, std::vector<int>> grid;
  std::vector<Eigen::Vector3i> lo(nf), hi(nf);
  for (int f = 0; f < nf; ++f) {
    V3 mn = x.row(faces(f, 0)), mx = mn;
    for (int k = 1; k < 3; ++k) {
      mn = mn.cwiseMin(x.row(faces(f, k)).transpose());
      mx = mx.cwiseMax(x.row(faces(f, k)).transpose());
    }
    lo[f] = cell_of(mn);
    hi[f] = cell_of(mx);
    for (int i = lo[f][0]; i <= hi[f][0]; ++i)
      for (int j = lo[f][1]; j <= hi[f][1]; ++j)
        for (int k = lo[f][2]; k <= hi[f][2]; ++k) grid[key(i, j, k)].push_back(f);
  }
  std::vector<int> candidates;
  for (int f = 0; f < nf && static_cast<int>(out.size()) < max_pairs; ++f) {
    candidates.clear();
    for (int i = lo[f][0]; i <= hi[f][0]; ++i)
      for (int j = lo[f][1]; j <= hi[f][1]; ++j)
        for (int k = lo[f][2]; k <= hi[f][2]; ++k) {
          auto it = grid.find(key(i, j, k));
          if (it == grid.end()) continue;
          for (int g : it->second)
            if (g > f) candidates.push_back(g);
        }
    std::sort(candidates.begin(), candidates.end());
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
    for (int g : candidates) {
      bool shared = false;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) shared |= faces(f, a) == faces(g, b);
      if (shared) continue;
      if ((hi[f].array() < lo[g].array()).any() || (hi[g].array() < lo[f].array()).any()) continue;
      if (TrianglesCross(x, faces, f, g)) {
        out.emplace_back(f, g);
        if (static_cast<int>(out.size()) >= max_pairs) break;
      }
    }
  }
  return out;
}

}  // namespace kgd
