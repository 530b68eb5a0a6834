// The per-frame Ceres costs of PolySfT, on one parameter block per frame
// (the JetDeformationModel parameters theta). Each evaluates the model once
// and chains its Jacobian by hand, so that a frame's thousands of residuals
// cost one model evaluation.
#ifndef POLYFIT_SFT_SOLVER_FRAME_COSTS_H_
#define POLYFIT_SFT_SOLVER_FRAME_COSTS_H_

#include <vector>

#include <ceres/cost_function.h>
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "cost_functions/compressed_cost.h"
#include "sft/model/jet_deformation.h"
#include "sft/render/soft_rasterizer.h"
#include "sft/scene/scene.h"
#include "sft/solver/robust_loss.h"

namespace polyfit {

// Photometric and silhouette residuals over the pixels of `roi`:
//   r_rgb(p) = w_photo (I(p; theta) - I_obs(p))                (robustified per pixel)
//   r_s(p)   = w_sil (S(p; theta) - clamp(S(p; theta), M_lo(p), M_hi(p)))
// (with a mask only). I and S from the soft rasterizer with the observed
// frame as background. The mask's bounds are equal (r_s = w_sil (S - M)),
// or a tolerance band around its border (silhouette_band.h) where any coverage
// costs nothing.
class RenderCost : public ceres::CostFunction {
 public:
  struct Data {
    const JetDeformationModel* model = nullptr;
    const SoftRasterizer* rasterizer = nullptr;
    // Faces, corner texture coordinates, boundary flags, depth range.
    ScreenMesh mesh;
    PinholeCamera camera;
    cv::Mat image;       // CV_32FC3
    cv::Mat mask;        // CV_32F or empty: M_lo
    cv::Mat mask_upper;  // CV_32F, M_hi; empty: M_lo
    cv::Rect roi;
    double photometric_weight = 1.0;
    double silhouette_weight = 1.0;
    RobustLoss robust_loss = RobustLoss::kNone;
    double robust_scale = 0.1;
  };
  explicit RenderCost(Data data);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;
  // |r|^2, and J^T J and J^T r (when not null), without forming J: rows of
  // pixels no triangle touches are zero and skipped.
  bool EvaluateNormalEquations(const double* theta, double* squared_norm, Eigen::MatrixXd* jtj,
                               Eigen::VectorXd* jtr) const;

 private:
  struct Accumulator {
    double squared_norm = 0.0;
    Eigen::MatrixXd jtj;
    Eigen::VectorXd jtr;
    Eigen::MatrixXd rows;
    Eigen::VectorXd values;
    int count = 0;
  };
  // Rows of the Jacobian of one pixel's 4 residuals (RGB, silhouette).
  using PixelRows = Eigen::Matrix<double, 4, Eigen::Dynamic, Eigen::RowMajor>;
  static constexpr int kBlockRows = 64;

  bool Compute(const double* theta, double* residuals, double* jacobian, double* squared_norm, Eigen::MatrixXd* jtj,
               Eigen::VectorXd* jtr) const;
  void ChainPixelJacobian(int pixel, int P, PixelRows* local) const;
  void ResetAccumulators(int threads, int P, bool want_jacobian) const;
  static void Flush(Accumulator* a);
  void ReduceAccumulators(int P, bool want_jacobian, double* squared_norm, Eigen::MatrixXd* jtj,
                          Eigen::VectorXd* jtr) const;

  Data data_;
  int channels_;
  mutable ScreenMesh screen_;
  mutable SoftRenderOutput render_;
  mutable Eigen::Matrix3Xd vertices_;
  mutable Eigen::MatrixXd model_jacobian_, screen_jacobian_;
  // Row-major: a vertex's three rows are contiguous.
  mutable Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> screen_theta_;
  mutable std::vector<Accumulator> accumulators_;
  mutable std::vector<PixelRows> scratch_;  // per thread
};

// RenderCost compressed (cost_functions/compressed_cost.h) from its normal
// equations: what the solver uses.
class CompressedRenderCost : public NormalEquationsCost {
 public:
  explicit CompressedRenderCost(RenderCost::Data data);
  bool EvaluateNormalEquations(double const* const* parameters, double* squared_norm, Eigen::MatrixXd* jtj,
                               Eigen::VectorXd* jtr) const override;

 private:
  RenderCost cost_;
};

// Edge inextensibility over all template edges (EdgeInextensibilityResidual).
class InextensibilityCost : public ceres::CostFunction {
 public:
  InextensibilityCost(const JetDeformationModel* model, const std::vector<Eigen::Vector2i>& edges,
                      const std::vector<double>& rest_lengths, double weight);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const JetDeformationModel* model_;
  std::vector<Eigen::Vector2i> edges_;
  std::vector<double> rest_lengths_;
  double weight_;
  mutable Eigen::Matrix3Xd vertices_;
  mutable Eigen::MatrixXd jacobian_;
};

// Temporal consistency of every vertex between two frames
// (TemporalConsistencyResidual). With `previous` given, the earlier frame
// is fixed data and the cost has one parameter block; otherwise two (this
// frame, the earlier one).
class TemporalCost : public ceres::CostFunction {
 public:
  TemporalCost(const JetDeformationModel* model, double length_scale, double weight,
               const Eigen::Matrix3Xd* previous = nullptr);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const JetDeformationModel* model_;
  double scale_;
  bool fixed_previous_;
  Eigen::Matrix3Xd previous_;
  mutable Eigen::Matrix3Xd now_, before_;
  mutable Eigen::MatrixXd jacobian_now_, jacobian_before_;
};

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_FRAME_COSTS_H_
