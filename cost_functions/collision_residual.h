// Body collision (the paper's eq. 3, weight k_c, margin eps): a garment
// point closer to the body than eps, or inside it, is pushed out.
//
//   d = (x - c) . n                  signed distance along the body's normal
//   r = w max(eps - d, 0)^(p / 2)    so that r^2 / 2 is w^2 / 2 max(eps - d, 0)^p
//
// c and n (unit) are the closest body point and its pseudonormal at the
// linearisation point (drape/collision/signed_distance.h), data; p is 2 or 3
// (SNUG's cubic penalty). Parameter block: x (3).
#ifndef COST_FUNCTIONS_COLLISION_RESIDUAL_H_
#define COST_FUNCTIONS_COLLISION_RESIDUAL_H_

#include <cmath>
#include <stdexcept>

#include <ceres/autodiff_cost_function.h>
#include <Eigen/Core>

namespace polyfit {

class CollisionResidual {
 public:
  CollisionResidual(const Eigen::Vector3d& closest, const Eigen::Vector3d& normal, double margin, double weight,
                    int power)
      : closest_(closest), normal_(normal), margin_(margin), weight_(weight), power_(power) {}

  template <typename T>
  bool operator()(const T* x, T* residual) const {
    using std::pow;
    using std::sqrt;
    const T d =
        (x[0] - closest_[0]) * normal_[0] + (x[1] - closest_[1]) * normal_[1] + (x[2] - closest_[2]) * normal_[2];
    const T depth = T(margin_) - d;
    if (depth <= T(0.0)) {
      residual[0] = T(0.0);
    } else if (power_ == 2) {
      residual[0] = T(weight_) * depth;
    } else {
      residual[0] = T(weight_) * depth * sqrt(depth);
    }
    return true;
  }

  // power: 2 or 3. normal is normalised here.
  static ceres::CostFunction* Create(const Eigen::Vector3d& closest, const Eigen::Vector3d& normal, double margin,
                                     double weight = 1.0, int power = 3) {
    if (power != 2 && power != 3) throw std::invalid_argument("CollisionResidual: power must be 2 or 3");
    if (!(normal.norm() > 0.0)) throw std::invalid_argument("CollisionResidual: zero normal");
    return new ceres::AutoDiffCostFunction<CollisionResidual, 1, 3>(
        new CollisionResidual(closest, normal.normalized(), margin, weight, power));
  }

 private:
  Eigen::Vector3d closest_, normal_;
  double margin_, weight_;
  int power_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_COLLISION_RESIDUAL_H_
