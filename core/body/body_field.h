// The body as a smooth signed distance field: implicit moving least squares (IMLS) over the body
// vertices and their area-weighted normals (paper eq. IMLSField):
//   Phi(x) = sum_k phi_k(x) n_k . (x - v_k) / sum_k phi_k(x),   phi_k(x) = (1 - |x - v_k|^2 / h_k^2)^4,
// with h_k = support_scale (default 2) times the mean one-ring edge length of body vertex k. Phi is in
// metres, positive outside the body. It is defined where at least one kernel has support, i.e. within
// about h of the body surface; elsewhere Evaluate reports `supported = false`.
//
// Neighbour search uses a k-d tree (nanoflann). Each query point keeps a cached candidate list that stays
// valid while the point moves less than the cache margin from where the list was built.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

struct BodyFieldSettings {
  double support_scale = 2.0;  // h_k = support_scale * one-ring mean edge length (paper: twice)
  double cache_margin_m = 0;   // 0: a quarter of the mean support radius
};

// Candidate body vertices for one query point; owned by the caller (one per garment vertex).
struct NeighborCache {
  Eigen::Vector3d center = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::vector<int> candidates;
  int rebuilds = 0;
};

struct FieldSample {
  double phi_m = 0;
  Eigen::Vector3d grad = Eigen::Vector3d::Zero();      // dimensionless
  Eigen::Matrix3d hess = Eigen::Matrix3d::Zero();      // 1/m
  bool supported = false;
};

class BodyField {
 public:
  // Builds the field of a body surface in one pose. Fails on an invalid mesh (see ValidateMesh).
  static Result<std::shared_ptr<const BodyField>> Build(const Positions& body_vertices, const Faces& body_faces,
                                                        const BodyFieldSettings& settings = {});
  ~BodyField();

  // Phi and, on request, its gradient and Hessian at x. `cache` is refreshed when x has left its margin.
  FieldSample Evaluate(const Eigen::Vector3d& x, NeighborCache* cache, bool want_grad, bool want_hess) const;

  double mean_support_radius_m() const { return mean_h_; }
  double cache_margin_m() const { return margin_; }
  int num_vertices() const { return static_cast<int>(vertices_.rows()); }

  // Number of fields built in this process: lets tests prove that a scene without contact builds none.
  static long BuildCount();

 private:
  BodyField() = default;
  void RefreshCache(const Eigen::Vector3d& x, NeighborCache* cache) const;

  Positions vertices_;
  Positions normals_;
  Eigen::VectorXd h2_;      // squared support radius per body vertex
  Eigen::VectorXd inv_h2_;  // its inverse (0 for an isolated vertex, which is never a candidate)
  double max_h_ = 0, mean_h_ = 0, margin_ = 0;
  struct Index;
  std::unique_ptr<Index> index_;
};

// Each point moved onto the field's zero set (the smooth body surface): Newton steps along the
// gradient, x <- x - Phi grad / |grad|^2, each at most a quarter of the mean support radius long, until
// |Phi| <= 1e-12 m. For points already within the support (e.g. on the body mesh, which the IMLS
// surface smooths by a fraction of a millimetre). Errors name the point (`what` and its index) when it
// lies outside the support or the steps do not settle.
Result<Positions> PlaceOnZeroSet(const BodyField& field, const Positions& points, const std::string& what);

}  // namespace kgd
