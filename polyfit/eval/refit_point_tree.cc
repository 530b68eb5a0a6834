#include "polyfit/eval/refit_point_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "polyfit/eval/kd_tree.h"

namespace polyfit {
namespace {

// Leaves scanned in one vectorised pass: 32 points measured faster than 8
// on a body's 2,000 samples (fewer boxes to test per query).
constexpr int kLeafSize = 32;
static_assert(kLeafSize % 8 == 0, "leaves are scanned in lanes of 8");

double BoxDistance2(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& q) {
  return (lo - q).cwiseMax(q - hi).cwiseMax(0.0).squaredNorm();
}

}  // namespace

RefitPointTree::RefitPointTree(const Eigen::Matrix3Xd& points) : order_(points.cols()) {
  if (points.cols() == 0) throw std::invalid_argument("RefitPointTree: no points");
  std::iota(order_.begin(), order_.end(), 0);
  nodes_.reserve(4 * (points.cols() / kLeafSize + 1));
  Build(points, 0, static_cast<int>(points.cols()));
  place_.resize(order_.size());
  for (int i = 0; i < size(); ++i) place_[order_[i]] = i;
  parent_.assign(nodes_.size(), -1);
  leaf_.resize(order_.size());
  for (int n = 0; n < static_cast<int>(nodes_.size()); ++n) {
    const Node& node = nodes_[n];
    if (node.left >= 0) {
      parent_[node.left] = parent_[node.right] = n;
    } else {
      for (int i = node.begin; i < node.end; ++i) leaf_[i] = n;
    }
  }
  points_.resize(points.cols(), 3);
  Refit(points);
}

int RefitPointTree::Build(const Eigen::Matrix3Xd& points, int begin, int end) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back({Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), begin, end, -1, -1});
  if (end - begin <= kLeafSize) return index;
  int axis;
  const int mid = SplitAtMedian(points, begin, end, &order_, &axis);
  const int left = Build(points, begin, mid);
  const int right = Build(points, mid, end);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

void RefitPointTree::Refit(const Eigen::Matrix3Xd& points) {
  if (points.cols() != size()) throw std::invalid_argument("RefitPointTree::Refit: another number of points");
  for (int i = 0; i < size(); ++i) points_.row(i) = points.col(order_[i]).transpose();
  // Children come after their parents: backwards, every child is done first.
  for (int n = static_cast<int>(nodes_.size()) - 1; n >= 0; --n) {
    Node& node = nodes_[n];
    if (node.left < 0) {
      node.lo = points_.middleRows(node.begin, node.end - node.begin).colwise().minCoeff().transpose();
      node.hi = points_.middleRows(node.begin, node.end - node.begin).colwise().maxCoeff().transpose();
    } else {
      node.lo = nodes_[node.left].lo.cwiseMin(nodes_[node.right].lo);
      node.hi = nodes_[node.left].hi.cwiseMax(nodes_[node.right].hi);
    }
  }
}

double RefitPointTree::PlacedDistance2(int i, const Eigen::Vector3d& q) const {
  const double dx = points_(i, 0) - q.x(), dy = points_(i, 1) - q.y(), dz = points_(i, 2) - q.z();
  return dx * dx + dy * dy + dz * dz;
}

void RefitPointTree::ScanLeaf(const Node& node, const Eigen::Vector3d& q, int* best, double* best_d2) const {
  // The leaf's squared distances in one pass over its coordinates, then
  // the nearest (the first of ties, as one point at a time).
  const int n = node.end - node.begin;
  double d2[kLeafSize];
  const double* x = points_.col(0).data() + node.begin;
  const double* y = points_.col(1).data() + node.begin;
  const double* z = points_.col(2).data() + node.begin;
  for (int i = 0; i < n; ++i) {
    const double dx = x[i] - q.x(), dy = y[i] - q.y(), dz = z[i] - q.z();
    d2[i] = dx * dx + dy * dy + dz * dz;
  }
  // The leaf's least distance by a branch-free pass in 8 independent lanes
  // (a < b ? a : b per lane is the vector min; one running minimum was a
  // chain of dependent scalar mins), NaNs skipped as by comparison; only a
  // leaf that beats the bound is searched for the first index holding it
  // (the same answer as comparing one point at a time, whose branches
  // mispredicted).
  for (int i = n; i < kLeafSize; ++i) d2[i] = std::numeric_limits<double>::infinity();
  double lanes[8];
  for (int j = 0; j < 8; ++j) lanes[j] = *best_d2;
  for (int i = 0; i < kLeafSize; i += 8) {
    for (int j = 0; j < 8; ++j) lanes[j] = d2[i + j] < lanes[j] ? d2[i + j] : lanes[j];
  }
  for (int width = 4; width > 0; width /= 2) {
    for (int j = 0; j < width; ++j) lanes[j] = lanes[j + width] < lanes[j] ? lanes[j + width] : lanes[j];
  }
  const double least = lanes[0];
  if (!(least < *best_d2)) return;
  for (int i = 0; i < n; ++i) {
    if (d2[i] == least) {
      *best_d2 = least;
      *best = node.begin + i;
      return;
    }
  }
}

void RefitPointTree::Search(int index, const Eigen::Vector3d& q, int* best, double* best_d2) const {
  const Node& node = nodes_[index];
  if (node.left < 0) {
    ScanLeaf(node, q, best, best_d2);
    return;
  }
  const Node& left = nodes_[node.left];
  const Node& right = nodes_[node.right];
  const double dl = BoxDistance2(left.lo, left.hi, q), dr = BoxDistance2(right.lo, right.hi, q);
  const bool left_first = dl <= dr;
  const int near = left_first ? node.left : node.right, far = left_first ? node.right : node.left;
  const double d_near = left_first ? dl : dr, d_far = left_first ? dr : dl;
  if (d_near < *best_d2) Search(near, q, best, best_d2);
  if (d_far < *best_d2) Search(far, q, best, best_d2);
}

int RefitPointTree::Nearest(const Eigen::Vector3d& query, double* squared_distance, int hint) const {
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  if (IsIndex(hint)) {
    const double d2 = PlacedDistance2(place_[hint], query);
    if (d2 < best_d2) {  // false for a NaN
      best = place_[hint];
      best_d2 = d2;
    }
  }
  if (best < 0) {
    Search(0, query, &best, &best_d2);
  } else {
    // Bottom up: the hint's leaf, then each ancestor's other child. Every
    // leaf is under exactly one of them, and each is pruned by its box.
    int node = leaf_[best];
    Search(node, query, &best, &best_d2);
    for (int parent = parent_[node]; parent >= 0; node = parent, parent = parent_[node]) {
      const Node& p = nodes_[parent];
      const int sibling = p.left == node ? p.right : p.left;
      if (BoxDistance2(nodes_[sibling].lo, nodes_[sibling].hi, query) < best_d2) {
        Search(sibling, query, &best, &best_d2);
      }
    }
  }
  if (squared_distance) *squared_distance = best_d2;
  return best < 0 ? -1 : order_[best];
}

struct RefitPointTree::Group {
  int count = 0;
  Eigen::Vector3d query[kMaxGroup];
  int best[kMaxGroup];  // leaf order, -1 for none yet
  double best_d2[kMaxGroup];
  double offset[kMaxGroup];  // |query - centre|
  Eigen::Vector3d centre;
  // max over the queries of offset + sqrt(best_d2): a node whose box is as
  // far from the centre holds no point nearer to any query than its best.
  double reach = 0.0;

  void UpdateReach() {
    reach = 0.0;
    for (int i = 0; i < count; ++i) reach = std::max(reach, offset[i] + std::sqrt(best_d2[i]));
    reach *= 1.0 + 1e-12;  // rounding in the sums never prunes a nearer point
  }
};

void RefitPointTree::SearchGroup(int index, Group* group) const {
  const Node& node = nodes_[index];
  if (node.left < 0) {
    for (int i = 0; i < group->count; ++i) {
      if (BoxDistance2(node.lo, node.hi, group->query[i]) < group->best_d2[i]) {
        ScanLeaf(node, group->query[i], &group->best[i], &group->best_d2[i]);
      }
    }
    group->UpdateReach();
    return;
  }
  const Node& left = nodes_[node.left];
  const Node& right = nodes_[node.right];
  const double dl = BoxDistance2(left.lo, left.hi, group->centre), dr = BoxDistance2(right.lo, right.hi, group->centre);
  const bool left_first = dl <= dr;
  const int near = left_first ? node.left : node.right, far = left_first ? node.right : node.left;
  const double d_near = left_first ? dl : dr, d_far = left_first ? dr : dl;
  if (d_near < group->reach * group->reach) SearchGroup(near, group);
  if (d_far < group->reach * group->reach) SearchGroup(far, group);
}

void RefitPointTree::NearestGroup(const Eigen::Matrix3Xd& queries, const int* hints, int* nearest,
                                  double* squared_distances) const {
  const int count = static_cast<int>(queries.cols());
  if (count > kMaxGroup) throw std::invalid_argument("RefitPointTree::NearestGroup: more than kMaxGroup queries");
  if (count == 0) return;
  if (!queries.allFinite()) {  // as Nearest answers a point with a NaN, one at a time
    for (int i = 0; i < count; ++i) nearest[i] = Nearest(queries.col(i), &squared_distances[i], hints ? hints[i] : -1);
    return;
  }
  Group group;
  group.count = count;
  group.centre = queries.rowwise().mean();
  int shared = -1;  // a hint for the queries without one
  for (int i = 0; i < count && shared < 0; ++i) {
    if (hints != nullptr && IsIndex(hints[i])) shared = hints[i];
  }
  if (shared < 0) {
    double d2;
    shared = Nearest(queries.col(0), &d2);
  }
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d q = queries.col(i);
    group.query[i] = q;
    group.offset[i] = (q - group.centre).norm();
    const int hint = hints != nullptr && IsIndex(hints[i]) ? hints[i] : shared;
    const int b = place_[hint];
    const double d2 = PlacedDistance2(b, q);
    const bool bounded = d2 < std::numeric_limits<double>::infinity();  // false for a point with a NaN
    group.best[i] = bounded ? b : -1;
    group.best_d2[i] = bounded ? d2 : std::numeric_limits<double>::infinity();
  }
  group.UpdateReach();
  SearchGroup(0, &group);
  for (int i = 0; i < count; ++i) {
    nearest[i] = group.best[i] < 0 ? -1 : order_[group.best[i]];
    squared_distances[i] = group.best_d2[i];
  }
}

}  // namespace polyfit
