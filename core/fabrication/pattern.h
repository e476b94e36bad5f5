// Pattern pieces: a garment's rest shape cut along seams into topological disks and flattened, the way
// a maker cuts stretch fabric. Pure geometry (no files); SI units (m) throughout.
//
// Seams: a garment with one boundary loop and no handles is a disk already (a flat sample, a patch);
// one with several loops (a sleeve has two; shorts three; a shirt four) is cut along shortest paths
// that join every loop to the first, through the least-strained cloth when a strain field is given
// (seams where the garment works least). Flattening starts from CGAL's least-squares conformal map
// (Surface_mesh_parameterization, LSCM) and refines all pieces together by local/global steps (as in
// ARAP, with a free boundary and free scale) towards a map that keeps every triangle's area first and
// its angles second, with the two sides of every seam held to equal lengths edge by edge, so that
// pieces sew together as they were cut.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

using FlatPositions = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

// How far a flat piece is from its 3D shape, per face: area |A_flat / A_3d - 1| and the largest corner
// angle change (degrees); area-weighted means and maxima over the piece.
struct Distortion {
  double area_mean = 0, area_max = 0;
  double angle_mean_deg = 0, angle_max_deg = 0;
};
Distortion MeasureDistortion(const Positions& x, const Faces& faces, const FlatPositions& uv);

// One pattern piece: garment faces, its own vertices (a garment vertex on a seam appears once per side),
// its rest shape and flat shape.
struct PatternPiece {
  std::vector<int> garment_faces;   // faces of the garment, in the piece's face order
  std::vector<int> garment_vertex;  // piece vertex -> garment vertex
  Faces faces;                      // over piece vertices
  Positions rest;                   // 3D rest positions (m)
  FlatPositions flat;               // flat positions (m)
  Distortion distortion;
  std::vector<int> outline;         // piece vertices around the boundary, counter-clockwise in flat
  // The sew line (core/fabrication/sew_line.h): the outline faired between its corners, a point about
  // every millimetre, closed and counter-clockwise; sewn and cut along, where the outline steps at every
  // mesh edge.
  FlatPositions sew_line;
  std::vector<int> sew_at;          // outline vertex k -> its point on the sew line (corners exactly)
  std::vector<int> sew_corners;     // sew line points that are corners (seam ends, where seams meet)
  double sew_turning_max_deg = 0;   // the largest turn between consecutive segments away from corners
  double sew_deviation_max_mm = 0;  // the farthest sew line point from the outline, on the body
};

// A seam: garment vertices along mesh edges; the two sides of every edge are sewn together.
struct Seam {
  std::vector<int> vertices;
};

struct Pattern {
  std::vector<PatternPiece> pieces;
  std::vector<Seam> seams;
};

struct PatternOptions {
  // Seams given by the user (garment vertex paths along edges); empty: chosen as above.
  std::vector<Seam> seams;
  // Per garment face, how hard the cloth works (e.g. energy density); seams avoid high values. Empty:
  // shortest paths by length alone.
  Eigen::VectorXd strain;
  // Distortion limits: a sleeve (two boundary loops, seams chosen) whose one piece exceeds them is cut
  // into two along a second seam opposite the first.
  double max_area_distortion_mean = 0.02, max_area_distortion_max = 0.05, max_angle_distortion_mean_deg = 2;
};

// Cuts `garment` (rest shape) into disks, flattens each and fairs its sew line. Errors name the problem: a closed garment,
// a handle, a seam that is not a path along edges, a piece that is not a disk.
Result<Pattern> CutPattern(const TriMesh& garment, const PatternOptions& options = {});

// Signed area of a closed polygon (positive: counter-clockwise).
double SignedArea(const FlatPositions& polygon);

}  // namespace kgd
