// Pattern pieces as data: a piece's faces, its rest and flat shapes, its outline and sew line, and the
// seams between pieces. What core/fabrication/pattern.h cuts and core/fabrication/sew_line.h fairs.
// SI units (m) unless a name says mm or deg.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/mesh/trimesh.h"

namespace kgd {

using FlatPositions = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

// How far a flat piece is from its 3D shape, per face: area |A_flat / A_3d - 1| and the largest corner
// angle change (degrees); area-weighted means and maxima over the piece.
struct Distortion {
  double area_mean = 0, area_max = 0;
  double angle_mean_deg = 0, angle_max_deg = 0;
};

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

}  // namespace kgd
