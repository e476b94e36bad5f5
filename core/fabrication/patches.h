// Reinforcement for manufacture: a design cleaned of what a cutter cannot make, and its reinforced
// regions as patches in the flat coordinates of the pattern pieces. Pure geometry; SI units (m).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/fabrication/pattern.h"
#include "core/mesh/trimesh.h"

namespace kgd {

struct CleaningOptions {
  double min_feature_m = 0.003;  // reinforced features thinner than this are removed
  double min_area_m2 = 0;        // islands and holes smaller than this go; 0: (2 x min_feature)^2
};

struct CleanedDesign {
  std::vector<uint8_t> design;
  double removed_m2 = 0;  // reinforced area dropped (islands, thin features)
  double added_m2 = 0;    // holes filled
  int islands_removed = 0, holes_filled = 0;
};

// Measured on the rest shape: reinforced islands and cloth holes (cloth regions that touch no garment
// edge) smaller than min_area go, then a morphological opening by min_feature (faces farther than
// min_feature / 2 from the cloth survive the erosion; reinforced faces within min_feature / 2 of a
// survivor come back) removes what is thinner than min_feature. `keep` (optional, per face) marks faces
// that stay as they are (attachments).
CleanedDesign CleanDesign(const TriMesh& rest, const std::vector<uint8_t>& design, const CleaningOptions& options,
                          const std::vector<uint8_t>& keep = {});

// One reinforcement patch: an edge-connected reinforced region of one pattern piece, as a smooth
// outline (counter-clockwise) with its holes (clockwise), in the piece's flat coordinates (m).
struct Patch {
  int piece = 0;
  FlatPositions outline;
  std::vector<FlatPositions> holes;
  double area_m2 = 0;            // of the triangles (the design's area on the flat piece)
  double outline_area_m2 = 0;    // enclosed by the smoothed outline minus its holes
};

// Patches of every piece. `include` (optional, per garment face) leaves faces out (clamp strips of a
// test sample); pieces of patches smaller than min_area_m2 (slivers a seam cut off) are left out.
// Outlines are the triangle staircase faired by Taubin smoothing (straight runs and the corners between
// them stay) and rescaled about their centroid so the area stays that of the triangles.
std::vector<Patch> ReinforcementPatches(const Pattern& pattern, const std::vector<uint8_t>& design, const std::vector<uint8_t>& include = {},
                                        double min_area_m2 = 0);

}  // namespace kgd
