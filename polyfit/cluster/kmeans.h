// Lloyd's k-means on weighted points of any dimension:
//   minimise sum_i w_i |x_i - c_(label_i)|^2
// by alternating nearest-centre labels and weighted centre means. A centre
// that loses all its points keeps its place. The nearest centre is found by
// a kd-tree in 3-d with many centres, by brute force otherwise (ties to the
// lower index).
#ifndef POLYFIT_CLUSTER_KMEANS_H_
#define POLYFIT_CLUSTER_KMEANS_H_

#include <vector>

#include <Eigen/Core>

#include "polyfit/eval/kd_tree.h"

namespace polyfit {

// points: D by N; weights: N (or empty for all 1); centres: D by K, the
// seeds in, the centres out; labels: N, in [0, K). Stops when no label
// changes or after max_iterations. Returns the iterations run.
template <int D>
int LloydKMeans(const Eigen::Matrix<double, D, Eigen::Dynamic>& points, const Eigen::VectorXd& weights,
                Eigen::Matrix<double, D, Eigen::Dynamic>* centres, std::vector<int>* labels, int max_iterations) {
  using Matrix = Eigen::Matrix<double, D, Eigen::Dynamic>;
  const Eigen::Index n = points.cols(), k = centres->cols();
  labels->assign(n, -1);
  int iteration = 0;
  for (; iteration < max_iterations; ++iteration) {
    bool changed = false;
    const auto assign = [&](Eigen::Index i, int label) {
      changed = changed || (*labels)[i] != label;
      (*labels)[i] = label;
    };
    if constexpr (D == 3) {
      if (k > 16) {
        const KdTree3 tree(*centres);
        for (Eigen::Index i = 0; i < n; ++i) {
          double d2;
          assign(i, tree.Nearest(points.col(i), &d2));
        }
      }
    }
    if (!(D == 3 && k > 16)) {
      for (Eigen::Index i = 0; i < n; ++i) {
        int best = 0;
        double best_d2 = (points.col(i) - centres->col(0)).squaredNorm();
        for (Eigen::Index c = 1; c < k; ++c) {
          const double d2 = (points.col(i) - centres->col(c)).squaredNorm();
          if (d2 < best_d2) {
            best_d2 = d2;
            best = static_cast<int>(c);
          }
        }
        assign(i, best);
      }
    }
    if (!changed) break;
    Matrix sums = Matrix::Zero(points.rows(), k);
    Eigen::VectorXd mass = Eigen::VectorXd::Zero(k);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double w = weights.size() == 0 ? 1.0 : weights[i];
      sums.col((*labels)[i]) += w * points.col(i);
      mass[(*labels)[i]] += w;
    }
    for (Eigen::Index c = 0; c < k; ++c) {
      if (mass[c] > 0.0) centres->col(c) = sums.col(c) / mass[c];
    }
  }
  return iteration;
}

}  // namespace polyfit

#endif  // POLYFIT_CLUSTER_KMEANS_H_
