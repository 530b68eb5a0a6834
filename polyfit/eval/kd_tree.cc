#include "polyfit/eval/kd_tree.h"

#include <algorithm>
#include <limits>
#include <numeric>

namespace polyfit {
namespace {
constexpr int kLeafSize = 12;
}

int SplitAtMedian(const Eigen::Matrix3Xd& points, int begin, int end, std::vector<int>* order, int* axis) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (int i = begin; i < end; ++i) {
    lo = lo.cwiseMin(points.col((*order)[i]));
    hi = hi.cwiseMax(points.col((*order)[i]));
  }
  (hi - lo).maxCoeff(axis);
  const int mid = (begin + end) / 2, a = *axis;
  std::nth_element(order->begin() + begin, order->begin() + mid, order->begin() + end,
                   [&](int i, int j) { return points(a, i) < points(a, j); });
  return mid;
}

KdTree3::KdTree3(const Eigen::Matrix3Xd& points) : points_(points), order_(points.cols()) {
  std::iota(order_.begin(), order_.end(), 0);
  nodes_.reserve(2 * (points.cols() / kLeafSize + 1));
  if (points.cols() > 0) Build(0, static_cast<int>(points.cols()), 0);
}

int KdTree3::Build(int begin, int end, int depth) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back({begin, end, -1, -1, 0, 0.0});
  if (end - begin <= kLeafSize) return index;
  int axis;
  const int mid = SplitAtMedian(points_, begin, end, &order_, &axis);
  const double split = points_(axis, order_[mid]);
  const int left = Build(begin, mid, depth + 1);
  const int right = Build(mid, end, depth + 1);
  nodes_[index].left = left;
  nodes_[index].right = right;
  nodes_[index].axis = axis;
  nodes_[index].split = split;
  return index;
}

void KdTree3::Search(int node_index, const Eigen::Vector3d& q, int* best, double* best_d2) const {
  const Node& node = nodes_[node_index];
  if (node.left < 0) {
    for (int i = node.begin; i < node.end; ++i) {
      const double d2 = (points_.col(order_[i]) - q).squaredNorm();
      if (d2 < *best_d2) {
        *best_d2 = d2;
        *best = order_[i];
      }
    }
    return;
  }
  const double delta = q[node.axis] - node.split;
  const int near = delta < 0 ? node.left : node.right;
  const int far = delta < 0 ? node.right : node.left;
  Search(near, q, best, best_d2);
  if (delta * delta < *best_d2) Search(far, q, best, best_d2);
}

int KdTree3::Nearest(const Eigen::Vector3d& query, double* squared_distance) const {
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  if (!nodes_.empty()) Search(0, query, &best, &best_d2);
  if (squared_distance) *squared_distance = best_d2;
  return best;
}

}  // namespace polyfit
