// Nearest-neighbour queries among 3D points that move, such as a posed
// body's samples: the tree's topology (median splits of the points as first
// given) is built once, and each frame only its nodes' bounding boxes are
// refitted to the moved points, in O(N) with no allocation. Queries prune by
// the distance to a node's box, so they stay exact however the points move;
// they only slow down where a node's points drifted apart and its box grew
// (linear blend skinning keeps neighbours near: the boxes stay tight).
#ifndef POLYFIT_EVAL_REFIT_POINT_TREE_H_
#define POLYFIT_EVAL_REFIT_POINT_TREE_H_

#include <vector>

#include <Eigen/Core>

namespace polyfit {

class RefitPointTree {
 public:
  // points: 3 by N, N > 0 (throws std::invalid_argument otherwise): the
  // layout the topology is built for, and the first positions.
  explicit RefitPointTree(const Eigen::Matrix3Xd& points);

  // The same N points, moved (throws std::invalid_argument on another N).
  void Refit(const Eigen::Matrix3Xd& points);

  // Index (into the points as given) of the nearest point to query, and
  // its squared distance. hint: a point likely near (the answer for a
  // query close by), whose distance starts the search's bound and whose
  // leaf starts the search, which then climbs to the root through the
  // siblings that the bound does not prune; any index, or -1 for none
  // (from the root down), gives the same answer (but for ties).
  int Nearest(const Eigen::Vector3d& query, double* squared_distance, int hint = -1) const;

  // Nearest for a group of queries close together (a patch's probes):
  // queries 3 by count; hints (may be null) count indices as Nearest's, or
  // -1; nearest and squared_distances count each. One descent for the
  // group, pruned by a ball around the queries' centroid, each leaf it
  // reaches scanned for every query: the same answers as Nearest one query
  // at a time (but for ties), with one tree walk instead of count. A
  // query without a hint starts bounded by the group's first one (any
  // point bounds any query; with none at all, the first query's nearest).
  // count <= kMaxGroup (throws std::invalid_argument otherwise).
  void NearestGroup(const Eigen::Matrix3Xd& queries, const int* hints, int* nearest, double* squared_distances) const;

  static constexpr int kMaxGroup = 16;

  int size() const { return static_cast<int>(order_.size()); }

 private:
  struct Node {
    Eigen::Vector3d lo, hi;  // the box of points_ columns [begin, end)
    int begin, end;
    int left, right;  // children (always after their parent), -1 for a leaf
  };
  int Build(const Eigen::Matrix3Xd& points, int begin, int end);
  void Search(int node, const Eigen::Vector3d& q, int* best, double* best_d2) const;
  // A leaf's points against q: *best (leaf order) and *best_d2 updated when
  // one is nearer.
  void ScanLeaf(const Node& leaf, const Eigen::Vector3d& q, int* best, double* best_d2) const;
  struct Group;
  void SearchGroup(int node, Group* group) const;
  bool IsIndex(int i) const { return i >= 0 && i < size(); }
  // |points_ row i (leaf order) - q|^2, summed as the leaves' scan sums it,
  // so that a hint's bound ties with its own point.
  double PlacedDistance2(int i, const Eigen::Vector3d& q) const;

  // N by 3 (each coordinate contiguous, for the leaves' scans), in leaf order.
  Eigen::Matrix<double, Eigen::Dynamic, 3> points_;
  std::vector<int> order_;   // leaf order -> the index as given
  std::vector<int> place_;   // the index as given -> leaf order
  std::vector<Node> nodes_;  // depth first, the root first
  std::vector<int> parent_;  // per node, -1 for the root
  std::vector<int> leaf_;    // per point in leaf order, its leaf
};

}  // namespace polyfit

#endif  // POLYFIT_EVAL_REFIT_POINT_TREE_H_
