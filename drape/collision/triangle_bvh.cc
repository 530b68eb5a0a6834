#include "drape/collision/triangle_bvh.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace polyfit {
namespace {

constexpr int kLeafFaces = 4;
// Median splits give a depth of about log2(#faces / kLeafFaces); each level
// defers at most one child.
constexpr int kMaxStack = 128;

double BoxSquaredDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& lower, const Eigen::Vector3d& upper) {
  double d2 = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double below = lower[k] - p[k], above = p[k] - upper[k];
    if (below > 0.0) d2 += below * below;
    if (above > 0.0) d2 += above * above;
  }
  return d2;
}

}  // namespace

Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double sum = va + vb + vc;
  // A degenerate triangle that reached the interior region: its corners
  // and edges were the candidates, and a is as good as any.
  if (!(sum > 0.0)) return a;
  return a + ab * (vb / sum) + ac * (vc / sum);
}

TriangleBvh::TriangleBvh(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces,
                         const std::vector<int>& subset)
    : faces_(faces) {
  if (faces.size() > 0 && (faces.minCoeff() < 0 || faces.maxCoeff() >= vertices.cols())) {
    throw std::invalid_argument("TriangleBvh: a face refers to a vertex that does not exist");
  }
  if (subset.empty()) {
    face_order_.resize(faces.cols());
    for (int f = 0; f < faces.cols(); ++f) face_order_[f] = f;
  } else {
    for (int f : subset) {
      if (f < 0 || f >= faces.cols()) throw std::invalid_argument("TriangleBvh: a face index is out of range");
    }
    face_order_ = subset;
  }
  held_.assign(faces.cols(), 0);
  for (int f : face_order_) held_[f] = 1;
  if (face_order_.empty()) return;
  Eigen::Matrix3Xd centroids(3, faces.cols());
  for (int f : face_order_) {
    centroids.col(f) = (vertices.col(faces(0, f)) + vertices.col(faces(1, f)) + vertices.col(faces(2, f))) / 3.0;
  }
  nodes_.reserve(2 * face_order_.size() / kLeafFaces + 1);
  Build(centroids, 0, static_cast<int>(face_order_.size()));
  Refit(vertices);
}

int TriangleBvh::Build(const Eigen::Matrix3Xd& centroids, int first, int count) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  if (count <= kLeafFaces) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  Eigen::Vector3d lower = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d upper = -lower;
  for (int i = first; i < first + count; ++i) {
    lower = lower.cwiseMin(centroids.col(face_order_[i]));
    upper = upper.cwiseMax(centroids.col(face_order_[i]));
  }
  int axis = 0;
  (upper - lower).maxCoeff(&axis);
  const int half = count / 2;
  std::nth_element(face_order_.begin() + first, face_order_.begin() + first + half, face_order_.begin() + first + count,
                   [&](int f, int g) { return centroids(axis, f) < centroids(axis, g); });
  Build(centroids, first, half);
  const int right = Build(centroids, first + half, count - half);
  nodes_[index].right = right;
  return index;
}

void TriangleBvh::Refit(const Eigen::Matrix3Xd& vertices) {
  for (int i = static_cast<int>(nodes_.size()) - 1; i >= 0; --i) {
    Node& node = nodes_[i];
    if (node.count > 0) {
      node.lower = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
      node.upper = -node.lower;
      for (int k = node.first; k < node.first + node.count; ++k) {
        for (int c = 0; c < 3; ++c) {
          node.lower = node.lower.cwiseMin(vertices.col(faces_(c, face_order_[k])));
          node.upper = node.upper.cwiseMax(vertices.col(faces_(c, face_order_[k])));
        }
      }
    } else {
      node.lower = nodes_[i + 1].lower.cwiseMin(nodes_[node.right].lower);
      node.upper = nodes_[i + 1].upper.cwiseMax(nodes_[node.right].upper);
    }
  }
}

bool TriangleBvh::ClosestPoint(const Eigen::Vector3d& p, const Eigen::Matrix3Xd& vertices, Eigen::Vector3d* closest,
                               int* face, int hint_face) const {
  if (nodes_.empty()) return false;
  double best = std::numeric_limits<double>::infinity();
  if (hint_face >= 0 && hint_face < faces_.cols() && held_[hint_face]) {
    *closest = ClosestPointOnTriangle(p, vertices.col(faces_(0, hint_face)), vertices.col(faces_(1, hint_face)),
                                      vertices.col(faces_(2, hint_face)));
    *face = hint_face;
    // Boxes at exactly this distance are still opened, so that a face tied
    // with the hint is found as without it.
    best = std::nextafter((*closest - p).squaredNorm(), std::numeric_limits<double>::infinity());
  }
  int stack[kMaxStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (BoxSquaredDistance(p, node.lower, node.upper) >= best) continue;
    if (node.count > 0) {
      for (int k = node.first; k < node.first + node.count; ++k) {
        const int f = face_order_[k];
        const Eigen::Vector3d q = ClosestPointOnTriangle(p, vertices.col(faces_(0, f)), vertices.col(faces_(1, f)),
                                                         vertices.col(faces_(2, f)));
        const double d2 = (q - p).squaredNorm();
        if (d2 < best) {
          best = d2;
          *closest = q;
          *face = f;
        }
      }
      continue;
    }
    const int near_child = static_cast<int>(&node - nodes_.data()) + 1, far_child = node.right;
    const double near_d2 = BoxSquaredDistance(p, nodes_[near_child].lower, nodes_[near_child].upper);
    const double far_d2 = BoxSquaredDistance(p, nodes_[far_child].lower, nodes_[far_child].upper);
    // The nearer box is searched first (pushed last); a child that cannot
    // hold a closer point is not pushed.
    const bool swap = far_d2 < near_d2;
    const int first = swap ? far_child : near_child, second = swap ? near_child : far_child;
    const double first_d2 = std::min(near_d2, far_d2), second_d2 = std::max(near_d2, far_d2);
    if (second_d2 < best && top < kMaxStack) stack[top++] = second;
    if (first_d2 < best && top < kMaxStack) stack[top++] = first;
  }
  return true;
}

}  // namespace polyfit
