// The parametric body's inner parts, shared by its implementation files (not part of kgd's interface):
// the skeleton's angle helpers and the implicit surface of the body in one pose (PosedField), built
// from the primitives of a ParametricBody.
#pragma once

#include <Eigen/Geometry>
#include <numbers>
#include <string>
#include <vector>

#include "core/body/parametric_body.h"

namespace kgd::body_internal {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDeg = kPi / 180.0;
using V3 = Eigen::Vector3d;

// Rotations about the axes (rad).
inline Eigen::Matrix3d Rx(double a) { return Eigen::AngleAxisd(a, V3::UnitX()).toRotationMatrix(); }
inline Eigen::Matrix3d Ry(double a) { return Eigen::AngleAxisd(a, V3::UnitY()).toRotationMatrix(); }
inline Eigen::Matrix3d Rz(double a) { return Eigen::AngleAxisd(a, V3::UnitZ()).toRotationMatrix(); }

// A joint angle (rad) as given, or its rest value; and relative to the rest pose, what the skeleton
// rotates by.
double Angle(const JointAngles& angles, const std::string& name);
double Rel(const JointAngles& angles, const std::string& name);

// Polynomial smooth minimum with blend radius k (a plain min for k <= 0).
double SmoothMin(double a, double b, double k);

// Everything about a primitive the evaluation needs, including its cap semi-axes.
struct Prim {
  BodyPrimitive p;
  double cap_a, cap_b;
  std::string group;  // primitives of one group are joined first (a chain), groups then blend
};

// Distance-like value of one primitive at rest-space point q; `bulge` >= 0 widens it.
double PrimitiveValue(const BodyPrimitive& p, double cap_a, double cap_b, double bulge, const V3& q);
// The full primitive records: cap semi-axes and blend groups follow from the bone kind, so that
// BodyPrimitive stays a plain description.
std::vector<Prim> Prims(const ParametricBody& body);
// Bend of a joint (rad): the rotation between the two bones' frames, 0 for a straight chain.
double Bend(const Eigen::Isometry3d& parent, const Eigen::Isometry3d& child);
// Blend radius inside a chain grows with the joint's bend away from rest: a fillet where the inner
// sides of a bent elbow or knee meet, nothing (a plain union) for a straight chain.
double ChainBlend(const Eigen::Isometry3d& parent, const Eigen::Isometry3d& child);
// Blend radii between groups (m, before scaling by height).
double GroupBlend(const std::string& g);

// The implicit body with everything precomputed for one pose.
class PosedField {
 public:
  PosedField(const ParametricBody& body, const JointAngles& angles) : prims_(Prims(body)) {
    const auto t = BoneTransforms(body, angles);
    const double s = body.measurements.height_m / 1.70;
    for (const Prim& p : prims_) {
      inverse_.push_back(t[p.p.bone].inverse());
      bulge_.push_back(p.p.bulge_joint.empty() ? 0.0 : p.p.bulge_per_rad * std::max(0.0, Rel(angles, p.p.bulge_joint)));
    }
    // Groups in order of first appearance; inside a group, blend radius from the bend between
    // consecutive members.
    for (size_t i = 0; i < prims_.size(); ++i) {
      int g = -1;
      for (size_t k = 0; k < groups_.size(); ++k)
        if (group_names_[k] == prims_[i].group) g = static_cast<int>(k);
      if (g < 0) {
        g = static_cast<int>(groups_.size());
        groups_.emplace_back();
        group_names_.push_back(prims_[i].group);
        // The groin keeps its rest fillet at any hip flexion: real flesh folds away in the flexed groin,
        // and a fillet widening with the flexion adds skin there for a garment to cover (twice the fully
        // reinforced crouch's energy, docs/BODIES.md).
        group_blend_.push_back(GroupBlend(prims_[i].group) * s);
      }
      ChainLink link;
      if (!groups_[g].empty()) {
        const Prim& prev = prims_[groups_[g].back().index];
        link.blend = ChainBlend(t[prev.p.bone], t[prims_[i].p.bone]) * s;
        // Posed joint and the bisector of the joint's concave side: where the fillet belongs.
        link.joint = t[prims_[i].p.bone] * prims_[i].p.a;
        const V3 toward = t[prev.p.bone].linear() * (prev.p.b - prev.p.a).normalized();
        const V3 away = t[prims_[i].p.bone].linear() * (prims_[i].p.b - prims_[i].p.a).normalized();
        const V3 inner = away - toward;
        link.inner = inner.norm() > 1e-9 ? V3(inner.normalized()) : V3::Zero();
        const V3 along = away + toward;
        link.along = along.norm() > 1e-9 ? V3(along.normalized()) : V3::Zero();
        // The crease flattens: where forearm meets biceps (calf meets thigh) the flesh gives way, so
        // the girth round a bent joint stays what it was. Two rigid round limbs meeting at a bend
        // theta have a concave side reaching r / cos(theta / 2) from the joint instead of r, and the
        // fillet swells it by a quarter of its radius more; the pinch takes both back, fading over
        // 1.25 r on either side of the bisector plane. Without it the sleeve of a bent elbow is
        // stretched 1.2-1.35 all round (the MakeHuman elbow: 1.00-1.03), see docs/RESULTS.md.
        const double bend = std::min(Bend(t[prev.p.bone], t[prims_[i].p.bone]), 150 * kDeg);
        const double r = 0.5 * (prev.cap_b + prims_[i].cap_a);
        link.pinch = r * (1.0 / std::cos(0.5 * bend) - 1.0) + 0.25 * link.blend;
        link.pinch_width = 1.25 * r;
      }
      link.index = static_cast<int>(i);
      groups_[g].push_back(link);
    }
  }
  double operator()(const V3& x) const {
    double f = 0;
    for (size_t g = 0; g < groups_.size(); ++g) {
      double gv = 0;
      for (size_t m = 0; m < groups_[g].size(); ++m) {
        const ChainLink& link = groups_[g][m];
        const Prim& p = prims_[link.index];
        const double v = PrimitiveValue(p.p, p.cap_a, p.cap_b, bulge_[link.index], inverse_[link.index] * x);
        if (m == 0) {
          gv = v;
          continue;
        }
        const double concave = ConcaveWeight(link, x);
        gv = SmoothMin(gv, v, link.blend * concave);
        const double a = (x - link.joint).dot(link.along) / link.pinch_width;
        if (link.pinch > 0 && std::abs(a) < 1) gv += link.pinch * concave * (1 - a * a) * (1 - a * a);
      }
      f = g == 0 ? gv : SmoothMin(f, gv, group_blend_[g]);
    }
    return f;
  }
  V3 Gradient(const V3& x) const {
    const double h = 1e-6;
    V3 g;
    for (int k = 0; k < 3; ++k) {
      V3 a = x, b = x;
      a[k] += h;
      b[k] -= h;
      g[k] = ((*this)(a) - (*this)(b)) / (2 * h);
    }
    return g;
  }
  // Tangential smoothing on the level set: each active vertex moves halfway to its neighbours' mean,
  // within the tangent plane, and is projected back. Evens out triangle sizes and unfolds pinches.
  // With `rest`, each vertex moves instead by `step` (in (0, 1]) of the way towards where its edges
  // would have their rest lengths (a spring relaxation): the skin keeps its metric where it slides,
  // rather than evening out triangle sizes, which stretches compressed skin sideways. A tangential
  // step is short against the surface's curvature, so one Newton step along the normal keeps the
  // vertex on the surface until the last iteration projects it fully.
  void Relax(Positions* x, const std::vector<std::vector<int>>& nbrs, const std::vector<int>& active, int iterations,
             const Positions* rest = nullptr, double step = 0.5) const {
    Positions next = *x;
    for (int it = 0; it < iterations; ++it) {
#pragma omp parallel for schedule(static)
      for (size_t i = 0; i < active.size(); ++i) {
        const int v = active[i];
        if (nbrs[v].empty()) continue;
        const V3 p = x->row(v).transpose();
        V3 mean = V3::Zero();
        for (int w : nbrs[v]) {
          const V3 q = x->row(w).transpose();
          if (rest == nullptr) {
            mean += q;
            continue;
          }
          const V3 e = p - q;
          const double len = e.norm();
          mean += len > 1e-12 ? V3(q + (rest->row(v) - rest->row(w)).norm() / len * e) : p;
        }
        mean /= static_cast<double>(nbrs[v].size());
        V3 n = Gradient(p);
        if (n.norm() < 1e-9) continue;
        n.normalize();
        V3 d = mean - p;
        d -= d.dot(n) * n;
        if (rest == nullptr) {
          next.row(v) = Project(p + 0.5 * d).transpose();
        } else {
          const V3 y = p + step * d;
          next.row(v) = (y - (*this)(y) * n).transpose();
        }
      }
      for (int v : active) x->row(v) = next.row(v);
    }
    if (rest != nullptr)
      for (int v : active) x->row(v) = Project(x->row(v).transpose()).transpose();
  }
  // Of the faces `candidates`, those whose normal points into the body (folded over) or that have
  // collapsed.
  std::vector<int> FoldedFaces(const Positions& x, const Faces& faces, const std::vector<int>& candidates, double min_area) const {
    std::vector<char> bad(candidates.size(), 0);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < candidates.size(); ++i) {
      const int f = candidates[i];
      const V3 a = x.row(faces(f, 0)), b = x.row(faces(f, 1)), c = x.row(faces(f, 2));
      const V3 n = (b - a).cross(c - a);
      bad[i] = 0.5 * n.norm() < min_area || n.dot(Gradient((a + b + c) / 3.0)) <= 0;
    }
    std::vector<int> out;
    for (size_t i = 0; i < candidates.size(); ++i)
      if (bad[i]) out.push_back(candidates[i]);
    return out;
  }
  // Newton steps along the gradient onto the zero level set.
  V3 Project(V3 x) const {
    for (int it = 0; it < 8; ++it) {
      const double f = (*this)(x);
      if (std::abs(f) < 1e-9) break;
      const V3 g = Gradient(x);
      const double g2 = g.squaredNorm();
      if (g2 < 1e-12) break;
      x -= f * g / g2;
    }
    return x;
  }

 private:
  std::vector<Prim> prims_;
  std::vector<Eigen::Isometry3d> inverse_;
  std::vector<double> bulge_;
  // A chain member: its primitive and the fillet joining it to the previous member.
  struct ChainLink {
    int index = 0;
    double blend = 0;            // fillet radius (m) at the concave side
    V3 joint = V3::Zero();       // posed joint centre
    V3 inner = V3::Zero();       // unit bisector of the concave side; zero for a straight joint
    V3 along = V3::Zero();       // unit normal of the plane bisecting the bend
    double pinch = 0;            // depth (m) the concave side is drawn in by, at the bisecting plane
    double pinch_width = 1;      // distance (m) from that plane over which the pinch fades out
  };
  // The fillet is confined to the concave side of a bent joint. A blend radius applied all around
  // would swell the joint: where two round cones overlap, smooth-min pushes the surface out by up to
  // a quarter of the radius on every side, and a sleeve over a bent elbow would be stretched 30-40 %
  // around its circumference (the MakeHuman elbow: ~0 %).
  static double ConcaveWeight(const ChainLink& link, const V3& x) {
    const V3 d = x - link.joint;
    const double n = d.norm();
    if (n < 1e-12) return 1.0;
    const double c = link.inner.dot(d) / n;
    return std::max(0.0, c) * std::max(0.0, c);
  }
  std::vector<std::vector<ChainLink>> groups_;
  std::vector<std::string> group_names_;
  std::vector<double> group_blend_;
};

}  // namespace kgd::body_internal
