// Height residual of one observed world point against an n-jet patch.
//
//   q = R^T (p - T) / s                       point_in_patch
//   r = w * s * (q_z - z(q_u, q_v; alpha))    world units
//
// z is the n-jet of polyfit/jet/jet_basis.h. Parameter blocks, in order:
//   alpha              NumJetCoefficients(order) coefficients
//   world_from_patch   rotation R as a unit quaternion (w, x, y, z), use
//                      ceres::QuaternionManifold
//   patch_origin       T (3)
// s (the patch scale), the point p and the weight w are data. To fit the jet
// in a fixed frame, hold the rotation and origin blocks constant: the solve
// then reaches the closed-form least-squares fit.
#ifndef COST_FUNCTIONS_JET_HEIGHT_RESIDUAL_H_
#define COST_FUNCTIONS_JET_HEIGHT_RESIDUAL_H_

#include <memory>
#include <stdexcept>
#include <string>

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>
#include <Eigen/Core>

#include "cost_functions/jet_order_dispatch.h"
#include "polyfit/jet/jet_surface.h"

namespace polyfit {

class JetHeightResidual {
 public:
  JetHeightResidual(int order, const Eigen::Vector3d& point_in_world, double scale, double weight = 1.0)
      : order_(order), point_in_world_(point_in_world), scale_(scale), weight_(weight) {}

  template <typename T>
  bool operator()(const T* alpha, const T* world_from_patch, const T* patch_origin, T* residual) const {
    const T patch_from_world[4] = {world_from_patch[0], -world_from_patch[1], -world_from_patch[2],
                                   -world_from_patch[3]};
    const T offset[3] = {T(point_in_world_[0]) - patch_origin[0], T(point_in_world_[1]) - patch_origin[1],
                         T(point_in_world_[2]) - patch_origin[2]};
    T q[3];
    ceres::UnitQuaternionRotatePoint(patch_from_world, offset, q);
    const T inv_scale(1.0 / scale_);
    const T u = q[0] * inv_scale, v = q[1] * inv_scale, z = q[2] * inv_scale;
    residual[0] = T(weight_ * scale_) * (z - EvaluateJetHeight(order_, alpha, u, v));
    return true;
  }

  // order in [1, 8]; scale > 0. Throws std::invalid_argument otherwise.
  static ceres::CostFunction* Create(int order, const Eigen::Vector3d& point_in_world, double scale,
                                     double weight = 1.0) {
    if (!(scale > 0.0)) throw std::invalid_argument("JetHeightResidual: scale must be > 0");
    auto functor = std::make_unique<JetHeightResidual>(order, point_in_world, scale, weight);
    return DispatchJetCoefficients(order, "JetHeightResidual", [&](auto k) -> ceres::CostFunction* {
      return new ceres::AutoDiffCostFunction<JetHeightResidual, 1, decltype(k)::value, 4, 3>(functor.release());
    });
  }

 private:
  int order_;
  Eigen::Vector3d point_in_world_;
  double scale_;
  double weight_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_JET_HEIGHT_RESIDUAL_H_
