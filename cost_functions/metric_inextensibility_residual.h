// Metric-tensor inextensibility (the paper's eq. 4, weight k_mi with the
// k_ext schedule): a deformed patch keeps its rest first fundamental form at
// a sample (u, v).
//
//   X(u, v) = A (s R (u, v, z(u, v; alpha)) + T)      LBS linear part A, frame R
//   J = dX/d(u, v) = s A R [(1, 0, z_u), (0, 1, z_v)]   (3 by 2)
//   g = J^T J,  r = w (g11 - g0_11, sqrt(2) (g12 - g0_12), g22 - g0_22)
//
// so |r|^2 = w^2 |g - g0|_F^2. A (from the body's skinning Jacobian), R,
// (u, v) and g0 are data. Parameter blocks: alpha (NumJetCoefficients(order)),
// scale s (1). T does not change g.
#ifndef COST_FUNCTIONS_METRIC_INEXTENSIBILITY_RESIDUAL_H_
#define COST_FUNCTIONS_METRIC_INEXTENSIBILITY_RESIDUAL_H_

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include <ceres/autodiff_cost_function.h>
#include <Eigen/Core>

#include "cost_functions/jet_order_dispatch.h"
#include "polyfit/jet/jet_surface.h"

namespace polyfit {

class MetricInextensibilityResidual {
 public:
  // rest_metric: (g11, g12, g22).
  MetricInextensibilityResidual(int order, double u, double v, const Eigen::Vector3d& rest_metric,
                                const Eigen::Matrix3d& rotation, const Eigen::Matrix3d& skinning, double weight)
      : order_(order), u_(u), v_(v), rest_(rest_metric), map_(skinning * rotation), weight_(weight) {}

  template <typename T>
  bool operator()(const T* alpha, const T* scale, T* residual) const {
    const JetHeightDerivatives<T> d = EvaluateJetDerivatives(order_, alpha, T(u_), T(v_));
    // Columns of J / s: M (1, 0, z_u) and M (0, 1, z_v), M = A R.
    T ju[3], jv[3];
    for (int k = 0; k < 3; ++k) {
      ju[k] = T(map_(k, 0)) + T(map_(k, 2)) * d.z_u;
      jv[k] = T(map_(k, 1)) + T(map_(k, 2)) * d.z_v;
    }
    const T s2 = scale[0] * scale[0];
    const T g11 = s2 * (ju[0] * ju[0] + ju[1] * ju[1] + ju[2] * ju[2]);
    const T g12 = s2 * (ju[0] * jv[0] + ju[1] * jv[1] + ju[2] * jv[2]);
    const T g22 = s2 * (jv[0] * jv[0] + jv[1] * jv[1] + jv[2] * jv[2]);
    residual[0] = T(weight_) * (g11 - T(rest_[0]));
    residual[1] = T(weight_ * std::sqrt(2.0)) * (g12 - T(rest_[1]));
    residual[2] = T(weight_) * (g22 - T(rest_[2]));
    return true;
  }

  static ceres::CostFunction* Create(int order, double u, double v, const Eigen::Vector3d& rest_metric,
                                     const Eigen::Matrix3d& rotation,
                                     const Eigen::Matrix3d& skinning = Eigen::Matrix3d::Identity(),
                                     double weight = 1.0) {
    auto functor =
        std::make_unique<MetricInextensibilityResidual>(order, u, v, rest_metric, rotation, skinning, weight);
    return DispatchJetCoefficients(order, "MetricInextensibilityResidual", [&](auto k) -> ceres::CostFunction* {
      using Cost = ceres::AutoDiffCostFunction<MetricInextensibilityResidual, 3, decltype(k)::value, 1>;
      return new Cost(functor.release());
    });
  }

 private:
  int order_;
  double u_, v_;
  Eigen::Vector3d rest_;
  Eigen::Matrix3d map_;
  double weight_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_METRIC_INEXTENSIBILITY_RESIDUAL_H_
