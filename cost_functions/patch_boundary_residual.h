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
#ifndef COST_FUNCTIONS_PATCH_BOUNDARY_RESIDUAL_H_
#define COST_FUNCTIONS_PATCH_BOUNDARY_RESIDUAL_H_

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include <ceres/autodiff_cost_function.h>
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

}  // namespace polyfit

#endif  // COST_FUNCTIONS_PATCH_BOUNDARY_RESIDUAL_H_
