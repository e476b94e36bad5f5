#include "core/fabrication/patches.h"

#include <algorithm>
#include <cmath>

#include "core/mesh/topology.h"

namespace kgd {
namespace {

// Fairs a closed staircase polyline (Taubin lambda/mu, so it does not shrink), leaving alone the
// vertices on straight runs and the corners between long straight runs: an outline that is already
// straight (a band on a grid) keeps its exact shape.
FlatPositions Fair(const FlatPositions& p) {
  const int n = static_cast<int>(p.rows());
  if (n < 5) return p;
  double mean = 0;
  for (int i = 0; i < n; ++i) mean += (p.row((i + 1) % n) - p.row(i)).norm();
  mean /= n;
  // Straight runs: consecutive segments turning by less than 1 degree.
  std::vector<double> run(n, 0);  // length of the straight run that segment i (i -> i+1) belongs to
  auto turn = [&](int i) {        // at vertex i
    const Eigen::Vector2d a = p.row(i) - p.row((i + n - 1) % n), b = p.row((i + 1) % n) - p.row(i);
    return std::abs(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b)));
  };
  const double straight = M_PI / 180;
  for (int i = 0; i < n; ++i) {
    double length = (p.row((i + 1) % n) - p.row(i)).norm();
    for (int j = i; turn(j) < straight && length < 1e9; j = (j + n - 1) % n) {
      length += (p.row(j) - p.row((j + n - 1) % n)).norm();
      if ((j + n - 1) % n == i) break;
    }
    for (int j = (i + 1) % n; turn(j) < straight; j = (j + 1) % n) {
      length += (p.row((j + 1) % n) - p.row(j)).norm();
      if (j == i) break;
    }
    run[i] = length;
  }
  std::vector<char> pinned(n, 0);
  for (int i = 0; i < n; ++i) pinned[i] = turn(i) < straight || (run[(i + n - 1) % n] > 3 * mean && run[i] > 3 * mean);
  FlatPositions q = p;
  for (int it = 0; it < 10; ++it)
    for (const double step : {0.5, -0.53}) {
      FlatPositions next = q;
      for (int i = 0; i < n; ++i)
        if (!pinned[i]) next.row(i) += step * (0.5 * (q.row((i + n - 1) % n) + q.row((i + 1) % n)) - q.row(i));
      q = next;
    }
  return q;
}

FlatPositions Polygon(const FlatPositions& flat, const std::vector<int>& loop) {
  FlatPositions p(loop.size(), 2);
  for (size_t k = 0; k < loop.size(); ++k) p.row(k) = flat.row(loop[k]);
  return p;
}

}  // namespace

CleanedDesign CleanDesign(const TriMesh& rest, const std::vector<uint8_t>& design, const CleaningOptions& o, const std::vector<uint8_t>& keep) {
  const Faces& faces = rest.faces;
  const int nf = static_cast<int>(faces.rows());
  const Eigen::VectorXd area = FaceAreas(rest.vertices, faces);
  const double min_area = o.min_area_m2 > 0 ? o.min_area_m2 : 4 * o.min_feature_m * o.min_feature_m;
  const std::vector<std::vector<int>> neighbours = FaceNeighbors(faces);
  auto kept = [&](int f) { return !keep.empty() && keep[f]; };
  CleanedDesign out;
  out.design = design;
  std::vector<uint8_t>& d = out.design;

  // Islands: small reinforced components (unless a kept face holds them).
  {
    std::vector<char> in(nf);
    for (int f = 0; f < nf; ++f) in[f] = d[f] != 0;
    const FacePieces pieces = EdgeConnectedPieces(faces, in);
    const std::vector<int>& comp = pieces.piece;
    const int count = pieces.count;
    std::vector<double> a(count, 0);
    std::vector<char> held(count, 0);
    for (int f = 0; f < nf; ++f)
      if (comp[f] >= 0) a[comp[f]] += area[f], held[comp[f]] |= kept(f);
    for (int c = 0; c < count; ++c) out.islands_removed += a[c] < min_area && !held[c];
    for (int f = 0; f < nf; ++f)
      if (comp[f] >= 0 && a[comp[f]] < min_area && !held[comp[f]]) d[f] = 0, out.removed_m2 += area[f];
  }
  // Holes: small cloth components that touch no garment edge.
  {
    std::vector<char> in(nf);
    for (int f = 0; f < nf; ++f) in[f] = d[f] == 0;
    const FacePieces pieces = EdgeConnectedPieces(faces, in);
    const std::vector<int>& comp = pieces.piece;
    const int count = pieces.count;
    std::vector<double> a(count, 0);
    std::vector<char> open(count, 0);
    for (int f = 0; f < nf; ++f)
      if (comp[f] >= 0) {
        a[comp[f]] += area[f];
        open[comp[f]] |= neighbours[f].size() < 3 || kept(f);  // on the garment's edge
      }
    for (int c = 0; c < count; ++c) out.holes_filled += a[c] < min_area && !open[c];
    for (int f = 0; f < nf; ++f)
      if (comp[f] >= 0 && a[comp[f]] < min_area && !open[comp[f]]) d[f] = 1, out.added_m2 += area[f];
  }
  // Opening by min_feature: erosion (distance from each reinforced face to the nearest cloth face),
  // then dilation within the reinforced set.
  const double r = 0.5 * o.min_feature_m;
  if (r > 0) {
    Positions centroid(nf, 3);
    for (int f = 0; f < nf; ++f)
      centroid.row(f) = (rest.vertices.row(faces(f, 0)) + rest.vertices.row(faces(f, 1)) + rest.vertices.row(faces(f, 2))) / 3;
    std::vector<int> frontier;  // cloth faces beside reinforced ones
    for (int f = 0; f < nf; ++f)
      if (!d[f])
        for (int g : neighbours[f])
          if (d[g]) {
            frontier.push_back(f);
            break;
          }
    // Half a face across: a face centroid lies about that far inside the region's edge.
    const double inset = 0.5 * std::sqrt(area.mean());
    std::vector<int> core;
    for (int f = 0; f < nf; ++f) {
      if (!d[f]) continue;
      double nearest = std::numeric_limits<double>::infinity();
      for (int g : frontier) nearest = std::min(nearest, (centroid.row(f) - centroid.row(g)).squaredNorm());
      if (kept(f) || std::sqrt(nearest) - inset >= r - 1e-12) core.push_back(f);
    }
    std::vector<uint8_t> opened(nf, 0);
    for (int f = 0; f < nf; ++f) {
      if (!d[f]) continue;
      if (kept(f)) {
        opened[f] = 1;
        continue;
      }
      for (int g : core)
        if ((centroid.row(f) - centroid.row(g)).norm() <= r + inset + 1e-12) {
          opened[f] = 1;
          break;
        }
    }
    for (int f = 0; f < nf; ++f)
      if (d[f] && !opened[f]) d[f] = 0, out.removed_m2 += area[f];
  }
  return out;
}

std::vector<Patch> ReinforcementPatches(const Pattern& pattern, const std::vector<uint8_t>& design, const std::vector<uint8_t>& include,
                                        double min_area_m2) {
  std::vector<Patch> patches;
  for (size_t i = 0; i < pattern.pieces.size(); ++i) {
    const PatternPiece& piece = pattern.pieces[i];
    const int nf = static_cast<int>(piece.faces.rows());
    std::vector<char> in(nf);
    for (int f = 0; f < nf; ++f) {
      const int g = piece.garment_faces[f];
      in[f] = design[g] && (include.empty() || include[g]);
    }
    const FacePieces pieces = EdgeConnectedPieces(piece.faces, in);
    const std::vector<int>& comp = pieces.piece;
    const int count = pieces.count;
    Positions flat3(piece.flat.rows(), 3);
    flat3 << piece.flat, Eigen::VectorXd::Zero(piece.flat.rows());
    const Eigen::VectorXd flat_area = FaceAreas(flat3, piece.faces);
    for (int c = 0; c < count; ++c) {
      std::vector<int> ids;
      double a = 0;
      for (int f = 0; f < nf; ++f)
        if (comp[f] == c) ids.push_back(f), a += flat_area[f];
      Faces sub(ids.size(), 3);
      for (size_t k = 0; k < ids.size(); ++k) sub.row(k) = piece.faces.row(ids[k]);
      std::vector<FlatPositions> loops;
      for (const std::vector<int>& loop : BoundaryLoops(sub)) loops.push_back(Fair(Polygon(piece.flat, loop)));
      // A sliver a seam cut off a patch is too small to cut and press.
      if (loops.empty() || a < min_area_m2) continue;
      // The outer loop encloses the most.
      size_t outer = 0;
      for (size_t k = 1; k < loops.size(); ++k)
        if (std::abs(SignedArea(loops[k])) > std::abs(SignedArea(loops[outer]))) outer = k;
      // Loops turn like the outer one around more reinforcement (where faces touch at a vertex only,
      // the outer boundary splits into lobes), the other way around holes. A lobe is a patch of its own.
      // Loops under the minimum area are slivers of such pinches, too small to cut (as the cleaning
      // fills holes under it); faired, they can even cross the outline.
      const bool outer_ccw = SignedArea(loops[outer]) > 0;
      std::vector<FlatPositions> holes, lobes;
      for (size_t k = 0; k < loops.size(); ++k) {
        if (k == outer || loops[k].rows() < 3 || std::abs(SignedArea(loops[k])) < min_area_m2) continue;
        ((SignedArea(loops[k]) > 0) == outer_ccw ? lobes : holes).push_back(loops[k]);
      }
      for (FlatPositions& lobe : lobes) {
        Patch l;
        l.piece = static_cast<int>(i);
        l.outline = SignedArea(lobe) < 0 ? lobe.colwise().reverse().eval() : lobe;
        l.area_m2 = l.outline_area_m2 = SignedArea(l.outline);
        a -= l.area_m2;
        if (l.area_m2 >= min_area_m2) patches.push_back(std::move(l));
      }
      Patch p;
      p.piece = static_cast<int>(i);
      p.area_m2 = a;
      p.outline = loops[outer];
      if (SignedArea(p.outline) < 0) p.outline = p.outline.colwise().reverse().eval();
      for (FlatPositions h : holes) {
        if (SignedArea(h) > 0) h = h.colwise().reverse().eval();
        p.holes.push_back(h);
      }
      auto enclosed = [&] {
        double e = SignedArea(p.outline);
        for (const FlatPositions& h : p.holes) e += SignedArea(h);
        return e;
      };
      // Fairing cuts corners off: scale about the centroid back to the triangles' area.
      const double e = enclosed();
      if (e > 0 && std::abs(e / a - 1) > 1e-3) {
        const Eigen::RowVector2d centre = p.outline.colwise().mean();
        const double s = std::sqrt(a / e);
        p.outline = ((p.outline.rowwise() - centre) * s).rowwise() + centre;
        for (FlatPositions& h : p.holes) h = ((h.rowwise() - centre) * s).rowwise() + centre;
      }
      p.outline_area_m2 = enclosed();
      patches.push_back(std::move(p));
    }
  }
  return patches;
}

}  // namespace kgd
