// Edge inextensibility (the paper's eq. 1, weight k_mi): a deformed edge
// keeps its template length.
//
//   r = w (|x_i - x_j| - L) / L
//
// L is the edge's template length (data), w = sqrt(k_mi / #edges) in the
// solver. Parameter blocks, in order: x_i (3), x_j (3).
#ifndef COST_FUNCTIONS_EDGE_INEXTENSIBILITY_H_
#define COST_FUNCTIONS_EDGE_INEXTENSIBILITY_H_

#include <cmath>
#include <stdexcept>

#include <ceres/autodiff_cost_function.h>

namespace polyfit {

class EdgeInextensibilityResidual {
 public:
  EdgeInextensibilityResidual(double rest_length, double weight) : rest_length_(rest_length), weight_(weight) {}

  template <typename T>
  bool operator()(const T* x_i, const T* x_j, T* residual) const {
    using std::sqrt;
    const T dx = x_i[0] - x_j[0], dy = x_i[1] - x_j[1], dz = x_i[2] - x_j[2];
    // The derivative of |e| at e = 0 is undefined: a tiny floor keeps it finite.
    const T length = sqrt(dx * dx + dy * dy + dz * dz + T(1e-30));
    residual[0] = T(weight_ / rest_length_) * (length - T(rest_length_));
    return true;
  }

  // rest_length > 0, else std::invalid_argument.
  static ceres::CostFunction* Create(double rest_length, double weight = 1.0) {
    if (!(rest_length > 0.0)) throw std::invalid_argument("EdgeInextensibilityResidual: rest_length must be > 0");
    return new ceres::AutoDiffCostFunction<EdgeInextensibilityResidual, 1, 3, 3>(
        new EdgeInextensibilityResidual(rest_length, weight));
  }

 private:
  double rest_length_;
  double weight_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_EDGE_INEXTENSIBILITY_H_
