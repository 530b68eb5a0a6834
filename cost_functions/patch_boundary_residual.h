// Patch boundary continuity (the paper's eq. 5, weight k_b): a vertex on the
// boundary between patches a and b is at the same place, with the same
// normal, on both jets.
//
//   X_p = s_p R_p (u_p, v_p, z(u_p, v_p; alpha_p)) + T_p
//   n_p = R_p (-z_u, -z_v, 1) / |(-z_u, -z_v, 1)|
//   r = (w_x (X_a - X_b - d_x), w_n (n_a - n_b - d_n))          6 residuals
//
// d_x, d_n are zero in the paper; a solver may pass the gaps its patches
// have at rest (a fit's residual), so that the term keeps seams as they
// were rather than shrinking patches to close a gap no shape can close.
//
// R_p and (u_p, v_p) are data (PolyFitModel::BoundaryPoints). Parameter
// blocks: alpha_a (NumJetCoefficients(order)), s_a (1), T_a (3), alpha_b,
// s_b, T_b.
//
// PatchBoundaryResidual is the templated functor (autodiff, or inside other
// functors); PatchBoundaryCost below is the same residual with hand-derived
// Jacobians, for solvers that evaluate many seams per iteration.
#ifndef COST_FUNCTIONS_PATCH_BOUNDARY_RESIDUAL_H_
#define COST_FUNCTIONS_PATCH_BOUNDARY_RESIDUAL_H_

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include <ceres/autodiff_cost_function.h>
#include <ceres/cost_function.h>
#include <Eigen/Core>

#include "cost_functions/jet_order_dispatch.h"
#include "polyfit/jet/jet_surface.h"

namespace polyfit {

class PatchBoundaryResidual {
 public:
  PatchBoundaryResidual(int order, const Eigen::Vector2d& uv_a, const Eigen::Matrix3d& rotation_a,
                        const Eigen::Vector2d& uv_b, const Eigen::Matrix3d& rotation_b, double position_weight,
                        double normal_weight, const Eigen::Vector3d& position_gap = Eigen::Vector3d::Zero(),
                        const Eigen::Vector3d& normal_gap = Eigen::Vector3d::Zero())
      : order_(order),
        uv_a_(uv_a),
        uv_b_(uv_b),
        rotation_a_(rotation_a),
        rotation_b_(rotation_b),
        position_weight_(position_weight),
        normal_weight_(normal_weight),
        position_gap_(position_gap),
        normal_gap_(normal_gap) {}

  template <typename T>
  bool operator()(const T* alpha_a, const T* scale_a, const T* translation_a, const T* alpha_b, const T* scale_b,
                  const T* translation_b, T* residual) const {
    T xa[3], na[3], xb[3], nb[3];
    Point(alpha_a, scale_a[0], translation_a, uv_a_, rotation_a_, xa, na);
    Point(alpha_b, scale_b[0], translation_b, uv_b_, rotation_b_, xb, nb);
    Difference(xa, na, xb, nb, position_weight_, normal_weight_, residual, position_gap_, normal_gap_);
    return true;
  }

  // The residual from the points and normals both patches give (eq. 5),
  // for solvers whose patches are parameterised otherwise
  // (sft/solver/frame_costs.h's seams).
  template <typename T>
  static void Difference(const T* xa, const T* na, const T* xb, const T* nb, double position_weight,
                         double normal_weight, T* residual,
                         const Eigen::Vector3d& position_gap = Eigen::Vector3d::Zero(),
                         const Eigen::Vector3d& normal_gap = Eigen::Vector3d::Zero()) {
    for (int k = 0; k < 3; ++k) {
      residual[k] = T(position_weight) * (xa[k] - xb[k] - T(position_gap[k]));
      residual[3 + k] = T(normal_weight) * (na[k] - nb[k] - T(normal_gap[k]));
    }
  }

  static ceres::CostFunction* Create(int order, const Eigen::Vector2d& uv_a, const Eigen::Matrix3d& rotation_a,
                                     const Eigen::Vector2d& uv_b, const Eigen::Matrix3d& rotation_b,
                                     double position_weight = 1.0, double normal_weight = 1.0,
                                     const Eigen::Vector3d& position_gap = Eigen::Vector3d::Zero(),
                                     const Eigen::Vector3d& normal_gap = Eigen::Vector3d::Zero()) {
    auto functor = std::make_unique<PatchBoundaryResidual>(order, uv_a, rotation_a, uv_b, rotation_b, position_weight,
                                                           normal_weight, position_gap, normal_gap);
    return DispatchJetCoefficients(order, "PatchBoundaryResidual", [&](auto k) -> ceres::CostFunction* {
      constexpr int K = decltype(k)::value;
      return new ceres::AutoDiffCostFunction<PatchBoundaryResidual, 6, K, 1, 3, K, 1, 3>(functor.release());
    });
  }

 private:
  template <typename T>
  void Point(const T* alpha, const T& scale, const T* translation, const Eigen::Vector2d& uv,
             const Eigen::Matrix3d& rotation, T* x, T* n) const {
    const JetHeightDerivatives<T> d = EvaluateJetDerivatives(order_, alpha, T(uv.x()), T(uv.y()));
    T local_normal[3];
    JetNormal(d, local_normal);
    const T local[3] = {T(uv.x()), T(uv.y()), d.z};
    for (int k = 0; k < 3; ++k) {
      x[k] = translation[k];
      n[k] = T(0.0);
      for (int c = 0; c < 3; ++c) {
        x[k] += scale * T(rotation(k, c)) * local[c];
        n[k] += T(rotation(k, c)) * local_normal[c];
      }
    }
  }

  int order_;
  Eigen::Vector2d uv_a_, uv_b_;
  Eigen::Matrix3d rotation_a_, rotation_b_;
  double position_weight_, normal_weight_;
  Eigen::Vector3d position_gap_, normal_gap_;
};

// PatchBoundaryResidual's residual and parameter blocks, with its
// Jacobians by hand. z is linear in alpha, so with the monomials m, m_u, m_v
// at (u_p, v_p) fixed at construction:
//   dX_p/dalpha = s_p R_p e_3 m^T,  dX_p/ds_p = R_p (u_p, v_p, z),  dX_p/dT_p = I
//   dn_p/dalpha = -(R_p P / w) (e_1 m_u^T + e_2 m_v^T),  P = I - n_l n_l^T,
// with n_l = (-z_u, -z_v, 1) / w the normal in the patch's frame; b's
// blocks enter with the opposite sign.
class PatchBoundaryCost final : public ceres::CostFunction {
 public:
  PatchBoundaryCost(int order, const Eigen::Vector2d& uv_a, const Eigen::Matrix3d& rotation_a,
                    const Eigen::Vector2d& uv_b, const Eigen::Matrix3d& rotation_b, double position_weight,
                    double normal_weight, const Eigen::Vector3d& position_gap = Eigen::Vector3d::Zero(),
                    const Eigen::Vector3d& normal_gap = Eigen::Vector3d::Zero())
      : num_coefficients_(NumJetCoefficients(order)),
        position_weight_(position_weight),
        normal_weight_(normal_weight),
        position_gap_(position_gap),
        normal_gap_(normal_gap) {
    if (order < 1 || order > kMaxJetOrder) {
      throw std::invalid_argument("PatchBoundaryCost: order must be in [1, " + std::to_string(kMaxJetOrder) +
                                  "], got " + std::to_string(order));
    }
    Side* sides[2] = {&a_, &b_};
    const Eigen::Vector2d* uvs[2] = {&uv_a, &uv_b};
    const Eigen::Matrix3d* rotations[2] = {&rotation_a, &rotation_b};
    for (int p = 0; p < 2; ++p) {
      sides[p]->uv = *uvs[p];
      sides[p]->rotation = *rotations[p];
      JetMonomialGradients(order, uvs[p]->x(), uvs[p]->y(), sides[p]->m, sides[p]->m_u, sides[p]->m_v);
    }
    set_num_residuals(6);
    for (int p = 0; p < 2; ++p) {
      mutable_parameter_block_sizes()->push_back(num_coefficients_);
      mutable_parameter_block_sizes()->push_back(1);
      mutable_parameter_block_sizes()->push_back(3);
    }
  }

  static ceres::CostFunction* Create(int order, const Eigen::Vector2d& uv_a, const Eigen::Matrix3d& rotation_a,
                                     const Eigen::Vector2d& uv_b, const Eigen::Matrix3d& rotation_b,
                                     double position_weight = 1.0, double normal_weight = 1.0,
                                     const Eigen::Vector3d& position_gap = Eigen::Vector3d::Zero(),
                                     const Eigen::Vector3d& normal_gap = Eigen::Vector3d::Zero()) {
    return new PatchBoundaryCost(order, uv_a, rotation_a, uv_b, rotation_b, position_weight, normal_weight,
                                 position_gap, normal_gap);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    Eigen::Vector3d x[2], n[2];
    for (int p = 0; p < 2; ++p) {
      const Side& side = p == 0 ? a_ : b_;
      const double* alpha = parameters[3 * p];
      const double scale = parameters[3 * p + 1][0];
      double z = 0.0, z_u = 0.0, z_v = 0.0;
      for (int c = 0; c < num_coefficients_; ++c) {
        z += side.m[c] * alpha[c];
        z_u += side.m_u[c] * alpha[c];
        z_v += side.m_v[c] * alpha[c];
      }
      const Eigen::Vector3d local(side.uv.x(), side.uv.y(), z);
      const double w = std::sqrt(1.0 + z_u * z_u + z_v * z_v);
      const Eigen::Vector3d local_normal(-z_u / w, -z_v / w, 1.0 / w);
      x[p] = scale * (side.rotation * local) + Eigen::Map<const Eigen::Vector3d>(parameters[3 * p + 2]);
      n[p] = side.rotation * local_normal;
      if (jacobians != nullptr) Jacobians(side, scale, local, local_normal, w, p == 0 ? 1.0 : -1.0, jacobians + 3 * p);
    }
    PatchBoundaryResidual::Difference(x[0].data(), n[0].data(), x[1].data(), n[1].data(), position_weight_,
                                      normal_weight_, residuals, position_gap_, normal_gap_);
    return true;
  }

 private:
  struct Side {
    Eigen::Vector2d uv;
    Eigen::Matrix3d rotation;
    double m[kMaxJetCoefficients], m_u[kMaxJetCoefficients], m_v[kMaxJetCoefficients];
  };

  // One patch's three blocks (row-major, 6 rows each); sign: +1 for a, -1
  // for b.
  void Jacobians(const Side& side, double scale, const Eigen::Vector3d& local, const Eigen::Vector3d& local_normal,
                 double w, double sign, double** jacobians) const {
    const int k_count = num_coefficients_;
    if (jacobians[0] != nullptr) {
      const Eigen::Vector3d dx = sign * position_weight_ * scale * side.rotation.col(2);
      const Eigen::Matrix3d g =
          side.rotation * (Eigen::Matrix3d::Identity() - local_normal * local_normal.transpose()) / w;
      const Eigen::Vector3d dn_u = -sign * normal_weight_ * g.col(0), dn_v = -sign * normal_weight_ * g.col(1);
      for (int c = 0; c < k_count; ++c) {
        for (int k = 0; k < 3; ++k) {
          jacobians[0][k * k_count + c] = dx[k] * side.m[c];
          jacobians[0][(3 + k) * k_count + c] = dn_u[k] * side.m_u[c] + dn_v[k] * side.m_v[c];
        }
      }
    }
    if (jacobians[1] != nullptr) {
      const Eigen::Vector3d ds = sign * position_weight_ * (side.rotation * local);
      for (int k = 0; k < 3; ++k) {
        jacobians[1][k] = ds[k];
        jacobians[1][3 + k] = 0.0;
      }
    }
    if (jacobians[2] != nullptr) {
      for (int i = 0; i < 18; ++i) jacobians[2][i] = 0.0;
      for (int k = 0; k < 3; ++k) jacobians[2][3 * k + k] = sign * position_weight_;
    }
  }

  int num_coefficients_;
  Side a_, b_;
  double position_weight_, normal_weight_;
  Eigen::Vector3d position_gap_, normal_gap_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_PATCH_BOUNDARY_RESIDUAL_H_
