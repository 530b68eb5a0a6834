// OneFit's draping terms on skinned jet patches, as Ceres costs over a
// patch's parameters, with analytic Jacobians (the reference drape builds
// tens of thousands per frame). A garment point with rest parameters (u, v)
// on patch p, slid by (du, dv) along the patch, is
//
//   X = s R (u', v', z(u', v'; alpha)) + T    canonical (rest-pose) space,
//                                             (u', v') = (u + du, v + dv)
//   x = M X + b                               posed by the vertex's blended
//                                             skinning map (M, b)
//
// so dx/dalpha_k = s (M R e_3) m_k(u', v'), dx/ds = M R (u', v', z),
// dx/dT = M, dx/d(du, dv) = s M R [(1, 0, z_u), (0, 1, z_v)], with m_k the
// jet's monomials (polyfit/jet/jet_basis.h). The slide keeps every point on
// its patch's jet while letting it move in the patch's plane (what skinning
// distorts).
//
// The residuals in x are the functors of cost_functions/ (collision,
// inertia with gravity folded in, gravity, edge inextensibility), evaluated
// on ceres::Jet at x and chained through dx/dparameters by hand, as
// sft/solver/frame_costs.cc does. Parameter blocks of the vertex cost:
// alpha (NumJetCoefficients(order)), s (1), T (3), slide (2); of the edge
// cost: alpha, s, T, slide_i, slide_j. Tested against autodiff in
// skinned_patch_costs_test.cc.
#ifndef POLYFIT_DRAPE_LOSSES_SKINNED_PATCH_COSTS_H_
#define POLYFIT_DRAPE_LOSSES_SKINNED_PATCH_COSTS_H_

#include <algorithm>
#include <cmath>
#include <optional>

#include <ceres/cost_function.h>
#include <ceres/jet.h>
#include <Eigen/Core>

#include "cost_functions/collision_residual.h"
#include "cost_functions/edge_inextensibility.h"
#include "cost_functions/gravity_inertia_residuals.h"
#include "cost_functions/metric_inextensibility_residual.h"
#include "polyfit/jet/jet_basis.h"
#include "polyfit/jet/jet_surface.h"

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
      : order_(order),
        num_coefficients_(NumJetCoefficients(order)),
        u_(u),
        v_(v),
        rotation_(rotation),
        skin_linear_(skin_linear),
        skin_translation_(skin_translation) {}

  int num_coefficients() const { return num_coefficients_; }

  // slide: (du, dv), or nullptr for none.
  PatchPointState State(const double* alpha, const double* slide) const {
    PatchPointState state;
    const double u = u_ + (slide != nullptr ? slide[0] : 0.0);
    const double v = v_ + (slide != nullptr ? slide[1] : 0.0);
    double m_u[kMaxJetCoefficients], m_v[kMaxJetCoefficients];
    JetMonomialGradients(order_, u, v, state.monomials, m_u, m_v);
    for (int k = 0; k < num_coefficients_; ++k) {
      state.z += alpha[k] * state.monomials[k];
      state.z_u += alpha[k] * m_u[k];
      state.z_v += alpha[k] * m_v[k];
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
  // The canonical point alone (no slopes), before skinning. kOrder: the
  // jet's order when known at compile time (the loops unrolled), or -1.
  template <int kOrder = -1>
  Eigen::Vector3d CanonicalOf(const double* alpha, const double* scale, const double* translation,
                              const double* slide) const {
    const double u = u_ + (slide != nullptr ? slide[0] : 0.0);
    const double v = v_ + (slide != nullptr ? slide[1] : 0.0);
    const Eigen::Vector3d local(u, v, EvaluateJetHeight(kOrder < 0 ? order_ : kOrder, alpha, u, v));
    return scale[0] * (rotation_ * local) + Eigen::Map<const Eigen::Vector3d>(translation);
  }
  // The posed point alone (no slopes: what drawing a frame needs).
  Eigen::Vector3d Position(const double* alpha, const double* scale, const double* translation,
                           const double* slide) const {
    return *skin_linear_ * CanonicalOf(alpha, scale, translation, slide) + *skin_translation_;
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
      Eigen::Map<Eigen::Matrix<double, kRows, Eigen::Dynamic, Eigen::RowMajor>> j(jacobians[0], kRows,
                                                                                  num_coefficients_);
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

// A residual functor of cost_functions/ with one 3-vector block, evaluated
// at x: its residuals and their derivative rows in dr_dx.
// Rows first_row.. of dr_dx (4 by 3) are written.
template <int kRows, typename Functor>
bool EvaluateAtPoint(const Functor& functor, const Eigen::Vector3d& x, int first_row, double* residuals,
                     Eigen::Matrix<double, 4, 3>* dr_dx) {
  using J3 = ceres::Jet<double, 3>;
  const J3 point[3] = {J3(x[0], 0), J3(x[1], 1), J3(x[2], 2)};
  J3 r[kRows];
  if (!functor(point, r)) return false;
  for (int i = 0; i < kRows; ++i) {
    residuals[first_row + i] = r[i].a;
    dr_dx->row(first_row + i) = r[i].v.transpose();
  }
  return true;
}

// What a vertex's terms read, set per frame (motion) or per collision pass.
// An unset term gives zero residuals.
struct VertexTermsData {
  std::optional<CollisionResidual> collision;  // where the body is near
  std::optional<InertiaResidual> inertia;      // gravity folded in
  std::optional<GravityResidual> gravity;      // only without inertia
};

// Which rows a vertex cost has: the collision always; at a vertex's owner
// membership also its motion, as inertia (3 rows, gravity folded in) or, with
// no inertia, gravity (1 row).
enum class VertexMotion { kNone, kInertia, kGravity };

// Residuals: collision, then the motion rows. The data is read through a
// pointer at each evaluation (updated per frame).
class SkinnedVertexCost : public ceres::CostFunction {
 public:
  SkinnedVertexCost(const SkinnedPatchPoint& point, const VertexTermsData* data, VertexMotion motion)
      : point_(point), data_(*data), motion_(motion) {
    rows_ = motion == VertexMotion::kInertia ? 4 : (motion == VertexMotion::kGravity ? 2 : 1);
    set_num_residuals(rows_);
    mutable_parameter_block_sizes()->assign({point.num_coefficients(), 1, 3, 2});
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const PatchPointState state = point_.State(parameters[0], parameters[3]);
    const Eigen::Vector3d x = point_.Position(state, parameters[1], parameters[2]);
    Eigen::Matrix<double, 4, 3> dr_dx = Eigen::Matrix<double, 4, 3>::Zero();
    std::fill(residuals, residuals + rows_, 0.0);
    if (data_.collision && !EvaluateAtPoint<1>(*data_.collision, x, 0, residuals, &dr_dx)) return false;
    if (motion_ == VertexMotion::kInertia && data_.inertia &&
        !EvaluateAtPoint<3>(*data_.inertia, x, 1, residuals, &dr_dx)) {
      return false;
    }
    if (motion_ == VertexMotion::kGravity && data_.gravity &&
        !EvaluateAtPoint<1>(*data_.gravity, x, 1, residuals, &dr_dx)) {
      return false;
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
  VertexMotion motion_;
  int rows_ = 1;
};

// Edge inextensibility (EdgeInextensibilityResidual) between two points of
// one patch. Blocks: alpha, s, T, slide_i, slide_j.
class SkinnedEdgeCost : public ceres::CostFunction {
 public:
  // stretch_factor: the residual of an edge longer than at rest times this
  // (DrapePhysicsOptions::stretch_factor).
  SkinnedEdgeCost(const SkinnedPatchPoint& point_i, const SkinnedPatchPoint& point_j, double rest_length, double weight,
                  double stretch_factor = 1.0)
      : point_i_(point_i), point_j_(point_j), functor_(rest_length, weight), stretch_factor_(stretch_factor) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->assign({point_i.num_coefficients(), 1, 3, 2, 2});
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const PatchPointState state_i = point_i_.State(parameters[0], parameters[3]);
    const PatchPointState state_j = point_j_.State(parameters[0], parameters[4]);
    const Eigen::Vector3d xi = point_i_.Position(state_i, parameters[1], parameters[2]);
    const Eigen::Vector3d xj = point_j_.Position(state_j, parameters[1], parameters[2]);
    using J6 = ceres::Jet<double, 6>;
    const J6 a[3] = {J6(xi[0], 0), J6(xi[1], 1), J6(xi[2], 2)};
    const J6 b[3] = {J6(xj[0], 3), J6(xj[1], 4), J6(xj[2], 5)};
    J6 r;
    functor_(a, b, &r);
    if (r.a > 0.0) r *= stretch_factor_;
    residuals[0] = r.a;
    if (jacobians != nullptr) {
      point_i_.Chain<1>(r.v.head<3>().transpose(), state_i, parameters[1], jacobians, 3);
      point_j_.Chain<1>(r.v.tail<3>().transpose(), state_j, parameters[1], jacobians, 4, 1.0, true);
    }
    return true;
  }

 private:
  SkinnedPatchPoint point_i_, point_j_;
  EdgeInextensibilityResidual functor_;
  double stretch_factor_;
};

// Two patches' points of one garment vertex kept together once slid, in
// the canonical space they share (both are posed by the vertex's map):
//   r = w (X_a - X_b - g)                       energy w^2 / 2 |X_a - X_b - g|^2
// with g their gap at rest (the fits' disagreement there). Blocks: alpha_a,
// s_a, T_a, slide_a, alpha_b, s_b, T_b, slide_b.
class SkinnedAgreementCost : public ceres::CostFunction {
 public:
  SkinnedAgreementCost(const SkinnedPatchPoint& point_a, const SkinnedPatchPoint& point_b,
                       const Eigen::Vector3d& rest_gap, double weight)
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

// The metric-tensor term on a face of a patch
// (WarpedMetricInextensibilityResidual, eq. 4, with the slides' warp), its
// skinning Jacobian the mean of the corners' and its k_ext the mean of
// theirs, both read at each evaluation (they change per frame and pass).
// The metric is cost_functions' on a ceres::Jet over the slopes
// (z_u, z_v), s and the warp W; those are chained by hand: the slopes to
// alpha through the monomials' gradients and to the slides through the
// centroid (the jet's Hessian), W to the slides through the edges. Blocks:
// alpha, s, slide_a, slide_b, slide_c.
class SkinnedFaceMetricCost : public ceres::CostFunction {
 public:
  SkinnedFaceMetricCost(int order, const Eigen::Matrix<double, 2, 3>& uv, const Eigen::Vector3d& rest_metric,
                        const Eigen::Matrix3d& rotation, const Eigen::Matrix3d* const skinning[3],
                        const double* const k_ext[3], double weight, double stretch_factor = 1.0)
      : order_(order),
        stretch_factor_(stretch_factor),
        num_coefficients_(NumJetCoefficients(order)),
        uv_(uv),
        rest_(rest_metric),
        rotation_(rotation),
        weight_(weight),
        inverse_edges_(InverseTriangleEdges(uv, "SkinnedFaceMetricCost")) {
    for (int i = 0; i < 3; ++i) {
      skinning_[i] = skinning[i];
      k_ext_[i] = k_ext[i];
    }
    set_num_residuals(3);
    mutable_parameter_block_sizes()->assign({num_coefficients_, 1, 2, 2, 2});
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    double u[3], v[3];
    for (int i = 0; i < 3; ++i) {
      u[i] = uv_(0, i) + parameters[2 + i][0];
      v[i] = uv_(1, i) + parameters[2 + i][1];
    }
    const double cu = (u[0] + u[1] + u[2]) / 3.0, cv = (v[0] + v[1] + v[2]) / 3.0;
    const JetHeightDerivatives<double> d = EvaluateJetDerivatives(order_, parameters[0], cu, cv);
    double w[4];
    TriangleWarp(u, v, inverse_edges_, w);
    const Eigen::Matrix3d map = ((*skinning_[0] + *skinning_[1] + *skinning_[2]) / 3.0) * rotation_;
    const double k_ext = (*k_ext_[0] + *k_ext_[1] + *k_ext_[2]) / 3.0;
    // Inputs: z_u, z_v, s, w11, w12, w21, w22.
    using J7 = ceres::Jet<double, 7>;
    const J7 w7[4] = {J7(w[0], 3), J7(w[1], 4), J7(w[2], 5), J7(w[3], 6)};
    J7 h[3], g[3], r[3];
    MetricFromSlopes(J7(d.z_u, 0), J7(d.z_v, 1), J7(parameters[1][0], 2), map, h);
    PullBackMetric(h, w7, g);
    MetricResidual(g, rest_, k_ext, weight_, r);
    // Stretch along u or v (a diagonal entry above the rest's).
    if (r[0].a > 0.0) r[0] *= stretch_factor_;
    if (r[2].a > 0.0) r[2] *= stretch_factor_;
    for (int i = 0; i < 3; ++i) residuals[i] = r[i].a;
    if (jacobians == nullptr) return true;
    if (jacobians[0] != nullptr) {
      double m[kMaxJetCoefficients], m_u[kMaxJetCoefficients], m_v[kMaxJetCoefficients];
      JetMonomialGradients(order_, cu, cv, m, m_u, m_v);
      for (int i = 0; i < 3; ++i) {
        for (int k = 0; k < num_coefficients_; ++k) {
          jacobians[0][i * num_coefficients_ + k] = r[i].v[0] * m_u[k] + r[i].v[1] * m_v[k];
        }
      }
    }
    if (jacobians[1] != nullptr) {
      for (int i = 0; i < 3; ++i) jacobians[1][i] = r[i].v[2];
    }
    // d(w11, w12)/du and d(w21, w22)/dv of each corner: rows of Einv.
    const Eigen::Vector2d corner[3] = {-(inverse_edges_.row(0) + inverse_edges_.row(1)).transpose(),
                                       inverse_edges_.row(0).transpose(), inverse_edges_.row(1).transpose()};
    for (int c = 0; c < 3; ++c) {
      double* j = jacobians[2 + c];
      if (j == nullptr) continue;
      for (int i = 0; i < 3; ++i) {
        const double dp = r[i].v[0], dq = r[i].v[1];
        // Through the centroid (1/3 per corner), then through the warp.
        j[2 * i] = (dp * d.z_uu + dq * d.z_uv) / 3.0 + r[i].v[3] * corner[c][0] + r[i].v[4] * corner[c][1];
        j[2 * i + 1] = (dp * d.z_uv + dq * d.z_vv) / 3.0 + r[i].v[5] * corner[c][0] + r[i].v[6] * corner[c][1];
      }
    }
    return true;
  }

 private:
  int order_;
  double stretch_factor_;
  int num_coefficients_;
  Eigen::Matrix<double, 2, 3> uv_;
  Eigen::Vector3d rest_;
  Eigen::Matrix3d rotation_;
  double weight_;
  Eigen::Matrix2d inverse_edges_;
  const Eigen::Matrix3d* skinning_[3];
  const double* k_ext_[3];
};

// A prior w (x - mean) on a parameter block, the mean read through a
// pointer (the previous frame's parameters).
class ParameterPrior : public ceres::CostFunction {
 public:
  ParameterPrior(int size, double weight, const double* mean) : weight_(weight), mean_(mean) {
    set_num_residuals(size);
    mutable_parameter_block_sizes()->assign({size});
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int n = num_residuals();
    for (int i = 0; i < n; ++i) residuals[i] = weight_ * (parameters[0][i] - mean_[i]);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::MatrixXd>(jacobians[0], n, n) = weight_ * Eigen::MatrixXd::Identity(n, n);
    }
    return true;
  }

 private:
  double weight_;
  const double* mean_;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_LOSSES_SKINNED_PATCH_COSTS_H_
