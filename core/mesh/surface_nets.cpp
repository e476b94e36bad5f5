#include "core/mesh/surface_nets.h"

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

namespace kgd {

TriMesh SurfaceNets(const std::function<double(const Eigen::Vector3d&)>& field, const Eigen::Vector3d& lo,
                    const Eigen::Vector3d& hi, double h) {
  const Eigen::Vector3i n = (((hi - lo) / h).array().ceil().cast<int>() + 1).matrix();
  auto node = [&](int i, int j, int k) { return (static_cast<long>(k) * n[1] + j) * n[0] + i; };
  auto pos = [&](int i, int j, int k) { return Eigen::Vector3d(lo + h * Eigen::Vector3d(i, j, k)); };
  std::vector<double> value(static_cast<size_t>(n[0]) * n[1] * n[2]);
#pragma omp parallel for schedule(static)
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) value[node(i, j, k)] = field(pos(i, j, k));

  // One vertex per crossed cell.
  auto cell = [&](int i, int j, int k) { return (static_cast<long>(k) * (n[1] - 1) + j) * (n[0] - 1) + i; };
  std::vector<int> cell_vertex(static_cast<size_t>(n[0] - 1) * (n[1] - 1) * (n[2] - 1), -1);
  std::vector<Eigen::Vector3d> verts;
  static const int kEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                    {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  for (int k = 0; k + 1 < n[2]; ++k)
    for (int j = 0; j + 1 < n[1]; ++j)
      for (int i = 0; i + 1 < n[0]; ++i) {
        double v[8];
        Eigen::Vector3d p[8];
        int inside = 0;
        for (int c = 0; c < 8; ++c) {
          const int di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
          v[c] = value[node(i + di, j + dj, k + dk)];
          p[c] = pos(i + di, j + dj, k + dk);
          inside += v[c] < 0;
        }
        if (inside == 0 || inside == 8) continue;
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int crossings = 0;
        for (const auto& e : kEdges) {
          const double a = v[e[0]], b = v[e[1]];
          if ((a < 0) == (b < 0)) continue;
          const double t = a / (a - b);
          sum += p[e[0]] + t * (p[e[1]] - p[e[0]]);
          ++crossings;
        }
        cell_vertex[cell(i, j, k)] = static_cast<int>(verts.size());
        verts.push_back(sum / crossings);
      }

  // One quad per crossed grid edge, from the four cells around it.
  std::vector<Eigen::Vector3i> tris;
  auto emit = [&](int a, int b, int c, int d, const Eigen::Vector3d& outward) {
    if (a < 0 || b < 0 || c < 0 || d < 0) return;
    const Eigen::Vector3d normal = (verts[c] - verts[a]).cross(verts[d] - verts[b]);
    if (normal.dot(outward) < 0) std::swap(b, d);
    if ((verts[c] - verts[a]).squaredNorm() <= (verts[d] - verts[b]).squaredNorm()) {
      tris.emplace_back(a, b, c);
      tris.emplace_back(a, c, d);
    } else {
      tris.emplace_back(a, b, d);
      tris.emplace_back(b, c, d);
    }
  };
  for (int k = 1; k + 1 < n[2]; ++k)
    for (int j = 1; j + 1 < n[1]; ++j)
      for (int i = 1; i + 1 < n[0]; ++i) {
        const double v0 = value[node(i, j, k)];
        for (int axis = 0; axis < 3; ++axis) {
          const int ni = i + (axis == 0), nj = j + (axis == 1), nk = k + (axis == 2);
          if (ni >= n[0] || nj >= n[1] || nk >= n[2]) continue;
          const double v1 = value[node(ni, nj, nk)];
          if ((v0 < 0) == (v1 < 0)) continue;
          Eigen::Vector3d outward = Eigen::Vector3d::Zero();
          outward[axis] = v0 < 0 ? 1.0 : -1.0;
          if (axis == 0)
            emit(cell_vertex[cell(i, j - 1, k - 1)], cell_vertex[cell(i, j, k - 1)], cell_vertex[cell(i, j, k)],
                 cell_vertex[cell(i, j - 1, k)], outward);
          else if (axis == 1)
            emit(cell_vertex[cell(i - 1, j, k - 1)], cell_vertex[cell(i, j, k - 1)], cell_vertex[cell(i, j, k)],
                 cell_vertex[cell(i - 1, j, k)], outward);
          else
            emit(cell_vertex[cell(i - 1, j - 1, k)], cell_vertex[cell(i, j - 1, k)], cell_vertex[cell(i, j, k)],
                 cell_vertex[cell(i - 1, j, k)], outward);
        }
      }
  TriMesh mesh;
  mesh.vertices.resize(static_cast<Eigen::Index>(verts.size()), 3);
  for (size_t v = 0; v < verts.size(); ++v) mesh.vertices.row(v) = verts[v];
  mesh.faces.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t f = 0; f < tris.size(); ++f) mesh.faces.row(f) = tris[f];
  return mesh;
}

}  // namespace kgd
