// Girths of the posed parametric body: the length of a plane section round a limb or a joint.
#include <algorithm>

#include "core/body/implicit_body.h"
#include "core/body/parametric_body.h"

namespace kgd {
namespace {
using body_internal::V3;

// Length of the loop where the plane through `c` with unit normal `n` cuts the posed surface, keeping
// the pieces within `cutoff` of c (the loop round one limb, not the other limbs the plane also cuts).
double SectionLength(const Positions& posed, const Faces& f, const V3& c, const V3& n, double cutoff) {
  double length = 0;
  for (Eigen::Index i = 0; i < f.rows(); ++i) {
    V3 pts[2];
    int np = 0;
    for (int k = 0; k < 3 && np < 2; ++k) {
      const V3 p = posed.row(f(i, k)), q = posed.row(f(i, (k + 1) % 3));
      const double dp = (p - c).dot(n), dq = (q - c).dot(n);
      if ((dp < 0) != (dq < 0)) pts[np++] = p + dp / (dp - dq) * (q - p);
    }
    if (np != 2) continue;
    const V3 mid = 0.5 * (pts[0] + pts[1]);
    if ((mid - c).norm() > cutoff) continue;
    length += (pts[1] - pts[0]).norm();
  }
  return length;
}

double LargestRadius(const ParametricBody& body, int bone) {
  double rmax = 0;
  for (const BodyPrimitive& p : body.primitives)
    if (p.bone == bone) rmax = std::max({rmax, p.r1_a, p.r2_a, p.r1_b, p.r2_b});
  return rmax;
}

}  // namespace

double LimbGirth(const ParametricBody& body, const JointAngles& angles, const Positions& posed, int bone, double t) {
  const auto tr = BoneTransforms(body, angles);
  const V3 a = tr[bone] * body.joint[bone], b = tr[bone] * BoneEnd(body, bone);
  return SectionLength(posed, body.rest.faces, a + t * (b - a), (b - a).normalized(), 1.5 * LargestRadius(body, bone));
}

double JointGirth(const ParametricBody& body, const JointAngles& angles, const Positions& posed, int bone) {
  const auto tr = BoneTransforms(body, angles);
  const int parent = body.parent[bone];
  const V3 joint = tr[bone] * body.joint[bone];
  const V3 toward = (joint - tr[parent] * body.joint[parent]).normalized();
  const V3 away = (tr[bone] * BoneEnd(body, bone) - joint).normalized();
  return SectionLength(posed, body.rest.faces, joint, (toward + away).normalized(),
                       1.5 * std::max(LargestRadius(body, bone), LargestRadius(body, parent)));
}

}  // namespace kgd
