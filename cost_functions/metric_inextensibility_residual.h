// Metric-tensor inextensibility (the paper's eq. 4, weight k_mi): a
// deformed patch keeps its rest first fundamental form, scaled by k_ext, at
// a sample (u, v).
//
//   X(u, v) = A (s R (u, v, z(u, v; alpha)) + T)      LBS linear part A, frame R
//   J = dX/d(u, v) = s A R [(1, 0, z_u), (0, 1, z_v)]   (3 by 2)
//   g = J^T J,  r = w (g11 - k g0_11, sqrt(2) (g12 - k g0_12), g22 - k g0_22)
//
// so |r|^2 = w^2 |g - k g0|_F^2, with k = k_ext >= 1 (1 + min(d_c, 0.01)
// min(epoch, 100) in the paper: a penetrating point may stretch). A (from
// the body's skinning Jacobian), R, (u, v), g0 and k are data. Parameter
// blocks: alpha (NumJetCoefficients(order)), scale s (1). T does not change
// g.
//
// WarpedMetricInextensibilityResidual is the same term on a triangle of
// the patch whose corners slide in (u, v) (a warp of the patch's plane, as
// the reference drape's slides are): the warp is affine over the triangle,
// W = [u'_b - u'_a, u'_c - u'_a] [u_b - u_a, u_c - u_a]^-1 (2 by 2), the
// surface is evaluated at the slid centroid and its metric pulled back to
// the rest (u, v): g = W^T J^T J W. Parameter blocks: alpha, s, then the
// three corners' slides (du, dv) (2 each).
#ifndef COST_FUNCTIONS_METRIC_INEXTENSIBILITY_RESIDUAL_H_
#define COST_FUNCTIONS_METRIC_INEXTENSIBILITY_RESIDUAL_H_

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include <ceres/autodiff_cost_function.h>
#include <Eigen/Core>
#include <Eigen/LU>

#include "cost_functions/jet_order_dispatch.h"
#include "polyfit/jet/jet_surface.h"

namespace polyfit {

// g = J^T J as (g11, g12, g22) from the jet's slopes (z_u, z_v); map = A R.
template <typename T>
void MetricFromSlopes(const T& z_u, const T& z_v, const T& scale, const Eigen::Matrix3d& map, T* metric) {
  // Columns of J / s: M (1, 0, z_u) and M (0, 1, z_v), M = A R.
  T ju[3], jv[3];
  for (int k = 0; k < 3; ++k) {
    ju[k] = T(map(k, 0)) + T(map(k, 2)) * z_u;
    jv[k] = T(map(k, 1)) + T(map(k, 2)) * z_v;
  }
  const T s2 = scale * scale;
  metric[0] = s2 * (ju[0] * ju[0] + ju[1] * ju[1] + ju[2] * ju[2]);
  metric[1] = s2 * (ju[0] * jv[0] + ju[1] * jv[1] + ju[2] * jv[2]);
  metric[2] = s2 * (jv[0] * jv[0] + jv[1] * jv[1] + jv[2] * jv[2]);
}

// The same at (u, v) of the jet alpha.
template <typename T>
void PatchMetric(int order, const T* alpha, const T& scale, const T& u, const T& v, const Eigen::Matrix3d& map,
                 T* metric) {
  const JetHeightDerivatives<T> d = EvaluateJetDerivatives(order, alpha, u, v);
  MetricFromSlopes(d.z_u, d.z_v, scale, map, metric);
}

// g = W^T H W for a symmetric H = (h11, h12, h22) and W row-major
// (w11, w12, w21, w22): a metric pulled back through a warp.
template <typename T>
void PullBackMetric(const T* h, const T* w, T* g) {
  const T hw00 = h[0] * w[0] + h[1] * w[2], hw01 = h[0] * w[1] + h[1] * w[3];
  const T hw10 = h[1] * w[0] + h[2] * w[2], hw11 = h[1] * w[1] + h[2] * w[3];
  g[0] = w[0] * hw00 + w[2] * hw10;
  g[1] = w[0] * hw01 + w[2] * hw11;
  g[2] = w[1] * hw01 + w[3] * hw11;
}

// W = E Einv, E the slid (u, v) edges [u_b - u_a, u_c - u_a] (row-major
// like W), Einv the inverse of the rest edges.
template <typename T>
void TriangleWarp(const T* u, const T* v, const Eigen::Matrix2d& inverse_edges, T* w) {
  const T e00 = u[1] - u[0], e01 = u[2] - u[0], e10 = v[1] - v[0], e11 = v[2] - v[0];
  w[0] = e00 * inverse_edges(0, 0) + e01 * inverse_edges(1, 0);
  w[1] = e00 * inverse_edges(0, 1) + e01 * inverse_edges(1, 1);
  w[2] = e10 * inverse_edges(0, 0) + e11 * inverse_edges(1, 0);
  w[3] = e10 * inverse_edges(0, 1) + e11 * inverse_edges(1, 1);
}

// The inverse of a triangle's (u, v) edges (columns a, b, c of uv);
// throws std::invalid_argument for a degenerate triangle.
inline Eigen::Matrix2d InverseTriangleEdges(const Eigen::Matrix<double, 2, 3>& uv, const char* who) {
  Eigen::Matrix2d edges;
  edges << uv(0, 1) - uv(0, 0), uv(0, 2) - uv(0, 0), uv(1, 1) - uv(1, 0), uv(1, 2) - uv(1, 0);
  const double extent = std::max(edges.col(0).squaredNorm(), edges.col(1).squaredNorm());
  if (!(std::abs(edges.determinant()) > 1e-12 * extent)) {
    throw std::invalid_argument(std::string(who) + ": a degenerate (u, v) triangle");
  }
  return edges.inverse();
}

// r = w (g - k g0) with the off-diagonal weighted by sqrt(2).
template <typename T>
void MetricResidual(const T* metric, const Eigen::Vector3d& rest, double k_ext, double weight, T* residual) {
  residual[0] = T(weight) * (metric[0] - T(k_ext * rest[0]));
  residual[1] = T(weight * std::sqrt(2.0)) * (metric[1] - T(k_ext * rest[1]));
  residual[2] = T(weight) * (metric[2] - T(k_ext * rest[2]));
}

class MetricInextensibilityResidual {
 public:
  // rest_metric: (g11, g12, g22).
  MetricInextensibilityResidual(int order, double u, double v, const Eigen::Vector3d& rest_metric,
                                const Eigen::Matrix3d& rotation, const Eigen::Matrix3d& skinning, double weight,
                                double k_ext = 1.0)
      : order_(order), u_(u), v_(v), rest_(rest_metric), map_(skinning * rotation), weight_(weight), k_ext_(k_ext) {}

  template <typename T>
  bool operator()(const T* alpha, const T* scale, T* residual) const {
    T g[3];
    PatchMetric(order_, alpha, scale[0], T(u_), T(v_), map_, g);
    MetricResidual(g, rest_, k_ext_, weight_, residual);
    return true;
  }

  static ceres::CostFunction* Create(int order, double u, double v, const Eigen::Vector3d& rest_metric,
                                     const Eigen::Matrix3d& rotation,
                                     const Eigen::Matrix3d& skinning = Eigen::Matrix3d::Identity(), double weight = 1.0,
                                     double k_ext = 1.0) {
    auto functor =
        std::make_unique<MetricInextensibilityResidual>(order, u, v, rest_metric, rotation, skinning, weight, k_ext);
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
  double k_ext_;
};

class WarpedMetricInextensibilityResidual {
 public:
  // uv: the corners' rest (u, v) as columns (a, b, c), a non-degenerate
  // triangle; rest_metric: g0 at their centroid.
  WarpedMetricInextensibilityResidual(int order, const Eigen::Matrix<double, 2, 3>& uv,
                                      const Eigen::Vector3d& rest_metric, const Eigen::Matrix3d& rotation,
                                      const Eigen::Matrix3d& skinning, double weight, double k_ext = 1.0)
      : order_(order),
        uv_(uv),
        rest_(rest_metric),
        map_(skinning * rotation),
        weight_(weight),
        k_ext_(k_ext),
        inverse_edges_(InverseTriangleEdges(uv, "WarpedMetricInextensibilityResidual")) {}

  template <typename T>
  bool operator()(const T* alpha, const T* scale, const T* slide_a, const T* slide_b, const T* slide_c,
                  T* residual) const {
    const T* slides[3] = {slide_a, slide_b, slide_c};
    T u[3], v[3];
    for (int i = 0; i < 3; ++i) {
      u[i] = T(uv_(0, i)) + slides[i][0];
      v[i] = T(uv_(1, i)) + slides[i][1];
    }
    T w[4], h[3], g[3];
    TriangleWarp(u, v, inverse_edges_, w);
    PatchMetric(order_, alpha, scale[0], (u[0] + u[1] + u[2]) / 3.0, (v[0] + v[1] + v[2]) / 3.0, map_, h);
    PullBackMetric(h, w, g);
    MetricResidual(g, rest_, k_ext_, weight_, residual);
    return true;
  }

  static ceres::CostFunction* Create(int order, const Eigen::Matrix<double, 2, 3>& uv,
                                     const Eigen::Vector3d& rest_metric, const Eigen::Matrix3d& rotation,
                                     const Eigen::Matrix3d& skinning = Eigen::Matrix3d::Identity(), double weight = 1.0,
                                     double k_ext = 1.0) {
    auto functor = std::make_unique<WarpedMetricInextensibilityResidual>(order, uv, rest_metric, rotation, skinning,
                                                                         weight, k_ext);
    return DispatchJetCoefficients(order, "WarpedMetricInextensibilityResidual", [&](auto k) -> ceres::CostFunction* {
      using Cost = ceres::AutoDiffCostFunction<WarpedMetricInextensibilityResidual, 3, decltype(k)::value, 1, 2, 2, 2>;
      return new Cost(functor.release());
    });
  }

 private:
  int order_;
  Eigen::Matrix<double, 2, 3> uv_;
  Eigen::Vector3d rest_;
  Eigen::Matrix3d map_;
  double weight_;
  double k_ext_;
  Eigen::Matrix2d inverse_edges_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_METRIC_INEXTENSIBILITY_RESIDUAL_H_
