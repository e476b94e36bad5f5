// Garments cut from a body, as the paper builds them: a set of body faces, optionally subdivided, whose
// rest and deformed positions are copied from the body in its rest and deformed poses (paper section
// "Initialization"). Pure geometry and validation; no files.
#pragma once

#include <Eigen/SparseCore>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

// A body moving from a rest pose to a deformed pose, optionally through frames; every pose shares the
// faces. The last frame is normally the deformed pose.
struct BodyMotion {
  Faces faces;
  Positions rest;
  Positions deformed;
  std::vector<Positions> frames;
};

// Finite coordinates and non-degenerate faces in every pose, one vertex count for all poses. `names`
// gives the file (or description) of rest, deformed and each frame for the messages.
Status ValidateBodyMotion(const BodyMotion& motion, const std::vector<std::string>& names);

// How much a motion changes the volume the body's skin encloses, at the pose that changes it most
// (rest excluded; the deformed pose and every frame). Flesh keeps its volume, so a large change says
// the posed meshes are collapsed or swollen, as linear-blend skinning collapses bent joints, and that a
// garment on them is stretched less (or more) than on the body they stand for.
struct BodyVolumeChange {
  double rest_m3 = 0;
  double pose_m3 = 0;  // at the pose furthest from rest_m3
  int frame = 0;       // that pose: 0 the deformed pose, k >= 1 frame k
  double Relative() const { return (pose_m3 - rest_m3) / rest_m3; }
};
inline constexpr double kBodyVolumeNoticeFraction = 0.03;  // a change beyond this is worth telling the user
// Empty when the body surface is not closed and consistently oriented (its volume is then undefined).
std::optional<BodyVolumeChange> MotionVolumeChange(const BodyMotion& motion);
// For people: "0.05504 m^3 at rest, 0.04939 m^3 deformed (-10.3 %)".
std::string DescribeBodyVolume(const BodyVolumeChange& c);
// Why a change beyond kBodyVolumeNoticeFraction matters, in one line; empty for a smaller change.
std::string BodyVolumeNote(const BodyVolumeChange& c);

struct GarmentCut {
  TriMesh garment;  // rest positions: from_body * motion rest
  // Garment vertex positions in any pose = from_body * body positions in that pose
  // (garment vertices x body vertices).
  Eigen::SparseMatrix<double, Eigen::RowMajor> from_body;
  std::vector<int> body_face_of;      // per garment face, the body face it subdivides
  std::vector<int> attachment_faces;  // garment faces under the attachment body faces
};

// Cuts the garment `region` (body face indices) out of the body and subdivides it `subdivisions`
// times (midpoint, 1 -> 4). `attachments` (body faces) must lie inside the region. The region must
// be one edge-connected piece; otherwise the message lists the pieces. `region_name` and
// `attachments_name` (files or keys) prefix the messages.
Result<GarmentCut> CutGarment(const Faces& body_faces, const Positions& body_rest, const std::vector<int>& region,
                              const std::vector<int>& attachments, int subdivisions, const std::string& region_name,
                              const std::string& attachments_name);

}  // namespace kgd
