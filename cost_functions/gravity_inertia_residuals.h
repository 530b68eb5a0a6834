// Gravity (the paper's eq. 7, weight k_g) and inertia (eq. 8, weight k_i)
// for a garment vertex of mass m, as least-squares residuals.
//
// Gravity's energy E = k_g m g (x . up - h0) is linear; as a residual
//   r = sqrt(2 k_g m g (x . up - floor))
// gives r^2 / 2 = E + const and the same gradient, for any floor below
// every point (h0 drops out; x . up must stay above the floor).
//
// Gravity below the floor is not defined: the functor returns false there
// (Ceres rejects the step). Pick the floor well below any reachable point,
// or fold gravity into inertia (below), which is defined everywhere.
//
// Inertia keeps a vertex on its momentum:
//   r = sqrt(k_i m) / dt (x - (2 x_{t-1} - x_{t-2}))       (3 residuals)
// so r^2 / 2 = k_i m / (2 dt^2) |x - x_pred|^2 (an implicit-Euler step).
// With gravity folded in (completing the square), the target moves down by
// k_g g dt^2 / k_i:
//   r^2 / 2 = k_i m / (2 dt^2) |x - x_pred|^2 + k_g m g x . up + const,
// gravity's exact energy and gradient with no floor.
//
// Parameter block of both: x (3). Everything else is data.
#ifndef COST_FUNCTIONS_GRAVITY_INERTIA_RESIDUALS_H_
#define COST_FUNCTIONS_GRAVITY_INERTIA_RESIDUALS_H_

#include <cmath>
#include <stdexcept>

#include <ceres/autodiff_cost_function.h>
#include <Eigen/Core>

namespace polyfit {

class GravityResidual {
 public:
  // up: unit vector against gravity; g in m/s^2.
  GravityResidual(double mass, double gravity, const Eigen::Vector3d& up, double floor, double weight)
      : scale_(2.0 * weight * mass * gravity), up_(up), floor_(floor) {}

  template <typename T>
  bool operator()(const T* x, T* residual) const {
    using std::sqrt;
    const T height = x[0] * up_[0] + x[1] * up_[1] + x[2] * up_[2] - T(floor_);
    if (height <= T(0.0)) return false;  // below the floor: not defined
    residual[0] = sqrt(T(scale_) * height);
    return true;
  }

  static ceres::CostFunction* Create(double mass, double gravity, const Eigen::Vector3d& up, double floor,
                                     double weight = 1.0) {
    if (!(mass > 0.0) || !(gravity >= 0.0) || !(up.norm() > 0.0)) {
      throw std::invalid_argument("GravityResidual: mass > 0, gravity >= 0 and a non-zero up vector are needed");
    }
    return new ceres::AutoDiffCostFunction<GravityResidual, 1, 3>(
        new GravityResidual(mass, gravity, up.normalized(), floor, weight));
  }

 private:
  double scale_;
  Eigen::Vector3d up_;
  double floor_;
};

class InertiaResidual {
 public:
  // gravity_weight: k_g, 0 for inertia alone; up: unit vector against
  // gravity; g in m/s^2.
  InertiaResidual(const Eigen::Vector3d& previous, const Eigen::Vector3d& before_previous, double mass, double dt,
                  double weight, double gravity_weight = 0.0, double gravity = 9.81,
                  const Eigen::Vector3d& up = Eigen::Vector3d::UnitY())
      : predicted_(2.0 * previous - before_previous + GravityShift(dt, weight, gravity_weight, gravity, up)),
        scale_(std::sqrt(weight * mass) / dt) {}

  // How far gravity folded into inertia moves the target x_pred:
  // -(k_g g dt^2 / k_i) up (zero without either weight). With k_g = k_i,
  // g dt^2 along gravity: where a free fall is after one more step.
  static Eigen::Vector3d GravityShift(double dt, double weight, double gravity_weight, double gravity,
                                      const Eigen::Vector3d& up) {
    if (!(gravity_weight > 0.0 && weight > 0.0)) return Eigen::Vector3d::Zero();
    return -(gravity_weight * gravity * dt * dt / weight) * up;
  }

  template <typename T>
  bool operator()(const T* x, T* residual) const {
    for (int k = 0; k < 3; ++k) residual[k] = T(scale_) * (x[k] - T(predicted_[k]));
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& previous, const Eigen::Vector3d& before_previous,
                                     double mass, double dt, double weight = 1.0, double gravity_weight = 0.0,
                                     double gravity = 9.81, const Eigen::Vector3d& up = Eigen::Vector3d::UnitY()) {
    if (!(mass > 0.0) || !(dt > 0.0) || !(weight >= 0.0) || !(gravity_weight >= 0.0) || !(up.norm() > 0.0)) {
      throw std::invalid_argument(
          "InertiaResidual: mass > 0, dt > 0, weights >= 0 and a non-zero up vector are needed");
    }
    if (gravity_weight > 0.0 && !(weight > 0.0)) {
      throw std::invalid_argument("InertiaResidual: gravity folds into inertia only with an inertia weight > 0");
    }
    return new ceres::AutoDiffCostFunction<InertiaResidual, 3, 3>(
        new InertiaResidual(previous, before_previous, mass, dt, weight, gravity_weight, gravity, up.normalized()));
  }

  // The target x_pred (gravity's shift included).
  const Eigen::Vector3d& predicted() const { return predicted_; }

 private:
  Eigen::Vector3d predicted_;
  double scale_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_GRAVITY_INERTIA_RESIDUALS_H_
