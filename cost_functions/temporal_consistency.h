// Temporal consistency (the paper's eq. 2, weight k_tc): a vertex moves
// little between consecutive frames of the window.
//
//   r = w (x_t - x_{t-1}) / s        (3 residuals)
//
// s is a length scale (the template's size, data) that makes the term
// unitless; w = sqrt(k_tc / #vertices) in the solver. Parameter blocks, in
// order: x_t (3), x_{t-1} (3).
#ifndef COST_FUNCTIONS_TEMPORAL_CONSISTENCY_H_
#define COST_FUNCTIONS_TEMPORAL_CONSISTENCY_H_

#include <stdexcept>

#include <ceres/autodiff_cost_function.h>

namespace polyfit {

class TemporalConsistencyResidual {
 public:
  TemporalConsistencyResidual(double length_scale, double weight) : scale_(weight / length_scale) {}

  template <typename T>
  bool operator()(const T* x_t, const T* x_previous, T* residual) const {
    for (int k = 0; k < 3; ++k) residual[k] = T(scale_) * (x_t[k] - x_previous[k]);
    return true;
  }

  static ceres::CostFunction* Create(double length_scale, double weight = 1.0) {
    if (!(length_scale > 0.0)) throw std::invalid_argument("TemporalConsistencyResidual: length_scale must be > 0");
    return new ceres::AutoDiffCostFunction<TemporalConsistencyResidual, 3, 3, 3>(
        new TemporalConsistencyResidual(length_scale, weight));
  }

 private:
  double scale_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_TEMPORAL_CONSISTENCY_H_
