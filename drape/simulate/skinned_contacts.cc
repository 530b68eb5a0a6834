#include "drape/simulate/skinned_contacts.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "drape/collision/signed_distance.h"
#include "polyfit/mesh/barycentric.h"

namespace polyfit {

SkinnedContacts::SkinnedContacts(const SkinnedBody& body, const Eigen::Matrix3Xd& garment_rest, double reach)
    : num_joints_(body.skeleton.num_joints()) {
  const TriangleMesh& mesh = body.mesh;
  if (static_cast<int>(body.weight_offsets.size()) != mesh.num_vertices() + 1) {
    throw std::invalid_argument("SkinnedContacts: the body has no skinning weights for its " +
                                std::to_string(mesh.num_vertices()) + " vertices");
  }
  const BodySignedDistance distance(mesh);
  std::unordered_map<int, int> corner_of;  // body vertex -> corner
  std::vector<int> corners;
  for (int v = 0; v < garment_rest.cols(); ++v) {
    if (!garment_rest.col(v).allFinite()) continue;
    const SignedDistanceResult r = distance.Query(garment_rest.col(v));
    if (r.face < 0 || std::abs(r.distance) > reach) continue;
    Bound bound{v, {}, Eigen::Vector3d::Zero()};
    for (int c = 0; c < 3; ++c) {
      const int b = mesh.faces(c, r.face);
      const auto [it, added] = corner_of.emplace(b, static_cast<int>(corners.size()));
      if (added) corners.push_back(b);
      bound.corner[c] = it->second;
    }
    bound.barycentric =
        BarycentricOnTriangle(mesh.vertices.col(mesh.faces(0, r.face)), mesh.vertices.col(mesh.faces(1, r.face)),
                              mesh.vertices.col(mesh.faces(2, r.face)), r.closest);
    bound_.push_back(bound);
  }
  corner_rest_ = mesh.vertices(Eigen::all, corners);
  for (const int b : corners) {
    for (int k = body.weight_offsets[b]; k < body.weight_offsets[b + 1]; ++k) {
      joint_.push_back(body.weight_joint[k]);
      weight_.push_back(body.weight_value[k]);
    }
    offset_.push_back(static_cast<int>(joint_.size()));
  }
  corner_posed_.resize(3, corner_rest_.cols());
}

void SkinnedContacts::Pose(const std::vector<Eigen::Isometry3d>& rest_to_posed,
                           std::vector<BodyContact>* contacts) const {
  if (static_cast<int>(rest_to_posed.size()) != num_joints_) {
    throw std::invalid_argument("SkinnedContacts::Pose: " + std::to_string(num_joints_) +
                                " joint transforms are needed, not " + std::to_string(rest_to_posed.size()));
  }
  for (int c = 0; c < corner_rest_.cols(); ++c) {
    corner_posed_.col(c) = SkinPoint(corner_rest_.col(c), joint_.data() + offset_[c], weight_.data() + offset_[c],
                                     offset_[c + 1] - offset_[c], rest_to_posed);
  }
  // A face skinned flat holds nothing: a zero normal (KeepAbovePlanes moves
  // the vertex by the offset times it).
  contacts->resize(bound_.size());
  for (size_t i = 0; i < bound_.size(); ++i) {
    const Bound& b = bound_[i];
    const Eigen::Vector3d x0 = corner_posed_.col(b.corner[0]), x1 = corner_posed_.col(b.corner[1]),
                          x2 = corner_posed_.col(b.corner[2]);
    const Eigen::Vector3d n = (x1 - x0).cross(x2 - x0);
    const double length = n.norm();
    BodyContact& contact = (*contacts)[i];
    contact.vertex = b.vertex;
    contact.point = b.barycentric[0] * x0 + b.barycentric[1] * x1 + b.barycentric[2] * x2;
    contact.normal = length > 0.0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero();
  }
}

}  // namespace polyfit
