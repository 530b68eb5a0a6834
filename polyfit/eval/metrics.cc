#include "polyfit/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/LU>

#include "polyfit/eval/kd_tree.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {

SurfaceErrorAccumulator EvaluatePatchAgainstSurface(const JetPatch& patch, const Eigen::Matrix3Xd& surface_points,
                                                    const Eigen::Matrix3Xd& surface_normals) {
  constexpr double kRadToDeg = 57.29577951308232;
  SurfaceErrorAccumulator acc;
  const double* alpha = patch.coefficients.data();
  for (int i = 0; i < surface_points.cols(); ++i) {
    // Closest point phi(u, v) to q by Gauss-Newton from the vertical
    // projection, keeping the best iterate (the vertical distance bounds it).
    const Eigen::Vector3d q = patch.frame.PointToPatch(surface_points.col(i));
    double u = q.x(), v = q.y();
    double best_u = u, best_v = v;
    double best = std::abs(q.z() - patch.Height(u, v));
    for (int it = 0; it < 20; ++it) {
      const auto d = EvaluateJetDerivatives(patch.order, alpha, u, v);
      const Eigen::Vector3d r(u - q.x(), v - q.y(), d.z - q.z());
      const double norm = r.norm();
      if (norm < best) {
        best = norm;
        best_u = u;
        best_v = v;
      }
      Eigen::Matrix<double, 3, 2> j;
      j << 1.0, 0.0, 0.0, 1.0, d.z_u, d.z_v;
      const Eigen::Vector2d step = -(j.transpose() * j).inverse() * (j.transpose() * r);
      if (!step.allFinite() || step.squaredNorm() < 1e-24) break;
      u += step.x();
      v += step.y();
    }
    u = best_u;
    v = best_v;
    const double distance = best * patch.frame.scale;
    const Eigen::Vector3d n_fit = patch.NormalInWorld(u, v);
    const double c = std::min(1.0, std::abs(n_fit.dot(surface_normals.col(i))));
    acc.sum_squared_height += distance * distance;
    acc.sum_normal_deg += std::acos(c) * kRadToDeg;
    ++acc.count;
  }
  return acc;
}

SurfaceErrorAccumulator EvaluatePatchSet(const SyntheticPatchSet& set, const std::vector<JetPatch>& patches) {
  if (patches.size() != set.patches.size()) {
    throw std::invalid_argument("EvaluatePatchSet: one fitted patch per synthetic patch expected");
  }
  SurfaceErrorAccumulator acc;
  for (size_t p = 0; p < patches.size(); ++p) {
    acc.Add(EvaluatePatchAgainstSurface(patches[p], set.patches[p].surface_points_in_world,
                                        set.patches[p].surface_normals_in_world));
  }
  return acc;
}

namespace {
double MeanSquaredNearest(const Eigen::Matrix3Xd& from, const KdTree3& to) {
  const int n = static_cast<int>(from.cols());
  const int num_threads = ResolveNumThreads(0);
  std::vector<double> sums(num_threads, 0.0);
  ParallelFor(
      n, num_threads,
      [&](int thread, int i) {
        double d2;
        to.Nearest(from.col(i), &d2);
        sums[thread] += d2;
      },
      1024);
  double total = 0.0;
  for (double s : sums) total += s;
  return total / n;
}
}  // namespace

ChamferDistance ComputeChamferDistance(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  if (a.cols() == 0 || b.cols() == 0) {
    throw std::invalid_argument("ComputeChamferDistance: empty point set");
  }
  ChamferDistance c;
  c.a_to_b = MeanSquaredNearest(a, KdTree3(b));
  c.b_to_a = MeanSquaredNearest(b, KdTree3(a));
  return c;
}

}  // namespace polyfit
