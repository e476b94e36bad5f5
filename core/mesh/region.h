// Garment regions on a body mesh chosen by rules instead of written as face lists, and the checks a
// region must pass before a garment is cut from it (core/scene/body_garment.h). `kgd region`
// (client/region_command.h) is the command around this module. Distances in metres.
//
// A RegionSpec is a list of groups. Each group starts from every face of the body and applies its rules
// in order, each keeping some of the faces the group holds:
// - PlaneRule: the faces whose centroid lies on the plane or on the side its normal points to;
// - GeodesicRule: the faces whose centroid lies within radius_m of the centre along the body's surface
//   (GeodesicDistances from the point of the surface nearest the centre; the centroid's distance is the
//   mean of its corners');
// - NearRule: the edge-connected piece of the faces held so far nearest the point.
// The groups combine left to right: the first is the start, every later one is added to (kUnion) or
// removed from (kSubtract) the faces before it. The result's boundary is then tidied (notches filled,
// ears removed: RegionSpec::tidy_boundary).
//
// CheckRegion refuses what cannot be cut as one garment, naming a face and a point (x, y, z) for each:
// a region that is not one edge-connected piece, not manifold (an edge with more than two of its faces,
// or faces meeting at a vertex only: a pinch), that has a hole or a sliver. Definitions:
// - a hole is a boundary loop whose outside (the body faces outside the region that the loop borders,
//   one edge-connected piece) has less area than max_hole_area_m2, or a loop on the body mesh's own
//   boundary (an opening of the mesh). A sleeve's ends border the rest of the body and the hand:
//   openings, not holes. fill_holes adds the outsides of holes to the region instead;
// - a sliver is a place where the region is one face wide: an interior edge of the region whose two
//   ends lie on the boundary more than kSliverLoopSteps boundary edges apart both ways round their
//   loop, or on two loops (a strip of triangles whose every face touches both sides). A corner's ear
//   (2 steps) or a one-quad tooth (3) is no sliver.
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

struct PlaneRule {
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();  // any length but zero
};
struct GeodesicRule {
  Eigen::Vector3d centre_m = Eigen::Vector3d::Zero();
  double radius_m = 0;  // > 0
};
struct NearRule {
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();
};
using RegionRule = std::variant<PlaneRule, GeodesicRule, NearRule>;

enum class RegionOp { kUnion, kSubtract };
struct RegionGroup {
  RegionOp op = RegionOp::kUnion;  // ignored for the first group
  std::vector<RegionRule> rules;   // at least one
};
struct RegionSpec {
  std::vector<RegionGroup> groups;
  bool tidy_boundary = true;  // tidy the result's boundary (below)
};

// Selecting faces by their centroids leaves a zigzag edge where a plane or a disc's rim crosses
// triangulated quads (every other triangle in: about twice the length of a straight cut, on the
// MakeHuman arm). Tidying adds every face outside with two or more edges on the region (a notch) and
// then removes every face inside with one or none (an ear), in rounds until nothing changes (at most
// kTidyRounds).
inline constexpr int kTidyRounds = 20;

// `region` (body faces) with its boundary tidied as SelectRegion tidies its rules' faces; ascending
// (empty when every face was on its own or an ear). For faces chosen otherwise, e.g. painted.
std::vector<int> TidyRegionBoundary(const Faces& faces, const std::vector<int>& region);

// A rule as `kgd region` spells it, e.g. "--plane -0.255,1.244,0.017,-0.73,-0.67,0.15".
std::string DescribeRule(const RegionRule& rule);

// The faces a spec selects, ascending. Refused: a spec without rules, a zero normal, a radius <= 0, a
// geodesic centre farther from the surface than its radius, and a rule that leaves its group no face
// (the message names the rule) or a spec that selects none.
Result<std::vector<int>> SelectRegion(const TriMesh& body, const RegionSpec& spec);

// Distances along the surface (m) from `sources` (vertex, distance at it) to every vertex: Dijkstra's
// order with the fast-marching update across triangles (Kimmel and Sethian 1998): a vertex's distance
// through a face whose other two corners are known, from the planar unfolding of that face when the
// straight path crosses the edge between them, else along an edge. On a flat grid of right triangles
// it is within 0.1 % of the straight-line distance (region_test); plain Dijkstra on the edges is 41 %
// long there across the diagonals (a disc of radius R gets 77 % of pi R^2). Vertices not reached:
// +infinity.
Eigen::VectorXd GeodesicDistances(const Positions& x, const Faces& faces, const std::vector<std::pair<int, double>>& sources);

// The point of the surface nearest `p`: its face, the point and the distance (m). With `in` (one entry
// per face), only faces with in[f] count. Precondition: at least one face counts.
struct SurfacePoint {
  int face = -1;
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();
  double distance_m = 0;
};
SurfacePoint NearestSurfacePoint(const Positions& x, const Faces& faces, const Eigen::Vector3d& p, const std::vector<char>& in = {});

inline constexpr double kDefaultMaxHoleArea_m2 = 20e-4;  // 20 cm^2
inline constexpr int kSliverLoopSteps = 3;
struct RegionCheckOptions {
  double max_hole_area_m2 = kDefaultMaxHoleArea_m2;
  bool fill_holes = false;
};

struct RegionLoop {
  std::vector<int> vertices;  // body vertices, in the faces' orientation
  double length_m = 0;
  Eigen::Vector3d centre_m = Eigen::Vector3d::Zero();  // length-weighted mean of its edges' midpoints
  double outside_area_m2 = 0;  // area of the body faces outside the region that it borders
};
struct Region {
  std::vector<int> faces;         // ascending body face indices
  std::vector<int> filled_faces;  // of them, those fill_holes added (ascending)
  int vertices = 0;
  double area_m2 = 0;
  std::vector<RegionLoop> loops;  // its boundary loops (a closed region has none)
};

// Checks `faces` (body face indices) as a garment region (the header's definitions) and describes it.
Result<Region> CheckRegion(const TriMesh& body, const std::vector<int>& faces, const RegionCheckOptions& options = {});

// Attachment bands: for each boundary loop of a checked region, the region's faces whose centroid lies
// within width_m of the loop along the region's surface (GeodesicDistances on the region alone; the
// centroid's distance is the mean of its corners'). A band with no face (width_m below a third of the
// faces' size along the loop) is refused naming the loop.
struct AttachmentBand {
  int loop = 0;            // index into Region::loops
  std::vector<int> faces;  // ascending body face indices
  double area_m2 = 0;
};
Result<std::vector<AttachmentBand>> AttachmentBands(const TriMesh& body, const Region& region, double width_m);

// "face 12 at (-0.3210, 1.1800, 0.0310) m": a face and its centroid, for messages.
std::string FaceAt(const Positions& x, const Faces& faces, int face);

}  // namespace kgd
