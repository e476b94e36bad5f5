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

#include "core/fabrication/pattern_piece.h"
#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

// How far a flat piece is from its 3D shape (Distortion, core/fabrication/pattern_piece.h).
Distortion MeasureDistortion(const Positions& x, const Faces& faces, const FlatPositions& uv);

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
