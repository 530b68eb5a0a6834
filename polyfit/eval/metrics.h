// Accuracy metrics: height error and normal error of a fitted patch against a
// known surface, and the symmetric Chamfer distance between point sets.
#ifndef POLYFIT_EVAL_METRICS_H_
#define POLYFIT_EVAL_METRICS_H_

#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "polyfit/patch/jet_patch.h"
#include "polyfit/synthetic/patch_families.h"

namespace polyfit {

// Sums over points; combine patches with Add(), read with the accessors.
struct SurfaceErrorAccumulator {
  double sum_squared_height = 0.0;
  double sum_normal_deg = 0.0;
  long long count = 0;

  void Add(const SurfaceErrorAccumulator& other) {
    sum_squared_height += other.sum_squared_height;
    sum_normal_deg += other.sum_normal_deg;
    count += other.count;
  }
  double height_rmse() const { return count ? std::sqrt(sum_squared_height / count) : 0.0; }
  double normal_error_deg() const { return count ? sum_normal_deg / count : 0.0; }
};

// For each true surface point g_i (3 by N, world) with unit normal n_i: the
// height error is the distance from g_i to the fitted surface (its closest
// point, by Gauss-Newton from the vertical projection in the patch frame),
// the normal error the unoriented angle between n_i and the fitted normal
// there. (Intersecting the line g_i + t n_i instead has heavy tails: where
// the fit is off by tens of degrees the line grazes it far away.)
SurfaceErrorAccumulator EvaluatePatchAgainstSurface(const JetPatch& patch, const Eigen::Matrix3Xd& surface_points,
                                                    const Eigen::Matrix3Xd& surface_normals);

// EvaluatePatchAgainstSurface over a synthetic set, patches[p] fitted to
// set.patches[p].
SurfaceErrorAccumulator EvaluatePatchSet(const SyntheticPatchSet& set, const std::vector<JetPatch>& patches);

struct ChamferDistance {
  double a_to_b = 0.0;  // mean over a of the squared distance to the nearest b
  double b_to_a = 0.0;
  double sum() const { return a_to_b + b_to_a; }
};

// a: 3 by Na, b: 3 by Nb, both non-empty (std::invalid_argument otherwise).
ChamferDistance ComputeChamferDistance(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b);

}  // namespace polyfit

#endif  // POLYFIT_EVAL_METRICS_H_
