// The studio page's region check (POST /v1/regions:check, server/http_gateway.h): a body mesh and the
// body faces painted as a garment region in, what `kgd region` would say of them out, by geometry alone
// (no simulation). It composes core's pieces, never copies them:
//   1. the body parsed from its bytes (CheckMeshBytes, ParseMesh, ValidateMesh: core/mesh/mesh_io.h);
//   2. with `mirror`, the painted faces' mirror image added: the body's faces paired about the plane
//      (PairMirrorFaces, core/beso/design_constraints.h), each painted face's partner and each face
//      whose partner is painted (the parametric body is symmetric only within the tolerance: its
//      pairing is not one-to-one); a painted face whose mirror image lies farther than
//      DefaultMirrorTolerance(body) from every face's centroid is refused, named (FaceAt);
//   3. the boundary tidied as `kgd region` tidies its rules' faces (TidyRegionBoundary, core/mesh/region.h);
//   4. CheckRegion (holes filled with `fill_holes`): a refusal is an answer (valid false) whose message
//      is `kgd region`'s words, "BODY: ...";
//   5. when valid: the attachment bands (AttachmentBands), the garment cut and subdivided (CutGarment,
//      core/scene/body_garment.h) for its vertex and face counts and for the garment faces under the
//      keep-out and keep-in body faces, and the predicted job time per quality preset (PredictJobCost,
//      core/beso/quality.h: a scene of files, at the service's machine factor).
// Errors (400 at the door) name the part and the problem: the file and line of a mesh that does not
// parse, a face index and the mesh's face count, a number that is not one, an empty region.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh/region.h"
#include "core/scene/scene.h"
#include "core/util/status.h"

namespace kgd::server {

// The request as the door receives it: the parts' texts (absent parts empty / unset).
struct RegionCheckRequest {
  std::string body_name;   // the body part's file name (.obj or .ply): format and messages
  std::string body_bytes;  // the body in its rest pose
  std::string faces;       // 0-based body face indices, whitespace separated
  std::string keep_out, keep_in;
  std::string attach_width_m;  // empty: no bands
  std::string fill_holes;      // "true" / "false" / empty
  std::string mirror;          // "true" / "false" / empty
  std::string symmetry_plane;  // "X,Y,Z,NX,NY,NZ"; empty: the parametric body's sagittal plane x = 0
  std::string subdivisions;    // integer in [0, 4]; empty: 1
  std::string frames;          // integer >= 0; empty: 0
  std::string motions;         // the motions a design weighs, integer >= 1; empty: 1
  std::string budget;          // reinforced area fraction in (0, 1]; empty: BesoSettings' default
  // The service's limits (ServiceLimits, --max-mesh-vertices, --max-mesh-faces; 0: none) on the body and
  // on the garment cut from it (faces x 4^subdivisions): beyond them the check is refused.
  int64_t max_mesh_vertices = 0, max_mesh_faces = 0;
};

struct RegionCheckAnswer {
  std::vector<int> faces;         // ascending, after mirror, tidy and fill
  std::vector<int> filled_faces;  // of them, those fill_holes added
  bool mirrored = false;
  bool valid = false;
  std::string refusal;  // when !valid: CheckRegion's message as `kgd region` prints it ("BODY: ...")
  // When valid:
  Region region;
  std::vector<AttachmentBand> bands;  // with an attachment width
  int subdivided_vertices = 0, subdivided_faces = 0;
  std::vector<int> keep_out, keep_in;                               // body faces (mirrored with mirror), ascending
  std::vector<int> keep_out_garment_faces, keep_in_garment_faces;  // garment faces under them, ascending
  // Seconds of the whole job per preset name (draft, standard, precise); with an invalid region from
  // the faces the garment would have (faces x 4^subdivisions).
  std::map<std::string, double> predicted_job_s;
};

// `machine_factor`: the service's (JobService::ListScenes' machine_factor).
Result<RegionCheckAnswer> CheckPaintedRegion(const RegionCheckRequest& request, double machine_factor);

}  // namespace kgd::server
