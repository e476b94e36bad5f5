#include "core/mesh/trimesh.h"

#include <Eigen/Geometry>
#include <cmath>
#include <locale>
#include <sstream>

namespace kgd {

Eigen::VectorXd FaceAreas(const Positions& x, const Faces& faces) {
  Eigen::VectorXd areas(faces.rows());
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Eigen::Vector3d a = x.row(faces(f, 0)), b = x.row(faces(f, 1)), c = x.row(faces(f, 2));
    areas[f] = 0.5 * (b - a).cross(c - a).norm();
  }
  return areas;
}

Eigen::VectorXd LumpedVertexAreas(const Positions& x, const Faces& faces) {
  const Eigen::VectorXd face = FaceAreas(x, faces);
  Eigen::VectorXd out = Eigen::VectorXd::Zero(x.rows());
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) out[faces(f, k)] += face[f] / 3.0;
  return out;
}

double EnclosedVolume(const Positions& x, const Faces& faces) {
  if (faces.rows() == 0) return 0.0;
  // Tetrahedra from a point near the surface rather than the origin: the same sum, less cancellation
  // for a body far from the origin.
  const Eigen::RowVector3d o = x.colwise().mean();
  double six_v = 0.0;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Eigen::Vector3d a = (x.row(faces(f, 0)) - o).transpose(), b = (x.row(faces(f, 1)) - o).transpose(),
                          c = (x.row(faces(f, 2)) - o).transpose();
    six_v += a.dot(b.cross(c));
  }
  return six_v / 6.0;
}

double MeanEdgeLength(const Positions& x, const Faces& faces) {
  if (faces.rows() == 0) return 0.0;
  double sum = 0.0;
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) sum += (x.row(faces(f, k)) - x.row(faces(f, (k + 1) % 3))).norm();
  return sum / (3.0 * faces.rows());
}

Positions AreaWeightedVertexNormals(const Positions& x, const Faces& faces) {
  Positions n = Positions::Zero(x.rows(), 3);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Eigen::Vector3d a = x.row(faces(f, 0)), b = x.row(faces(f, 1)), c = x.row(faces(f, 2));
    const Eigen::Vector3d area_normal = 0.5 * (b - a).cross(c - a);  // length = face area
    for (int k = 0; k < 3; ++k) n.row(faces(f, k)) += area_normal.transpose();
  }
  for (Eigen::Index v = 0; v < n.rows(); ++v) {
    const double len = n.row(v).norm();
    if (len > 0) n.row(v) /= len;
  }
  return n;
}

Eigen::VectorXd OneRingMeanEdgeLength(const Positions& x, const Faces& faces) {
  // Each interior edge is seen from two faces; counting it twice at both ends keeps the mean exact.
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(x.rows()), count = Eigen::VectorXd::Zero(x.rows());
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int i = faces(f, k), j = faces(f, (k + 1) % 3);
      const double len = (x.row(i) - x.row(j)).norm();
      sum[i] += len; sum[j] += len; count[i] += 1; count[j] += 1;
    }
  for (Eigen::Index v = 0; v < x.rows(); ++v) sum[v] = count[v] > 0 ? sum[v] / count[v] : 0.0;
  return sum;
}

Positions FaceCentroids(const Positions& x, const Faces& faces) {
  Positions c(faces.rows(), 3);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) c.row(f) = (x.row(faces(f, 0)) + x.row(faces(f, 1)) + x.row(faces(f, 2))) / 3.0;
  return c;
}

Positions FaceCentroids(const Positions& x, const Faces& faces, const std::vector<int>& face_ids) {
  Positions c(face_ids.size(), 3);
  for (size_t i = 0; i < face_ids.size(); ++i) {
    const int f = face_ids[i];
    c.row(i) = (x.row(faces(f, 0)) + x.row(faces(f, 1)) + x.row(faces(f, 2))) / 3.0;
  }
  return c;
}

Status ValidateMesh(const Positions& x, const Faces& faces, const std::string& name) {
  const std::string prefix = name.empty() ? "" : name + ": ";
  if (x.rows() == 0) return Status::Error(prefix + "mesh has no vertices");
  if (faces.rows() == 0) return Status::Error(prefix + "mesh has no faces");
  for (Eigen::Index v = 0; v < x.rows(); ++v)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(x(v, k))) {
        std::ostringstream os;
        os << prefix << "vertex " << v << " has a non-finite coordinate (" << x(v, 0) << ", " << x(v, 1) << ", "
           << x(v, 2) << ")";
        return Status::Error(os.str());
      }
  // Bodies and garments are metres across: a mesh hundreds of metres across was written in millimetres
  // (or centimetres), and simulating it would give plausible-looking nonsense.
  const double across = (x.colwise().maxCoeff() - x.colwise().minCoeff()).norm();
  if (across > kMaxMeshExtent_m) {
    std::ostringstream os;
    os.imbue(std::locale::classic());
    const long long metres = std::llround(across);
    std::string digits = std::to_string(metres), grouped;
    for (size_t i = 0; i < digits.size(); ++i) {
      if (i > 0 && (digits.size() - i) % 3 == 0) grouped += ',';
      grouped += digits[i];
    }
    // The likelier unit first: a body is about 2 m across, 200 in centimetres, 2,000 in millimetres.
    os << prefix << "the mesh is " << grouped << " m across, but kgd reads metres (SI): "
       << (across > 1000 ? "millimetres? scale the mesh by 0.001 (centimetres: 0.01)" : "centimetres? scale the mesh by 0.01 (millimetres: 0.001)");
    return Status::Error(os.str());
  }
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    for (int k = 0; k < 3; ++k)
      if (faces(f, k) < 0 || faces(f, k) >= x.rows()) {
        std::ostringstream os;
        os << prefix << "face " << f << " refers to vertex " << faces(f, k) << ", out of range [0, " << x.rows()
           << ")";
        return Status::Error(os.str());
      }
    if (faces(f, 0) == faces(f, 1) || faces(f, 1) == faces(f, 2) || faces(f, 0) == faces(f, 2)) {
      std::ostringstream os;
      os << prefix << "face " << f << " repeats a vertex (" << faces(f, 0) << ", " << faces(f, 1) << ", "
         << faces(f, 2) << ")";
      return Status::Error(os.str());
    }
    const Eigen::Vector3d a = x.row(faces(f, 0)), b = x.row(faces(f, 1)), c = x.row(faces(f, 2));
    const double area = 0.5 * (b - a).cross(c - a).norm();
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    // Relative test: a sliver whose area is 1e-9 of its longest edge squared is numerically collinear.
    if (!(area > 1e-9 * longest * longest)) {
      std::ostringstream os;
      os << prefix << "face " << f << " has zero area (" << area << " m^2; longest edge " << longest << " m)";
      return Status::Error(os.str());
    }
  }
  return Status::Ok();
}

Status ValidateFaceList(const std::vector<int>& face_ids, int num_faces, const std::string& what) {
  std::vector<char> seen(num_faces, 0);
  for (size_t i = 0; i < face_ids.size(); ++i) {
    const int f = face_ids[i];
    if (f < 0 || f >= num_faces) {
      std::ostringstream os;
      os << what << ": entry " << i << " is face " << f << ", out of range [0, " << num_faces << ")";
      return Status::Error(os.str());
    }
    if (seen[f]) {
      std::ostringstream os;
      os << what << ": entry " << i << " repeats face " << f;
      return Status::Error(os.str());
    }
    seen[f] = 1;
  }
  return Status::Ok();
}

}  // namespace kgd
