#include "polyfit/patch/jet_fit.h"

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "polyfit/patch/jet_fit_kernel.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {

std::string JetFitFlagsToString(uint32_t flags) {
  static const std::pair<uint32_t, const char*> kNames[] = {{kJetFitReducedOrder, "reduced_order"},
                                                            {kJetFitRankDeficient, "rank_deficient"},
                                                            {kJetFitDegenerate, "degenerate"},
                                                            {kJetFitDroppedNonFinite, "dropped_non_finite"},
                                                            {kJetFitNotHeightField, "not_height_field"}};
  std::string s;
  for (const auto& [flag, name] : kNames) {
    if (!(flags & flag)) continue;
    if (!s.empty()) s += '|';
    s += name;
  }
  return s.empty() ? "ok" : s;
}

std::string JetFitOptions::Validate() const {
  std::ostringstream e;
  if (order < 1 || order > kMaxJetOrder) e << "order must be in [1, " << kMaxJetOrder << "], got " << order << ". ";
  if (refinement.max_iterations < 0) e << "refinement.max_iterations must be >= 0. ";
  if (!(refinement.function_tolerance >= 0)) e << "refinement.function_tolerance must be >= 0. ";
  if (!(not_height_field_threshold > 0)) e << "not_height_field_threshold must be > 0. ";
  if (num_threads < 0) e << "num_threads must be >= 0. ";
  return e.str();
}

namespace internal {

std::unique_ptr<JetOrderKernel> MakeJetOrderKernel(int order) {
  if (order <= 2) return MakeJetOrderKernel1To2(order);
  if (order <= 4) return MakeJetOrderKernel3To4(order);
  if (order <= 6) return MakeJetOrderKernel5To6(order);
  return MakeJetOrderKernel7To8(order);
}

}  // namespace internal

struct JetFitter::Impl {
  JetFitOptions options;
  internal::JetFitWorkspace ws;
  // Per order, made on first use: after that a fit does not allocate.
  std::unique_ptr<internal::JetOrderKernel> kernels[kMaxJetOrder + 1];

  internal::JetOrderKernel& Kernel(int order) {
    if (!kernels[order]) kernels[order] = internal::MakeJetOrderKernel(order);
    return *kernels[order];
  }

  JetPatch Fit(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const double* weights) {
    JetPatch patch;
    const int n = static_cast<int>(points.cols());
    ws.Reserve(n);
    Eigen::Matrix3Xd& x0 = ws.x0;
    std::vector<double>& sqrt_w = ws.sqrt_w;

    // Centroid of the finite points (weighted), then their centred covariance.
    double weight_sum = 0.0;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const double w = weights ? weights[i] : 1.0;
      if (!points.col(i).allFinite() || !std::isfinite(w) || w <= 0.0) {
        if (!(w == 0.0 && points.col(i).allFinite())) patch.flags |= kJetFitDroppedNonFinite;
        continue;
      }
      centroid += w * points.col(i);
      weight_sum += w;
      x0.col(m) = points.col(i);
      sqrt_w[m] = std::sqrt(w);
      ++m;
    }
    patch.num_points = m;
    if (m == 0) {
      patch.flags |= kJetFitDegenerate;
      return patch;
    }
    centroid /= weight_sum;
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (int i = 0; i < m; ++i) {
      x0.col(i) -= centroid;
      covariance.noalias() += (sqrt_w[i] * sqrt_w[i]) * x0.col(i) * x0.col(i).transpose();
    }
    patch.frame.translation = centroid;

    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
    eigen.computeDirect(covariance);
    Eigen::Matrix3d rotation;
    rotation.col(0) = eigen.eigenvectors().col(2);
    rotation.col(2) = eigen.eigenvectors().col(0);
    rotation.col(1) = rotation.col(2).cross(rotation.col(0));
    if (!rotation.allFinite()) rotation.setIdentity();

    x0.leftCols(m) = rotation.transpose() * x0.leftCols(m);
    const double extent = x0.topLeftCorner(2, m).cwiseAbs().maxCoeff();
    const double magnitude = 1.0 + centroid.cwiseAbs().maxCoeff();
    patch.frame.rotation = rotation;
    if (m < 3 || !(extent > 1e-13 * magnitude)) {
      patch.flags |= kJetFitDegenerate;
      return patch;
    }
    patch.frame.scale = extent;
    x0.leftCols(m) /= extent;
    ws.x.leftCols(m) = x0.leftCols(m);

    int order = options.order;
    while (NumJetCoefficients(order) > m) --order;
    if (order < options.order) patch.flags |= kJetFitReducedOrder;
    patch.order = order;

    const double* sw = weights ? sqrt_w.data() : nullptr;
    Eigen::Matrix3d tilt;
    Kernel(order).Fit(options, order, m, sw, weight_sum, &ws, &patch, &tilt);
    patch.frame.rotation = rotation * tilt;
    patch.rms_residual *= extent;
    if (patch.rms_residual > options.not_height_field_threshold * extent) {
      patch.flags |= kJetFitNotHeightField;
    }
    return patch;
  }
};

JetFitter::JetFitter(const JetFitOptions& options) : impl_(new Impl) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("JetFitOptions: " + error);
  impl_->options = options;
}
JetFitter::~JetFitter() = default;
JetFitter::JetFitter(JetFitter&&) noexcept = default;

JetPatch JetFitter::Fit(const Eigen::Ref<const Eigen::Matrix3Xd>& points_in_world, const double* weights) {
  return impl_->Fit(points_in_world, weights);
}

std::string JetFitSummary::BriefReport() const {
  std::ostringstream s;
  s << "Fitted " << num_patches << " patches (" << num_points << " points) in " << total_time_s * 1e3 << " ms on "
    << num_threads << " thread(s), RMS residual " << rms_residual;
  if (num_reduced_order) s << ", " << num_reduced_order << " reduced order";
  if (num_rank_deficient) s << ", " << num_rank_deficient << " rank deficient";
  if (num_degenerate) s << ", " << num_degenerate << " degenerate";
  if (num_dropped_non_finite) s << ", " << num_dropped_non_finite << " with non-finite points";
  if (num_not_height_field) s << ", " << num_not_height_field << " not height fields";
  return s.str();
}

JetFitSummary FitJetPatches(const JetFitOptions& options, const Eigen::Matrix3Xd& points_in_world,
                            const std::vector<int>& patch_offsets, const std::vector<double>* weights,
                            std::vector<JetPatch>* patches) {
  const auto start = std::chrono::steady_clock::now();
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("JetFitOptions: " + error);
  if (patch_offsets.empty() || patch_offsets.front() != 0 || patch_offsets.back() != points_in_world.cols()) {
    throw std::invalid_argument("FitJetPatches: patch_offsets must run from 0 to the number of points");
  }
  for (size_t p = 1; p < patch_offsets.size(); ++p) {
    if (patch_offsets[p] < patch_offsets[p - 1]) {
      throw std::invalid_argument("FitJetPatches: patch_offsets decrease at " + std::to_string(p));
    }
  }
  if (weights && weights->size() != static_cast<size_t>(points_in_world.cols())) {
    throw std::invalid_argument("FitJetPatches: weights must have one value per point");
  }
  const int num_patches = static_cast<int>(patch_offsets.size()) - 1;
  patches->resize(num_patches);
  const int num_threads = std::min(ResolveNumThreads(options.num_threads), std::max(1, num_patches));
  std::vector<JetFitter> fitters;
  fitters.reserve(num_threads);
  for (int t = 0; t < num_threads; ++t) fitters.emplace_back(options);
  ParallelFor(num_patches, num_threads, [&](int thread, int p) {
    const int begin = patch_offsets[p];
    const int size = patch_offsets[p + 1] - begin;
    (*patches)[p] =
        fitters[thread].Fit(points_in_world.middleCols(begin, size), weights ? weights->data() + begin : nullptr);
  });

  JetFitSummary summary;
  summary.num_patches = num_patches;
  summary.num_threads = num_threads;
  double ssr = 0.0;
  for (const JetPatch& patch : *patches) {
    summary.num_points += patch.num_points;
    ssr += patch.rms_residual * patch.rms_residual * patch.num_points;
    summary.num_reduced_order += (patch.flags & kJetFitReducedOrder) != 0;
    summary.num_rank_deficient += (patch.flags & kJetFitRankDeficient) != 0;
    summary.num_degenerate += (patch.flags & kJetFitDegenerate) != 0;
    summary.num_dropped_non_finite += (patch.flags & kJetFitDroppedNonFinite) != 0;
    summary.num_not_height_field += (patch.flags & kJetFitNotHeightField) != 0;
  }
  summary.rms_residual = summary.num_points ? std::sqrt(ssr / summary.num_points) : 0.0;
  summary.total_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace polyfit
