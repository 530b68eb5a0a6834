// Per-vertex and per-edge draping terms on skinned jet patches, with
// analytic Jacobians (the reference drape builds tens of thousands per
// frame). A garment point with parameters (u, v) on patch p is
//
//   X = s R (u, v, z(u, v; alpha)) + T        canonical (rest-pose) space
//   x = M X + b                               posed by the vertex's blended
//                                             skinning map (M, b)
//
// so dx/dalpha_k = s (M R e_3) m_k(u, v), dx/ds = M R (u, v, z), dx/dT = M,
// with m_k the jet's monomials. Parameter blocks of every cost: alpha
// (NumJetCoefficients(order)), s (1), T (3). Tested against autodiff of the
// same formulas in drape_solver_test.cc.
#ifndef POLYFIT_DRAPE_SIMULATE_SKINNED_PATCH_COSTS_H_
#define POLYFIT_DRAPE_SIMULATE_SKINNED_PATCH_COSTS_H_

#include <algorithm>
#include <cmath>

#include <ceres/cost_function.h>
#include <Eigen/Core>

#include "polyfit/jet/jet_basis.h"

namespace polyfit {

// The posed point and its Jacobian blocks. The skinning map (M, b) is
// read through pointers at each evaluation, so that a solver can keep its
// problem across frames and only update the maps.
class SkinnedPatchPoint {
 public:
  SkinnedPatchPoint() = default;
  SkinnedPatchPoint(int order, double u, double v, const Eigen::Matrix3d& rotation, const Eigen::Matrix3d* skin_linear,
                    const Eigen::Vector3d* skin_translation)
      : num_coefficients_(NumJetCoefficients(order)), u_(u), v_(v), rotation_(rotation), skin_linear_(skin_linear),
        skin_translation_(skin_translation) {
    JetMonomials(order, u, v, monomials_);
  }

  int num_coefficients() const { return num_coefficients_; }

  Eigen::Vector3d Position(const double* alpha, const double* scale, const double* translation) const {
    const Eigen::Vector3d canonical =
        scale[0] * (rotation_ * Eigen::Vector3d(u_, v_, Height(alpha))) + Eigen::Map<const Eigen::Vector3d>(translation);
    return *skin_linear_ * canonical + *skin_translation_;
  }

  // Writes dr_dx * dx/dblock into the blocks asked for (row-major), or adds
  // sign times it (accumulate).
  template <int kRows>
  void Chain(const Eigen::Matrix<double, kRows, 3>& dr_dx, const double* alpha, const double* scale,
             double** jacobians, double sign = 1.0, bool accumulate = false) const {
    const Eigen::Matrix<double, kRows, 3> dr_dcanonical = sign * (dr_dx * *skin_linear_);
    if (jacobians[0] != nullptr) {
      const Eigen::Matrix<double, kRows, 1> along = scale[0] * (dr_dcanonical * rotation_.col(2));
      Eigen::Map<Eigen::Matrix<double, kRows, Eigen::Dynamic, Eigen::RowMajor>> j(jacobians[0], kRows, num_coefficients_);
      for (int k = 0; k < num_coefficients_; ++k) {
        if (accumulate) {
          j.col(k) += along * monomials_[k];
        } else {
          j.col(k) = along * monomials_[k];
        }
      }
    }
    if (jacobians[1] != nullptr) {
      const Eigen::Matrix<double, kRows, 1> ds = dr_dcanonical * (rotation_ * Eigen::Vector3d(u_, v_, Height(alpha)));
      Eigen::Map<Eigen::Matrix<double, kRows, 1>> j(jacobians[1]);
      if (accumulate) {
        j += ds;
      } else {
        j = ds;
      }
    }
    if (jacobians[2] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, kRows, 3, Eigen::RowMajor>> j(jacobians[2]);
      if (accumulate) {
        j += dr_dcanonical;
      } else {
        j = dr_dcanonical;
      }
    }
  }

 private:
  double Height(const double* alpha) const {
    double z = 0.0;
    for (int k = 0; k < num_coefficients_; ++k) z += alpha[k] * monomials_[k];
    return z;
  }

  int num_coefficients_ = 0;
  double u_ = 0.0, v_ = 0.0;
  double monomials_[kMaxJetCoefficients] = {};
  Eigen::Matrix3d rotation_ = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d* skin_linear_ = nullptr;
  const Eigen::Vector3d* skin_translation_ = nullptr;
};

// The vertex terms, 5 residuals (a term that is off gives 0):
//   collision   w_c max(eps - (x - c) . n, 0)                 energy w_c^2 / 2 depth^2
//   gravity     sqrt(2 w_g (x . up - floor))                  energy w_g (x . up - floor)
//   inertia     w_i (x - x_hat)  (3)                          energy w_i^2 / 2 |x - x_hat|^2
struct VertexTermsData {
  bool collision = false;
  Eigen::Vector3d closest = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();
  double margin = 0.0;
  double collision_weight = 0.0;
  double gravity_weight = 0.0;  // w_g = k_g m g; 0 for off
  Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  double floor = 0.0;
  double inertia_weight = 0.0;  // 0 for off
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
};

// The data is read through a pointer at each evaluation (updated per frame).
class SkinnedVertexCost : public ceres::CostFunction {
 public:
  SkinnedVertexCost(const SkinnedPatchPoint& point, const VertexTermsData* data) : point_(point), data_(*data) {
    set_num_residuals(5);
    mutable_parameter_block_sizes()->assign({point.num_coefficients(), 1, 3});
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Vector3d x = point_.Position(parameters[0], parameters[1], parameters[2]);
    Eigen::Matrix<double, 5, 3> dr_dx = Eigen::Matrix<double, 5, 3>::Zero();
    residuals[0] = 0.0;
    if (data_.collision) {
      const double depth = data_.margin - (x - data_.closest).dot(data_.normal);
      if (depth > 0.0) {
        residuals[0] = data_.collision_weight * depth;
        dr_dx.row(0) = -data_.collision_weight * data_.normal.transpose();
      }
    }
    residuals[1] = 0.0;
    if (data_.gravity_weight > 0.0) {
      const double height = std::max(x.dot(data_.up) - data_.floor, 1e-9);
      residuals[1] = std::sqrt(2.0 * data_.gravity_weight * height);
      dr_dx.row(1) = data_.gravity_weight / residuals[1] * data_.up.transpose();
    }
    for (int k = 0; k < 3; ++k) residuals[2 + k] = data_.inertia_weight * (x[k] - data_.target[k]);
    dr_dx.bottomRows<3>() = data_.inertia_weight * Eigen::Matrix3d::Identity();
    if (jacobians != nullptr) point_.Chain<5>(dr_dx, parameters[0], parameters[1], jacobians);
    return true;
  }

 private:
  SkinnedPatchPoint point_;
  const VertexTermsData& data_;
};

// Edge inextensibility (eq. 1) between two points of one patch:
//   r = w (|x_i - x_j| - L) / L                               energy w^2 / 2 strain^2
class SkinnedEdgeCost : public ceres::CostFunction {
 public:
  SkinnedEdgeCost(const SkinnedPatchPoint& point_i, const SkinnedPatchPoint& point_j, double rest_length, double weight)
      : point_i_(point_i), point_j_(point_j), rest_length_(rest_length), weight_(weight) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->assign({point_i.num_coefficients(), 1, 3});
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Vector3d e = point_i_.Position(parameters[0], parameters[1], parameters[2]) -
                              point_j_.Position(parameters[0], parameters[1], parameters[2]);
    const double length = e.norm();
    residuals[0] = weight_ * (length - rest_length_) / rest_length_;
    if (jacobians != nullptr) {
      Eigen::Matrix<double, 1, 3> dr_dx = Eigen::Matrix<double, 1, 3>::Zero();
      if (length > 0.0) dr_dx = weight_ / (rest_length_ * length) * e.transpose();
      point_i_.Chain<1>(dr_dx, parameters[0], parameters[1], jacobians);
      point_j_.Chain<1>(dr_dx, parameters[0], parameters[1], jacobians, -1.0, true);
    }
    return true;
  }

 private:
  SkinnedPatchPoint point_i_, point_j_;
  double rest_length_, weight_;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_SKINNED_PATCH_COSTS_H_
