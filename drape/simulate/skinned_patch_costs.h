// Per-vertex and per-edge draping terms on skinned jet patches, with
// analytic Jacobians (the reference drape builds tens of thousands per
// frame). A garment point with rest parameters (u, v) on patch p, slid by
// (du, dv) along the patch, is
//
//   X = s R (u', v', z(u', v'; alpha)) + T    canonical (rest-pose) space,
//                                             (u', v') = (u + du, v + dv)
//   x = M X + b                               posed by the vertex's blended
//                                             skinning map (M, b)
//
// so dx/dalpha_k = s (M R e_3) m_k(u', v'), dx/ds = M R (u', v', z),
// dx/dT = M, dx/d(du, dv) = s M R [(1, 0, z_u), (0, 1, z_v)], with m_k the
// jet's monomials. The slide keeps every point on its patch's jet while
// letting it move in the patch's plane (what skinning distorts). Parameter
// blocks of the vertex cost: alpha (NumJetCoefficients(order)), s (1),
// T (3), slide (2); of the edge cost: alpha, s, T, slide_i, slide_j.
// Tested against autodiff of the same formulas in drape_solver_test.cc.
#ifndef POLYFIT_DRAPE_SIMULATE_SKINNED_PATCH_COSTS_H_
#define POLYFIT_DRAPE_SIMULATE_SKINNED_PATCH_COSTS_H_

#include <algorithm>
#include <cmath>

#include <ceres/cost_function.h>
#include <Eigen/Core>

#include "polyfit/jet/jet_basis.h"

namespace polyfit {

// A point's jet evaluated at its slid parameters.
struct PatchPointState {
  double monomials[kMaxJetCoefficients];
  double z = 0.0, z_u = 0.0, z_v = 0.0;
  Eigen::Vector3d local = Eigen::Vector3d::Zero();  // (u', v', z)
};

// The posed point and its Jacobian blocks. The skinning map (M, b) is
// read through pointers at each evaluation, so that a solver can keep its
// problem across frames and only update the maps.
class SkinnedPatchPoint {
 public:
  SkinnedPatchPoint() = default;
  SkinnedPatchPoint(int order, double u, double v, const Eigen::Matrix3d& rotation, const Eigen::Matrix3d* skin_linear,
                    const Eigen::Vector3d* skin_translation)
      : order_(order), num_coefficients_(NumJetCoefficients(order)), u_(u), v_(v), rotation_(rotation),
        skin_linear_(skin_linear), skin_translation_(skin_translation) {}

  int num_coefficients() const { return num_coefficients_; }

  // slide: (du, dv), or nullptr for none.
  PatchPointState State(const double* alpha, const double* slide) const {
    PatchPointState state;
    const double u = u_ + (slide != nullptr ? slide[0] : 0.0);
    const double v = v_ + (slide != nullptr ? slide[1] : 0.0);
    double u_pow[kMaxJetOrder + 1], v_pow[kMaxJetOrder + 1];
    JetPowers(order_, u, v, u_pow, v_pow);
    int k = 0;
    for (int d = 0; d <= order_; ++d) {
      for (int b = 0; b <= d; ++b, ++k) {
        const int a = d - b;
        state.monomials[k] = u_pow[a] * v_pow[b];
        state.z += alpha[k] * state.monomials[k];
        if (a >= 1) state.z_u += alpha[k] * a * u_pow[a - 1] * v_pow[b];
        if (b >= 1) state.z_v += alpha[k] * b * u_pow[a] * v_pow[b - 1];
      }
    }
    state.local = Eigen::Vector3d(u, v, state.z);
    return state;
  }

  Eigen::Vector3d Canonical(const PatchPointState& state, const double* scale, const double* translation) const {
    return scale[0] * (rotation_ * state.local) + Eigen::Map<const Eigen::Vector3d>(translation);
  }
  Eigen::Vector3d Position(const PatchPointState& state, const double* scale, const double* translation) const {
    return *skin_linear_ * Canonical(state, scale, translation) + *skin_translation_;
  }
  Eigen::Vector3d Position(const double* alpha, const double* scale, const double* translation,
                           const double* slide) const {
    return Position(State(alpha, slide), scale, translation);
  }

  // Writes sign dr_dx dx/dblock (row-major) into jacobians[0..2] (alpha, s,
  // T; added to them with accumulate) and jacobians[slide_block].
  template <int kRows>
  void Chain(const Eigen::Matrix<double, kRows, 3>& dr_dx, const PatchPointState& state, const double* scale,
             double** jacobians, int slide_block, double sign = 1.0, bool accumulate = false) const {
    ChainCanonical<kRows>(sign * (dr_dx * *skin_linear_), state, scale, jacobians, slide_block, accumulate);
  }
  // The same from the derivative with respect to the canonical point X.
  template <int kRows>
  void ChainCanonical(const Eigen::Matrix<double, kRows, 3>& dr_dcanonical, const PatchPointState& state,
                      const double* scale, double** jacobians, int slide_block, bool accumulate = false) const {
    const auto write = [accumulate](auto&& target, const auto& value) {
      if (accumulate) {
        target += value;
      } else {
        target = value;
      }
    };
    const Eigen::Matrix<double, kRows, 3> dr_dlocal = scale[0] * (dr_dcanonical * rotation_);
    if (jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, kRows, Eigen::Dynamic, Eigen::RowMajor>> j(jacobians[0], kRows, num_coefficients_);
      for (int k = 0; k < num_coefficients_; ++k) write(j.col(k), dr_dlocal.col(2) * state.monomials[k]);
    }
    if (jacobians[1] != nullptr) {
      write(Eigen::Map<Eigen::Matrix<double, kRows, 1>>(jacobians[1]), dr_dcanonical * (rotation_ * state.local));
    }
    if (jacobians[2] != nullptr) {
      write(Eigen::Map<Eigen::Matrix<double, kRows, 3, Eigen::RowMajor>>(jacobians[2]), dr_dcanonical);
    }
    if (jacobians[slide_block] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, kRows, 2, Eigen::RowMajor>> j(jacobians[slide_block]);
      // A point's own block: never shared, always written.
      j.col(0) = dr_dlocal.col(0) + dr_dlocal.col(2) * state.z_u;
      j.col(1) = dr_dlocal.col(1) + dr_dlocal.col(2) * state.z_v;
    }
  }

 private:
  int order_ = 0;
  int num_coefficients_ = 0;
  double u_ = 0.0, v_ = 0.0;
  Eigen::Matrix3d rotation_ = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d* skin_linear_ = nullptr;
  const Eigen::Vector3d* skin_translation_ = nullptr;
};

// The vertex terms (a term that is off gives 0):
//   collision   w_c max(eps - (x - c) . n, 0)                 energy w_c^2 / 2 depth^2
//   inertia     w_i (x - x_hat + w_g / w_i^2 up)  (3)         energy w_i^2 / 2 |x - x_hat|^2
//                                                                    + w_g x . up + const
// so gravity's linear energy w_g (x . up - floor) rides on the inertia
// residual, exactly (completing the square); without inertia it is
//   gravity     sqrt(2 w_g (x . up - floor))                  energy w_g (x . up - floor)
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

// Residuals: the collision, then (with `motion`) the three inertia ones, or
// the gravity one when the inertia weight is 0 at construction. The data
// is read through a pointer at each evaluation (updated per frame).
class SkinnedVertexCost : public ceres::CostFunction {
 public:
  SkinnedVertexCost(const SkinnedPatchPoint& point, const VertexTermsData* data, bool motion = true)
      : point_(point), data_(*data) {
    rows_ = !motion ? 1 : (data->inertia_weight > 0.0 ? 4 : 2);
    set_num_residuals(rows_);
    mutable_parameter_block_sizes()->assign({point.num_coefficients(), 1, 3, 2});
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const PatchPointState state = point_.State(parameters[0], parameters[3]);
    const Eigen::Vector3d x = point_.Position(state, parameters[1], parameters[2]);
    Eigen::Matrix<double, 4, 3> dr_dx = Eigen::Matrix<double, 4, 3>::Zero();
    residuals[0] = 0.0;
    if (data_.collision) {
      const double depth = data_.margin - (x - data_.closest).dot(data_.normal);
      if (depth > 0.0) {
        residuals[0] = data_.collision_weight * depth;
        dr_dx.row(0) = -data_.collision_weight * data_.normal.transpose();
      }
    }
    if (rows_ == 4) {
      const double w = data_.inertia_weight;
      const Eigen::Vector3d target = data_.target - data_.gravity_weight / (w * w) * data_.up;
      for (int k = 0; k < 3; ++k) residuals[1 + k] = w * (x[k] - target[k]);
      dr_dx.bottomRows<3>() = w * Eigen::Matrix3d::Identity();
    } else if (rows_ == 2) {
      residuals[1] = 0.0;
      if (data_.gravity_weight > 0.0) {
        const double height = std::max(x.dot(data_.up) - data_.floor, 1e-9);
        residuals[1] = std::sqrt(2.0 * data_.gravity_weight * height);
        dr_dx.row(1) = data_.gravity_weight / residuals[1] * data_.up.transpose();
      }
    }
    if (jacobians == nullptr) return true;
    switch (rows_) {
      case 1: point_.Chain<1>(dr_dx.topRows<1>(), state, parameters[1], jacobians, 3); break;
      case 2: point_.Chain<2>(dr_dx.topRows<2>(), state, parameters[1], jacobians, 3); break;
      default: point_.Chain<4>(dr_dx, state, parameters[1], jacobians, 3); break;
    }
    return true;
  }

 private:
  SkinnedPatchPoint point_;
  const VertexTermsData& data_;
  int rows_ = 1;
};

// Edge inextensibility (eq. 1) between two points of one patch:
//   r = w (|x_i - x_j| - L) / L                               energy w^2 / 2 strain^2
// Blocks: alpha, s, T, slide_i, slide_j.
class SkinnedEdgeCost : public ceres::CostFunction {
 public:
  SkinnedEdgeCost(const SkinnedPatchPoint& point_i, const SkinnedPatchPoint& point_j, double rest_length, double weight)
      : point_i_(point_i), point_j_(point_j), rest_length_(rest_length), weight_(weight) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->assign({point_i.num_coefficients(), 1, 3, 2, 2});
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const PatchPointState state_i = point_i_.State(parameters[0], parameters[3]);
    const PatchPointState state_j = point_j_.State(parameters[0], parameters[4]);
    const Eigen::Vector3d e = point_i_.Position(state_i, parameters[1], parameters[2]) -
                              point_j_.Position(state_j, parameters[1], parameters[2]);
    const double length = e.norm();
    residuals[0] = weight_ * (length - rest_length_) / rest_length_;
    if (jacobians != nullptr) {
      Eigen::Matrix<double, 1, 3> dr_dx = Eigen::Matrix<double, 1, 3>::Zero();
      if (length > 0.0) dr_dx = weight_ / (rest_length_ * length) * e.transpose();
      point_i_.Chain<1>(dr_dx, state_i, parameters[1], jacobians, 3);
      point_j_.Chain<1>(dr_dx, state_j, parameters[1], jacobians, 4, -1.0, true);
    }
    return true;
  }

 private:
  SkinnedPatchPoint point_i_, point_j_;
  double rest_length_, weight_;
};

// Two patches' points of one garment vertex kept together once slid, in
// the canonical space they share (both are posed by the vertex's map):
//   r = w (X_a - X_b - g)                       energy w^2 / 2 |X_a - X_b - g|^2
// with g their gap at rest (the fits' disagreement there). Blocks: alpha_a,
// s_a, T_a, slide_a, alpha_b, s_b, T_b, slide_b.
class SkinnedAgreementCost : public ceres::CostFunction {
 public:
  SkinnedAgreementCost(const SkinnedPatchPoint& point_a, const SkinnedPatchPoint& point_b, const Eigen::Vector3d& rest_gap,
                       double weight)
      : point_a_(point_a), point_b_(point_b), rest_gap_(rest_gap), weight_(weight) {
    set_num_residuals(3);
    mutable_parameter_block_sizes()->assign({point_a.num_coefficients(), 1, 3, 2, point_b.num_coefficients(), 1, 3, 2});
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const PatchPointState state_a = point_a_.State(parameters[0], parameters[3]);
    const PatchPointState state_b = point_b_.State(parameters[4], parameters[7]);
    Eigen::Map<Eigen::Vector3d> r(residuals);
    r = weight_ * (point_a_.Canonical(state_a, parameters[1], parameters[2]) -
                   point_b_.Canonical(state_b, parameters[5], parameters[6]) - rest_gap_);
    if (jacobians != nullptr) {
      const Eigen::Matrix3d d = weight_ * Eigen::Matrix3d::Identity();
      point_a_.ChainCanonical<3>(d, state_a, parameters[1], jacobians, 3);
      point_b_.ChainCanonical<3>(-d, state_b, parameters[5], jacobians + 4, 3);
    }
    return true;
  }

 private:
  SkinnedPatchPoint point_a_, point_b_;
  Eigen::Vector3d rest_gap_;
  double weight_;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_SKINNED_PATCH_COSTS_H_
