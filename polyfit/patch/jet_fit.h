// Least-squares n-jet fitting of point patches in their canonical frames.
//
// Per patch: a PCA frame (centred two-pass covariance; u, v along the two
// largest principal axes, scaled so that |u|, |v| <= 1), then the closed-form
// weighted least-squares jet z(u, v) over it, then optionally the orientation
// refinement: the frame's tilt is optimised so that the closed-form fit's
// residual is smallest (variable projection; see orientation_refinement.h).
#ifndef POLYFIT_PATCH_JET_FIT_H_
#define POLYFIT_PATCH_JET_FIT_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "polyfit/patch/jet_patch.h"

namespace polyfit {

enum class OrientationSolver {
  // Levenberg-Marquardt on the two tilt angles with the Kaufman var-pro
  // Jacobian, written out here: the fast default.
  kVarProLM,
  // The same var-pro cost as a ceres::CostFunction over the normal direction
  // on ceres::SphereManifold<3>, solved by ceres::Solve (slower: per-patch
  // problem set-up).
  kCeres,
};

struct OrientationRefinementOptions {
  OrientationSolver solver = OrientationSolver::kVarProLM;
  int max_iterations = 3;
  // Stop when an iteration lowers the cost by less than this fraction.
  double function_tolerance = 1e-3;
};

struct JetFitOptions {
  // Requested order n in [1, 8].
  int order = 4;
  // Optimise the frame's tilt (variable projection) after the PCA fit.
  bool refine_orientation = false;
  OrientationRefinementOptions refinement;
  // rms_residual / scale above which a patch is flagged kJetFitNotHeightField.
  double not_height_field_threshold = 0.05;
  // Threads for FitJetPatches; 0 means all hardware threads.
  int num_threads = 0;

  // Empty when valid, else what is wrong.
  std::string Validate() const;
};

// Fits single patches, reusing its buffers: after the first patch of a given
// size, Fit() does not allocate. Not thread-safe; use one per thread.
class JetFitter {
 public:
  explicit JetFitter(const JetFitOptions& options);
  ~JetFitter();
  JetFitter(JetFitter&&) noexcept;

  // points_in_world: 3 by M. weights: M non-negative weights, or null.
  JetPatch Fit(const Eigen::Ref<const Eigen::Matrix3Xd>& points_in_world, const double* weights = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct JetFitSummary {
  int num_patches = 0;
  int num_points = 0;
  // Patches carrying each flag.
  int num_reduced_order = 0;
  int num_rank_deficient = 0;
  int num_degenerate = 0;
  int num_dropped_non_finite = 0;
  int num_not_height_field = 0;
  int num_threads = 0;
  double total_time_s = 0.0;
  // Point-weighted RMS of the height residuals, world units.
  double rms_residual = 0.0;

  std::string BriefReport() const;
};

// Fits every patch p of points_in_world[:, patch_offsets[p] .. patch_offsets[p+1]),
// in parallel. patch_offsets: #patches + 1 non-decreasing indices from 0 to
// #points. weights: #points values or null. Throws std::invalid_argument on
// invalid options or offsets.
JetFitSummary FitJetPatches(const JetFitOptions& options, const Eigen::Matrix3Xd& points_in_world,
                            const std::vector<int>& patch_offsets, const std::vector<double>* weights,
                            std::vector<JetPatch>* patches);

}  // namespace polyfit

#endif  // POLYFIT_PATCH_JET_FIT_H_
