// Procedural geometry for built-in scenes and tests: the pull-test sample of the paper's 2D validation
// and a capsule-like limb whose joint flexes, with a sleeve taken from its surface.
#pragma once

#include <vector>

#include "core/mesh/trimesh.h"

namespace kgd {

// Rectangular grid in the XZ plane (y = 0): x in [0, width], z in [0, length], square cells of `spacing`
// split by the "/" diagonal, as in the authors' 2D sample (10 x 14 cm, 2.5 mm: 41 x 57 vertices).
TriMesh RectangleSheet(double width_m, double length_m, double spacing_m);

// Closed box [0, x] x [0, y] x [0, z] of twelve triangles, normals outward.
TriMesh BoxSurface(double x_m, double y_m, double z_m);

struct LimbShape {
  double radius_m = 0.04;          // tube radius away from the joint
  double length_m = 0.36;          // length of the cylindrical part (caps added at both ends)
  double waist_depth = 0.12;       // relative radial dip at the joint (a concavity the cloth can bridge)
  double waist_halfwidth_m = 0.04;
  double joint_length_m = 0.10;    // length over which the centreline bends
  int around = 32;                 // vertices per ring
  double spacing_m = 0.0;          // axial spacing; 0: the arc length between ring vertices
};

// Closed capsule along +y centred at the origin. Vertices are rings (bottom pole first); `axial` (if given)
// receives each vertex's rest axial coordinate (m), used to select garment regions.
TriMesh LimbRest(const LimbShape& shape, std::vector<double>* axial = nullptr);

// The rest limb with its joint flexed by `angle_rad`: the centreline bends about the x axis towards +z
// over the joint length, cross-sections stay perpendicular to it.
Positions LimbPosed(const LimbShape& shape, const Positions& rest, double angle_rad);

}  // namespace kgd
