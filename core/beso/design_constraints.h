// Design constraints of a BESO job: keep-out faces (never reinforced), keep-in faces (always
// reinforced, counted in the budget) and mirror symmetry (every design equal on a face and its
// mirror image). BESO then decides on units instead of faces: a unit is a face, or with symmetry a
// group of faces joined by the mirror pairing; keep-out faces belong to no unit and stay cloth.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/scene/scene.h"
#include "core/util/status.h"

namespace kgd {

// The mirror pairing of a garment's faces. mirror[f]: the face whose rest centroid is nearest to the
// mirror image of f's (ties to the lower index). On a mirror-symmetric mesh `mirror` is an involution
// and the groups are pairs (a face the plane cuts in two halves is its own mirror). On a mesh that is
// symmetric only within the tolerance (the parametric body: its surface-nets grid is not centred on
// the sagittal plane) `mirror` need not be one-to-one; the groups are then the connected components
// of f -- mirror[f], so that a design constant on each group satisfies design[f] == design[mirror[f]].
struct MirrorPairing {
  std::vector<int> mirror;               // per face
  std::vector<std::vector<int>> groups;  // faces in increasing order; groups ordered by their first face
  double tolerance_m = 0;                // the tolerance used
  double max_distance_m = 0;             // the largest distance of a mirrored centroid to its partner's
};

// Twice the mean rest edge length: the default tolerance of SymmetryPlane.
double DefaultMirrorTolerance(const TriMesh& rest);

// Pairs the faces of `rest` about `plane` (normal of any non-zero length). Error when a face's mirrored
// centroid is farther than the tolerance from every centroid: the message names the plane, the
// tolerance and the unmatched faces (the first 20 and their count).
Result<MirrorPairing> PairMirrorFaces(const TriMesh& rest, const SymmetryPlane& plane);

// What BESO decides on. Built once per job.
struct DesignUnits {
  std::vector<std::vector<int>> members;  // faces of each unit, increasing; keep-out faces in none
  std::vector<uint8_t> locked;            // per unit: stays reinforced (keep-in, or kept attachments)
  std::vector<uint8_t> keep_out;          // per face: never reinforced
  std::vector<int> unit_of;               // per face: its unit, -1 for keep-out faces
  const MirrorPairing* pairing = nullptr; // with symmetry; not owned
};

// Units of an `nf`-face garment: a keep-out (keep-in) face makes its whole mirror group keep-out
// (keep-in); `locked_faces` (kept attachments) lock their units too. Errors name the faces: an index
// out of range, a face (or mirror group) both kept out and kept in, a kept attachment kept out.
Result<DesignUnits> MakeDesignUnits(int nf, const std::vector<int>& keep_out, const std::vector<int>& keep_in,
                                    const std::vector<int>& locked_faces, const MirrorPairing* pairing);

// The fully reinforced design under the constraints: reinforced but for the keep-out faces.
std::vector<uint8_t> FullDesign(const DesignUnits& units);

// Per face: the area-weighted mean of `face_values` over the face's mirror group (unchanged without
// symmetry). Makes the sensitivities symmetric before the design update.
Eigen::VectorXd SymmetrizeOverGroups(const Eigen::VectorXd& face_values, const Eigen::VectorXd& face_area, const DesignUnits& units);

// UpdateDesign (core/beso/beso.h) on the units: a unit's sensitivity is its faces' area-weighted mean,
// its area their sum, and every face of a unit takes the unit's decision; keep-out faces stay cloth.
// The reinforced area is within half the largest unit's area of the target (as the elements allow).
std::vector<uint8_t> UpdateDesignOnUnits(const DesignUnits& units, const Eigen::VectorXd& sensitivity, const Eigen::VectorXd& face_area,
                                         const std::vector<uint8_t>& design, double target_area_m2, double max_admitted_m2);

// Reinforced area of the locked units (m^2).
double LockedArea(const DesignUnits& units, const Eigen::VectorXd& face_area);
// Area of the keep-out faces (m^2).
double KeptOutArea(const DesignUnits& units, const Eigen::VectorXd& face_area);

// Ok when `design` keeps the constraints: keep-out faces cloth, locked units reinforced, every unit
// uniform (with symmetry: design[f] == design[mirror[f]] for every face). Else names the first face.
Status CheckDesignConstraints(const DesignUnits& units, const std::vector<uint8_t>& design);

}  // namespace kgd
