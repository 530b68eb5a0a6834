// The order-dependent part of a jet fit (internal to JetFitter): the
// closed-form solve in the patch's frame and the orientation refinement,
// for one jet order at compile time. The orders are instantiated two by two
// in four translation units (jet_fit_orders_*.cc, about 40 s and 1.5 GB
// each): all eight in one took 4 GB and five minutes to compile, 9 GB and
// eight under the sanitizers.
#ifndef POLYFIT_PATCH_JET_FIT_KERNEL_H_
#define POLYFIT_PATCH_JET_FIT_KERNEL_H_

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "polyfit/jet/jet_surface.h"
#include "polyfit/patch/jet_fit.h"
#include "polyfit/patch/local_jet_solver.h"
#include "polyfit/patch/orientation_refinement.h"

namespace polyfit {
namespace internal {

// A fitter's buffers, reused from patch to patch.
struct JetFitWorkspace {
  // Local points: x0 in the PCA frame, x in the current (tilted) frame.
  Eigen::Matrix3Xd x0, x;
  std::vector<double> sqrt_w;
  Eigen::Matrix<double, Eigen::Dynamic, 2> jacobian;

  void Reserve(int m) {
    if (x0.cols() < m) {
      x0.resize(3, m);
      x.resize(3, m);
      sqrt_w.resize(m);
      jacobian.resize(m, 2);
    }
  }
};

class JetOrderKernel {
 public:
  virtual ~JetOrderKernel() = default;
  // Fits the m points of ws->x (== ws->x0, scaled to |u|, |v| <= 1) at
  // `order`; sqrt_w: their square-root weights or null. Sets patch's
  // coefficients, flags, refinement_iterations and rms_residual (local
  // units: the caller scales it), and *tilt (the refinement's rotation of
  // the frame; identity without refinement).
  virtual void Fit(const JetFitOptions& options, int order, int m, const double* sqrt_w, double weight_sum,
                   JetFitWorkspace* ws, JetPatch* patch, Eigen::Matrix3d* tilt) = 0;
};

// The kernel for an order in [1, kMaxJetOrder]; each group of orders comes
// from its own translation unit.
std::unique_ptr<JetOrderKernel> MakeJetOrderKernel(int order);
std::unique_ptr<JetOrderKernel> MakeJetOrderKernel1To2(int order);
std::unique_ptr<JetOrderKernel> MakeJetOrderKernel3To4(int order);
std::unique_ptr<JetOrderKernel> MakeJetOrderKernel5To6(int order);
std::unique_ptr<JetOrderKernel> MakeJetOrderKernel7To8(int order);

// Defines MakeJetOrderKernel<A>To<B>, the kernels of orders A and B (one
// translation unit's pair).
#define POLYFIT_DEFINE_JET_ORDER_KERNELS(A, B)                                              \
  std::unique_ptr<JetOrderKernel> MakeJetOrderKernel##A##To##B(int order) {                 \
    if (order == (A)) return std::make_unique<JetOrderKernelImpl<NumJetCoefficients(A)>>(); \
    if (order == (B)) return std::make_unique<JetOrderKernelImpl<NumJetCoefficients(B)>>(); \
    return nullptr;                                                                         \
  }

constexpr double kMaxTiltStep = 0.3;  // radians

// Rotation by the tilt (t0, t1, 0) (axis-angle).
inline Eigen::Matrix3d TiltRotation(double t0, double t1) {
  const double angle = std::hypot(t0, t1);
  if (angle < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, Eigen::Vector3d(t0 / angle, t1 / angle, 0.0)).toRotationMatrix();
}

template <int K>
class JetOrderKernelImpl final : public JetOrderKernel {
 public:
  void Fit(const JetFitOptions& options, int order, int m, const double* sw, double weight_sum, JetFitWorkspace* ws,
           JetPatch* patch, Eigen::Matrix3d* tilt) override {
    *tilt = Eigen::Matrix3d::Identity();
    patch->flags |= solver_.Solve(order, ws->x, m, sw);
    if (options.refine_orientation && solver_.well_conditioned()) {
      if (options.refinement.solver == OrientationSolver::kCeres) {
        patch->refinement_iterations = RefineOrientationWithCeres(options.refinement, order, ws->x0, m, sw, tilt);
        ws->x.leftCols(m).noalias() = tilt->transpose() * ws->x0.leftCols(m);
        patch->flags |= solver_.Solve(order, ws->x, m, sw);
      } else {
        patch->refinement_iterations = RefineVarProLM(options.refinement, m, sw, ws, tilt);
      }
    }
    const int k = NumJetCoefficients(order);
    for (int i = 0; i < k; ++i) patch->coefficients[i] = solver_.alpha()[i];
    patch->rms_residual = std::sqrt(solver_.ssr() / (sw ? weight_sum : double(m)));
  }

 private:
  // Levenberg-Marquardt over the tilt with the Kaufman var-pro Jacobian.
  // On entry the solver holds the fit at x == x0; on exit the fit at
  // x = tilt^T x0.
  int RefineVarProLM(const OrientationRefinementOptions& options, int m, const double* sw, JetFitWorkspace* ws,
                     Eigen::Matrix3d* tilt) {
    const int order = solver_.order();
    Eigen::Matrix3d rc = Eigen::Matrix3d::Identity();
    double cost = solver_.ssr();
    double lambda = 1e-4;
    int iterations = 0;
    for (; iterations < options.max_iterations; ++iterations) {
      if (!solver_.well_conditioned() || cost <= 0.0) break;
      // dr/dt at fixed alpha, r = z - h(u, v), (u, v, z) = exp(-t^) x.
      auto j = ws->jacobian.topRows(m);
      const auto& alpha = solver_.alpha();
      for (int i = 0; i < m; ++i) {
        const double u = ws->x(0, i), v = ws->x(1, i), z = ws->x(2, i);
        const auto d = EvaluateJetDerivatives(order, alpha.data(), u, v);
        const double w = sw ? sw[i] : 1.0;
        j(i, 0) = w * (-v - d.z_v * z);
        j(i, 1) = w * (u + d.z_u * z);
      }
      solver_.ProjectOut(j);
      const Eigen::Matrix2d jtj = j.transpose() * j;
      const Eigen::Vector2d jtr = j.transpose() * solver_.residual();
      bool accepted = false;
      for (int attempt = 0; attempt < 12 && !accepted; ++attempt) {
        Eigen::Matrix2d h = jtj;
        h.diagonal() *= 1.0 + lambda;
        Eigen::Vector2d step = -h.ldlt().solve(jtr);
        if (!step.allFinite()) break;
        // A tilt step beyond ~17 degrees leaves the linearisation's reach.
        const double step_norm = step.norm();
        if (step_norm > kMaxTiltStep) step *= kMaxTiltStep / step_norm;
        const Eigen::Matrix3d rc_new = rc * TiltRotation(step[0], step[1]);
        ws->x.leftCols(m).noalias() = rc_new.transpose() * ws->x0.leftCols(m);
        solver_.Solve(order, ws->x, m, sw);
        if (solver_.ssr() < cost) {
          accepted = true;
          const double decrease = (cost - solver_.ssr()) / cost;
          rc = rc_new;
          cost = solver_.ssr();
          lambda = std::max(lambda * 0.1, 1e-8);
          if (decrease < options.function_tolerance) {
            *tilt = rc;
            return iterations + 1;
          }
        } else {
          lambda *= 10.0;
        }
      }
      if (!accepted) {
        // Restore the fit at the best rotation.
        ws->x.leftCols(m).noalias() = rc.transpose() * ws->x0.leftCols(m);
        solver_.Solve(order, ws->x, m, sw);
        break;
      }
    }
    *tilt = rc;
    return iterations;
  }

  LocalJetSolver<K> solver_;
};

}  // namespace internal
}  // namespace polyfit

#endif  // POLYFIT_PATCH_JET_FIT_KERNEL_H_
