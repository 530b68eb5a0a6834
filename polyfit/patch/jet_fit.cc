#include "polyfit/patch/jet_fit.h"

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "polyfit/patch/local_jet_solver.h"
#include "polyfit/patch/orientation_refinement.h"
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

namespace {

using internal::LocalJetSolver;

constexpr double kMaxTiltStep = 0.3;  // radians

// Rotation by the tilt (t0, t1, 0) (axis-angle).
Eigen::Matrix3d TiltRotation(double t0, double t1) {
  const double angle = std::hypot(t0, t1);
  if (angle < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, Eigen::Vector3d(t0 / angle, t1 / angle, 0.0)).toRotationMatrix();
}

}  // namespace

struct JetFitter::Impl {
  JetFitOptions options;
  // Local points: x0 in the PCA frame, x in the current (tilted) frame.
  Eigen::Matrix3Xd x0, x;
  std::vector<double> sqrt_w;
  Eigen::Matrix<double, Eigen::Dynamic, 2> jacobian;
  std::tuple<LocalJetSolver<3>, LocalJetSolver<6>, LocalJetSolver<10>, LocalJetSolver<15>, LocalJetSolver<21>,
             LocalJetSolver<28>, LocalJetSolver<36>, LocalJetSolver<45>>
      solvers;

  template <typename F>
  void WithSolver(int order, F&& f) {
    switch (order) {
      case 1: f(std::get<0>(solvers)); break;
      case 2: f(std::get<1>(solvers)); break;
      case 3: f(std::get<2>(solvers)); break;
      case 4: f(std::get<3>(solvers)); break;
      case 5: f(std::get<4>(solvers)); break;
      case 6: f(std::get<5>(solvers)); break;
      case 7: f(std::get<6>(solvers)); break;
      default: f(std::get<7>(solvers)); break;
    }
  }

  void Reserve(int m) {
    if (x0.cols() < m) {
      x0.resize(3, m);
      x.resize(3, m);
      sqrt_w.resize(m);
      jacobian.resize(m, 2);
    }
  }

  // Levenberg-Marquardt over the tilt with the Kaufman var-pro Jacobian.
  // On entry solver holds the fit at x == x0; on exit the fit at x = tilt^T x0.
  template <typename Solver>
  int RefineVarProLM(Solver& solver, int m, const double* sw, Eigen::Matrix3d* tilt) {
    const int order = solver.order();
    Eigen::Matrix3d rc = Eigen::Matrix3d::Identity();
    double cost = solver.ssr();
    double lambda = 1e-4;
    int iterations = 0;
    for (; iterations < options.refinement.max_iterations; ++iterations) {
      if (!solver.well_conditioned() || cost <= 0.0) break;
      // dr/dt at fixed alpha, r = z - h(u, v), (u, v, z) = exp(-t^) x.
      auto j = jacobian.topRows(m);
      const auto& alpha = solver.alpha();
      for (int i = 0; i < m; ++i) {
        const double u = x(0, i), v = x(1, i), z = x(2, i);
        const auto d = EvaluateJetDerivatives(order, alpha.data(), u, v);
        const double w = sw ? sw[i] : 1.0;
        j(i, 0) = w * (-v - d.z_v * z);
        j(i, 1) = w * (u + d.z_u * z);
      }
      solver.ProjectOut(j);
      const Eigen::Matrix2d jtj = j.transpose() * j;
      const Eigen::Vector2d jtr = j.transpose() * solver.residual();
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
        x.leftCols(m).noalias() = rc_new.transpose() * x0.leftCols(m);
        solver.Solve(order, x, m, sw);
        if (solver.ssr() < cost) {
          accepted = true;
          const double decrease = (cost - solver.ssr()) / cost;
          rc = rc_new;
          cost = solver.ssr();
          lambda = std::max(lambda * 0.1, 1e-8);
          if (decrease < options.refinement.function_tolerance) {
            ++iterations;
            *tilt = rc;
            return iterations;
          }
        } else {
          lambda *= 10.0;
        }
      }
      if (!accepted) {
        // Restore the fit at the best rotation.
        x.leftCols(m).noalias() = rc.transpose() * x0.leftCols(m);
        solver.Solve(order, x, m, sw);
        break;
      }
    }
    *tilt = rc;
    return iterations;
  }

  JetPatch Fit(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const double* weights) {
    JetPatch patch;
    const int n = static_cast<int>(points.cols());
    Reserve(n);

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
    x.leftCols(m) = x0.leftCols(m);

    int order = options.order;
    while (NumJetCoefficients(order) > m) --order;
    if (order < options.order) patch.flags |= kJetFitReducedOrder;
    patch.order = order;

    const double* sw = weights ? sqrt_w.data() : nullptr;
    WithSolver(order, [&](auto& solver) {
      patch.flags |= solver.Solve(order, x, m, sw);
      if (options.refine_orientation && solver.well_conditioned()) {
        Eigen::Matrix3d tilt = Eigen::Matrix3d::Identity();
        if (options.refinement.solver == OrientationSolver::kCeres) {
          patch.refinement_iterations = RefineOrientationWithCeres(options.refinement, order, x0, m, sw, &tilt);
          x.leftCols(m).noalias() = tilt.transpose() * x0.leftCols(m);
          patch.flags |= solver.Solve(order, x, m, sw);
        } else {
          patch.refinement_iterations = RefineVarProLM(solver, m, sw, &tilt);
        }
        patch.frame.rotation = rotation * tilt;
      }
      const int k = NumJetCoefficients(order);
      for (int i = 0; i < k; ++i) patch.coefficients[i] = solver.alpha()[i];
      const double mean_sq = solver.ssr() / (weights ? weight_sum : double(m));
      patch.rms_residual = std::sqrt(mean_sq) * extent;
    });
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
