// Signed distance from garment points to a body mesh, two ways:
//   BodySignedDistance    exact closest point (TriangleBvh: a tree over the
//                         triangles built once, refitted per pose), sign
//                         from the closest feature's
//                         angle-weighted pseudonormal (Baerentzen and Aanaes
//                         2005): negative inside a closed, outward-oriented body.
//                         A body of several closed pieces (overlapping
//                         capsules) is treated as their union.
//   NearestVertexDistance the SNUG/GAPS approximation: d = (p - x_v) . n_v
//                         with x_v the nearest body vertex, n_v its normal.
// Both are rebuilt per pose (SetVertices) and answer queries from many
// threads.
#ifndef POLYFIT_DRAPE_COLLISION_SIGNED_DISTANCE_H_
#define POLYFIT_DRAPE_COLLISION_SIGNED_DISTANCE_H_

#include <memory>

#include <Eigen/Core>

#include "polyfit/eval/refit_point_tree.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

struct SignedDistanceResult {
  double distance = 0.0;                              // negative inside
  Eigen::Vector3d closest = Eigen::Vector3d::Zero();  // on the body
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();   // the pseudonormal there (unit)
  int face = -1;
};

class BodySignedDistance {
 public:
  // The body's faces are kept; its vertices can change (SetVertices).
  explicit BodySignedDistance(const TriangleMesh& body);
  ~BodySignedDistance();
  BodySignedDistance(BodySignedDistance&&) noexcept;

  // New vertex positions (a pose): 3 by #V, same faces.
  void SetVertices(const Eigen::Matrix3Xd& vertices);
  // hint_face: the face of a query close by (a garment vertex's answer at
  // the last iteration), or -1; it only makes the query faster.
  SignedDistanceResult Query(const Eigen::Vector3d& point, int hint_face = -1) const;
  // #points signed distances.
  Eigen::VectorXd SignedDistances(const Eigen::Matrix3Xd& points, int num_threads = 1) const;

 private:
  struct Impl;
  static SignedDistanceResult QueryPiece(const Impl& m, size_t piece, const Eigen::Vector3d& point, int hint_face);
  std::unique_ptr<Impl> impl_;
};

class NearestVertexDistance {
 public:
  // The body's vertices in a tree built once and refitted per pose.
  explicit NearestVertexDistance(const TriangleMesh& body);
  // Throws std::invalid_argument on another number of vertices.
  void SetVertices(const Eigen::Matrix3Xd& vertices);
  // face: the nearest vertex (not a face). hint: the answer for a point
  // close by, or -1; it only makes the query faster.
  SignedDistanceResult Query(const Eigen::Vector3d& point, int hint = -1) const;

 private:
  TriangleMesh body_;
  Eigen::Matrix3Xd normals_;
  std::unique_ptr<RefitPointTree> tree_;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_COLLISION_SIGNED_DISTANCE_H_
