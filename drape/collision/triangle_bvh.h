// Closest points on a triangle mesh whose vertices move but whose faces do
// not (a posed body): a bounding-volume hierarchy built once over a set of
// faces, then refitted to each new pose in O(#faces) instead of rebuilt.
// A refitted tree keeps the rest pose's grouping, so its boxes grow where
// a pose pulls a node's faces apart; queries stay exact (every box bounds
// its faces), they only visit more nodes.
#ifndef POLYFIT_DRAPE_COLLISION_TRIANGLE_BVH_H_
#define POLYFIT_DRAPE_COLLISION_TRIANGLE_BVH_H_

#include <vector>

#include <Eigen/Core>

namespace polyfit {

// The point of triangle (a, b, c) closest to p (Ericson, Real-Time Collision
// Detection, 5.1.5); degenerate triangles are handled by the same regions.
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c);

class TriangleBvh {
 public:
  TriangleBvh() = default;
  // vertices: 3 by #V; faces: 3 by #F (indices into vertices); subset: the
  // faces to hold (all when empty). The tree is split by the faces'
  // centroids at these positions.
  TriangleBvh(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces, const std::vector<int>& subset = {});

  // The same faces at new vertex positions (3 by #V, as at construction).
  void Refit(const Eigen::Matrix3Xd& vertices);

  // The closest point of the held faces to p and its face (an index into
  // the construction's faces); vertices: the positions last refitted to.
  // hint_face: a held face near p (the answer for a point close by), or -1:
  // it bounds the search from the start, so that far boxes are never
  // opened; the answer does not depend on it (but for exact ties).
  // Thread-safe. Returns false when the tree holds no face.
  bool ClosestPoint(const Eigen::Vector3d& p, const Eigen::Matrix3Xd& vertices, Eigen::Vector3d* closest, int* face,
                    int hint_face = -1) const;

  int num_faces() const { return static_cast<int>(face_order_.size()); }

 private:
  struct Node {
    Eigen::Vector3d lower, upper;
    int first = 0, count = 0;  // a leaf's faces in face_order_ (count > 0)
    int right = -1;            // an inner node's second child; its first is the next node
  };
  int Build(const Eigen::Matrix3Xd& centroids, int first, int count);

  Eigen::Matrix3Xi faces_;
  std::vector<char> held_;  // per face of faces_: in this tree
  std::vector<int> face_order_;
  std::vector<Node> nodes_;  // depth first: a child after its parent
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_COLLISION_TRIANGLE_BVH_H_
