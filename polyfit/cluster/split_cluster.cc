#include "polyfit/cluster/split_cluster.h"

#include <algorithm>

#include "polyfit/cluster/kmeans.h"

namespace polyfit {

std::vector<int> SplitClusterInTwo(const Eigen::Matrix3Xd& normals, const Eigen::Matrix3Xd& centroids,
                                   const std::vector<int>& faces) {
  const Eigen::Index n = static_cast<Eigen::Index>(faces.size());
  if (n < 4) return {};
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int f : faces) mean += centroids.col(f) / static_cast<double>(n);
  double radius = 0.0;
  for (int f : faces) radius = std::max(radius, (centroids.col(f) - mean).norm());
  Eigen::Matrix<double, 6, Eigen::Dynamic> features(6, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    features.col(i) << normals.col(faces[i]), (centroids.col(faces[i]) - mean) / std::max(radius, 1e-12);
  }
  const auto farthest_from = [&](Eigen::Index from) {
    Eigen::Index best_i = from;
    double best = -1.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double d = (features.col(i) - features.col(from)).squaredNorm();
      if (d > best) {
        best = d;
        best_i = i;
      }
    }
    return best_i;
  };
  const Eigen::Index s0 = farthest_from(0);
  const Eigen::Index s1 = farthest_from(s0);
  Eigen::Matrix<double, 6, Eigen::Dynamic> centres(6, 2);
  centres << features.col(s0), features.col(s1);
  std::vector<int> side;
  LloydKMeans<6>(features, Eigen::VectorXd(), &centres, &side, 10);
  const auto ones = std::count(side.begin(), side.end(), 1);
  if (ones == 0 || ones == n) return {};
  return side;
}

}  // namespace polyfit
