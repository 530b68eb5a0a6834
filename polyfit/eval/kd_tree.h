// A static 3D kd-tree for nearest-neighbour queries (Chamfer distances).
#ifndef POLYFIT_EVAL_KD_TREE_H_
#define POLYFIT_EVAL_KD_TREE_H_

#include <vector>

#include <Eigen/Core>

namespace polyfit {

// Reorders (*order)[begin, end) so that its middle element is the median,
// along the widest axis of the points it names (points: 3 by N, order's
// entries columns of it), the lower half before it; returns the middle's
// position (begin + end) / 2 and sets *axis. The split of KdTree3 and
// RefitPointTree.
int SplitAtMedian(const Eigen::Matrix3Xd& points, int begin, int end, std::vector<int>* order, int* axis);

class KdTree3 {
 public:
  // points: 3 by N, copied.
  explicit KdTree3(const Eigen::Matrix3Xd& points);

  // Index of the nearest point to query and its squared distance. N > 0.
  int Nearest(const Eigen::Vector3d& query, double* squared_distance) const;

  int size() const { return static_cast<int>(points_.cols()); }

 private:
  struct Node {
    int begin, end;   // range in order_
    int left, right;  // children, -1 for a leaf
    int axis;
    double split;
  };
  int Build(int begin, int end, int depth);
  void Search(int node, const Eigen::Vector3d& q, int* best, double* best_d2) const;

  Eigen::Matrix3Xd points_;
  std::vector<int> order_;
  std::vector<Node> nodes_;
};

}  // namespace polyfit

#endif  // POLYFIT_EVAL_KD_TREE_H_
