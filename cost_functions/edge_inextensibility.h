// Edge inextensibility (the paper's eq. 1, weight k_mi): a deformed edge
// keeps its template length.
//
//   r = w s,  s = (|x_i - x_j| - L) / L          (robust_strain b = 0)
//   r = w s sqrt(2 / (1 + sqrt(1 + (s / b)^2)))   (b > 0)
//
// L is the edge's template length (data), w = sqrt(k_mi / #edges) in the
// solver. With b > 0, r^2 = w^2 2 b^2 (sqrt(1 + (s/b)^2) - 1), the
// pseudo-Huber penalty: s^2 for strains well below b, 2 b |s| well above,
// so that a few edges a model cannot keep (a fold a smooth patch does not
// bend to) are not what the rest of the surface stretches to spread.
// Parameter blocks, in order: x_i (3), x_j (3).
#ifndef COST_FUNCTIONS_EDGE_INEXTENSIBILITY_H_
#define COST_FUNCTIONS_EDGE_INEXTENSIBILITY_H_

#include <cmath>
#include <stdexcept>

#include <ceres/autodiff_cost_function.h>

#include "cost_functions/pseudo_huber.h"

namespace polyfit {

class EdgeInextensibilityResidual {
 public:
  EdgeInextensibilityResidual(double rest_length, double weight, double robust_strain = 0.0)
      : rest_length_(rest_length), weight_(weight), robust_strain_(robust_strain) {}

  template <typename T>
  bool operator()(const T* x_i, const T* x_j, T* residual) const {
    using std::sqrt;
    const T dx = x_i[0] - x_j[0], dy = x_i[1] - x_j[1], dz = x_i[2] - x_j[2];
    // The derivative of |e| at e = 0 is undefined: a tiny floor keeps it finite.
    const T length = sqrt(dx * dx + dy * dy + dz * dz + T(1e-30));
    const T strain = (length - T(rest_length_)) / T(rest_length_);
    residual[0] = T(weight_) * strain;
    if (robust_strain_ > 0.0) residual[0] *= PseudoHuberFactor(strain / T(robust_strain_));
    return true;
  }

  // rest_length > 0 and robust_strain >= 0 (finite), else
  // std::invalid_argument.
  static ceres::CostFunction* Create(double rest_length, double weight = 1.0, double robust_strain = 0.0) {
    if (!(rest_length > 0.0)) throw std::invalid_argument("EdgeInextensibilityResidual: rest_length must be > 0");
    if (!(robust_strain >= 0.0) || !std::isfinite(robust_strain)) {
      throw std::invalid_argument("EdgeInextensibilityResidual: robust_strain must be finite and >= 0");
    }
    return new ceres::AutoDiffCostFunction<EdgeInextensibilityResidual, 1, 3, 3>(
        new EdgeInextensibilityResidual(rest_length, weight, robust_strain));
  }

 private:
  double rest_length_;
  double weight_;
  double robust_strain_;  // b; 0: squared
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_EDGE_INEXTENSIBILITY_H_
