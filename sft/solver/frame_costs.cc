#include "sft/solver/frame_costs.h"

#include <algorithm>
#include <cmath>

#include <ceres/jet.h>

#include "cost_functions/edge_inextensibility.h"
#include "cost_functions/temporal_consistency.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {

RenderCost::RenderCost(Data data) : data_(std::move(data)) {
  channels_ = data_.mask.empty() ? 3 : 4;
  set_num_residuals(data_.roi.area() * channels_);
  mutable_parameter_block_sizes()->push_back(data_.model->num_parameters());
  screen_ = data_.mesh;
}

bool RenderCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const bool want = jacobians != nullptr && jacobians[0] != nullptr;
  return Compute(parameters[0], residuals, want ? jacobians[0] : nullptr, nullptr, nullptr, nullptr);
}

bool RenderCost::EvaluateNormalEquations(const double* theta, double* squared_norm, Eigen::MatrixXd* jtj,
                                         Eigen::VectorXd* jtr) const {
  return Compute(theta, nullptr, nullptr, squared_norm, jtj, jtr);
}

namespace {

// Robust loss per pixel (iteratively reweighted least squares): the RGB
// residual r scaled by sqrt(rho(s) / s), its Jacobian by sqrt(rho'(s)),
// s = |r|^2, b the loss's scale.
void ApplyRobustLoss(RobustLoss loss, double b, double* r, double* jacobian_scale) {
  if (loss == RobustLoss::kNone) return;
  const double s = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  const double b2 = b * b;
  double rho = s, rho1 = 1.0;
  if (loss == RobustLoss::kHuber && s > b2) {
    rho = 2.0 * std::sqrt(s * b2) - b2;
    rho1 = std::sqrt(b2 / s);
  } else if (loss == RobustLoss::kCauchy) {
    rho = b2 * std::log1p(s / b2);
    rho1 = 1.0 / (1.0 + s / b2);
  }
  const double residual_scale = s > 0.0 ? std::sqrt(rho / s) : 1.0;
  for (int ch = 0; ch < 3; ++ch) r[ch] *= residual_scale;
  *jacobian_scale *= std::sqrt(rho1);
}

}  // namespace

void RenderCost::ChainPixelJacobian(int pixel, int P, PixelRows* local) const {
  // local (4 by P) = sum over the pixel's vertices of d (4 by 3) times their
  // 3 by P rows; written out, as Eigen's dynamic-size product costs more
  // than the arithmetic at this size.
  local->setZero();
  for (int k = render_.begin[pixel]; k < render_.end[pixel]; ++k) {
    const VertexGradient& g = render_.gradients[k];
    const double* s0 = screen_theta_.data() + static_cast<size_t>(3 * g.vertex) * P;
    const double* s1 = s0 + P;
    const double* s2 = s1 + P;
    for (int a = 0; a < 4; ++a) {
      const double d0 = g.d[a][0], d1 = g.d[a][1], d2 = g.d[a][2];
      double* out = local->data() + static_cast<size_t>(a) * P;
      for (int c = 0; c < P; ++c) out[c] += d0 * s0[c] + d1 * s1[c] + d2 * s2[c];
    }
  }
}

void RenderCost::ResetAccumulators(int threads, int P, bool want_jacobian) const {
  accumulators_.resize(threads);
  for (Accumulator& a : accumulators_) {
    a.squared_norm = 0.0;
    if (want_jacobian) {
      a.jtj.setZero(P, P);
      a.jtr.setZero(P);
      a.rows.resize(kBlockRows, P);
      a.values.resize(kBlockRows);
      a.count = 0;
    }
  }
}

void RenderCost::Flush(Accumulator* a) {
  if (a->count == 0) return;
  a->jtj.selfadjointView<Eigen::Lower>().rankUpdate(a->rows.topRows(a->count).transpose());
  a->jtr.noalias() += a->rows.topRows(a->count).transpose() * a->values.head(a->count);
  a->count = 0;
}

void RenderCost::ReduceAccumulators(int P, bool want_jacobian, double* squared_norm, Eigen::MatrixXd* jtj,
                                    Eigen::VectorXd* jtr) const {
  *squared_norm = 0.0;
  for (Accumulator& a : accumulators_) *squared_norm += a.squared_norm;
  if (!want_jacobian) return;
  jtj->setZero(P, P);
  jtr->setZero(P);
  for (Accumulator& a : accumulators_) {
    Flush(&a);
    *jtj += a.jtj;
    *jtr += a.jtr;
  }
  *jtj = jtj->selfadjointView<Eigen::Lower>();
}

bool RenderCost::Compute(const double* theta, double* residuals, double* jacobian, double* squared_norm,
                         Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr) const {
  const JetDeformationModel& model = *data_.model;
  const bool normal = squared_norm != nullptr;
  const bool want_jacobian = jacobian != nullptr || jtj != nullptr;
  model.Evaluate(theta, &vertices_, want_jacobian ? &model_jacobian_ : nullptr);
  if (!ProjectVertices(data_.camera, vertices_, &screen_, want_jacobian ? &screen_jacobian_ : nullptr)) return false;
  data_.rasterizer->Render(screen_, data_.camera.width, data_.camera.height, data_.image, want_jacobian, &render_,
                           data_.roi);
  const int P = model.num_parameters();
  const int n = model.num_vertices();
  // d(x, y, depth)/d theta per vertex: 3 #V by P.
  if (want_jacobian) {
    screen_theta_.resize(3 * n, P);
    for (int i = 0; i < n; ++i) {
      screen_theta_.middleRows(3 * i, 3).noalias() =
          screen_jacobian_.middleRows(3 * i, 3) * model_jacobian_.middleRows(3 * i, 3);
    }
  }
  const cv::Rect& roi = data_.roi;
  const int width = data_.camera.width;
  // Normal equations: per thread, Jacobian rows of covered pixels are
  // gathered in blocks and added with one symmetric rank-k update each.
  const int threads = std::max(1, std::min(ResolveNumThreads(data_.rasterizer->options().num_threads), roi.height));
  if (normal) ResetAccumulators(threads, P, want_jacobian);
  if (static_cast<int>(scratch_.size()) < threads || (!scratch_.empty() && scratch_[0].cols() != P)) {
    scratch_.assign(threads, PixelRows(4, P));
  }
  ParallelFor(
      roi.height, threads,
      [&](int thread, int row) {
        const int y = roi.y + row;
        PixelRows& local = scratch_[thread];
        double r[4];
        for (int col = 0; col < roi.width; ++col) {
          const int x = roi.x + col;
          const int r0 = (row * roi.width + col) * channels_;
          const cv::Vec3f rendered = render_.color.at<cv::Vec3f>(y, x), observed = data_.image.at<cv::Vec3f>(y, x);
          for (int ch = 0; ch < 3; ++ch) r[ch] = data_.photometric_weight * (rendered[ch] - observed[ch]);
          double jacobian_scale = data_.photometric_weight;
          bool in_band = false;
          ApplyRobustLoss(data_.robust_loss, data_.robust_scale, r, &jacobian_scale);
          if (channels_ == 4) {
            const double s = render_.silhouette.at<float>(y, x), lo = data_.mask.at<float>(y, x);
            const double hi = data_.mask_upper.empty() ? lo : data_.mask_upper.at<float>(y, x);
            in_band = s > lo && s < hi;  // (lo < hi only in a band)
            r[3] = data_.silhouette_weight * (s - std::clamp(s, lo, hi));
          }
          if (residuals != nullptr) {
            for (int ch = 0; ch < channels_; ++ch) residuals[r0 + ch] = r[ch];
          }
          if (normal) {
            for (int ch = 0; ch < channels_; ++ch) accumulators_[thread].squared_norm += r[ch] * r[ch];
          }
          if (!want_jacobian) continue;
          const int pixel = y * width + x;
          if (render_.end[pixel] == render_.begin[pixel] && jacobian == nullptr) continue;  // a zero row
          ChainPixelJacobian(pixel, P, &local);
          local.topRows(3) *= jacobian_scale;
          local.row(3) *= in_band ? 0.0 : data_.silhouette_weight;
          if (jacobian != nullptr) {
            double* jrow = jacobian + static_cast<size_t>(r0) * P;
            for (int ch = 0; ch < channels_; ++ch) {
              for (int c = 0; c < P; ++c) jrow[ch * P + c] = local(ch, c);
            }
          }
          if (normal) {
            Accumulator& a = accumulators_[thread];
            if (a.count + channels_ > kBlockRows) Flush(&a);
            a.rows.middleRows(a.count, channels_) = local.topRows(channels_);
            for (int ch = 0; ch < channels_; ++ch) a.values[a.count + ch] = r[ch];
            a.count += channels_;
          }
        }
      },
      1);
  if (normal) ReduceAccumulators(P, want_jacobian, squared_norm, jtj, jtr);
  return true;
}

CompressedRenderCost::CompressedRenderCost(RenderCost::Data data)
    : NormalEquationsCost({data.model->num_parameters()}), cost_(std::move(data)) {}

bool CompressedRenderCost::EvaluateNormalEquations(double const* const* parameters, double* squared_norm,
                                                   Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr) const {
  return cost_.EvaluateNormalEquations(parameters[0], squared_norm, jtj, jtr);
}

InextensibilityCost::InextensibilityCost(const JetDeformationModel* model, const std::vector<Eigen::Vector2i>& edges,
                                         const std::vector<double>& rest_lengths, double weight)
    : model_(model), edges_(edges), rest_lengths_(rest_lengths), weight_(weight) {
  set_num_residuals(static_cast<int>(edges.size()));
  mutable_parameter_block_sizes()->push_back(model->num_parameters());
}

bool InextensibilityCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
  model_->Evaluate(parameters[0], &vertices_, want_jacobian ? &jacobian_ : nullptr);
  const int P = model_->num_parameters();
  using J6 = ceres::Jet<double, 6>;
  for (size_t e = 0; e < edges_.size(); ++e) {
    const int i = edges_[e][0], j = edges_[e][1];
    const EdgeInextensibilityResidual functor(rest_lengths_[e], weight_);
    if (!want_jacobian) {
      functor(vertices_.col(i).data(), vertices_.col(j).data(), &residuals[e]);
      continue;
    }
    J6 xi[3], xj[3], r;
    for (int k = 0; k < 3; ++k) {
      xi[k] = J6(vertices_(k, i), k);
      xj[k] = J6(vertices_(k, j), 3 + k);
    }
    functor(xi, xj, &r);
    residuals[e] = r.a;
    Eigen::Map<Eigen::RowVectorXd> row(jacobians[0] + e * P, P);
    row.noalias() = r.v.head<3>().transpose() * jacobian_.middleRows(3 * i, 3) +
                    r.v.tail<3>().transpose() * jacobian_.middleRows(3 * j, 3);
  }
  return true;
}

TemporalCost::TemporalCost(const JetDeformationModel* model, double length_scale, double weight,
                           const Eigen::Matrix3Xd* previous)
    : model_(model), scale_(weight / length_scale), fixed_previous_(previous != nullptr) {
  if (previous != nullptr) previous_ = *previous;
  set_num_residuals(3 * model->num_vertices());
  mutable_parameter_block_sizes()->push_back(model->num_parameters());
  if (!fixed_previous_) mutable_parameter_block_sizes()->push_back(model->num_parameters());
}

bool TemporalCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const bool j_now = jacobians != nullptr && jacobians[0] != nullptr;
  const bool j_before = !fixed_previous_ && jacobians != nullptr && jacobians[1] != nullptr;
  model_->Evaluate(parameters[0], &now_, j_now ? &jacobian_now_ : nullptr);
  const Eigen::Matrix3Xd* before = &previous_;
  if (!fixed_previous_) {
    model_->Evaluate(parameters[1], &before_, j_before ? &jacobian_before_ : nullptr);
    before = &before_;
  }
  const int n = model_->num_vertices(), P = model_->num_parameters();
  // r = scale (x_t - x_{t-1}): TemporalConsistencyResidual with length
  // scale / weight folded into scale_.
  const TemporalConsistencyResidual functor(1.0 / scale_, 1.0);
  for (int i = 0; i < n; ++i) functor(now_.col(i).data(), before->col(i).data(), residuals + 3 * i);
  if (j_now) Eigen::Map<Eigen::MatrixXd>(jacobians[0], P, 3 * n) = scale_ * jacobian_now_.transpose();
  if (j_before) Eigen::Map<Eigen::MatrixXd>(jacobians[1], P, 3 * n) = -scale_ * jacobian_before_.transpose();
  return true;
}

}  // namespace polyfit
