// A fitted patch: its frame and the n-jet height function over it.
#ifndef POLYFIT_PATCH_JET_PATCH_H_
#define POLYFIT_PATCH_JET_PATCH_H_

#include <array>
#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "polyfit/jet/jet_surface.h"
#include "polyfit/patch/patch_frame.h"

namespace polyfit {

// Bit flags describing how a patch was fitted. A patch is always usable
// (finite frame and coefficients); the flags say how far to trust it.
enum JetFitFlag : uint32_t {
  // Fewer points than coefficients: the highest order the points support
  // was fitted instead (see JetPatch::order).
  kJetFitReducedOrder = 1u << 0,
  // The points do not determine every coefficient (collinear points, a thin
  // strip): the undetermined coefficients are set to zero.
  kJetFitRankDeficient = 1u << 1,
  // Fewer than three finite points, or all coincident: a flat patch through
  // their centroid.
  kJetFitDegenerate = 1u << 2,
  // Some points were NaN or infinite and were ignored.
  kJetFitDroppedNonFinite = 1u << 3,
  // The residual is large against the patch size: the surface folds over the
  // frame's plane (no height graph there). Refine the orientation or split.
  kJetFitNotHeightField = 1u << 4,
};

// "ok" or a '|'-separated list of flag names.
std::string JetFitFlagsToString(uint32_t flags);

struct JetPatch {
  PatchFrame frame;
  // The fitted order (<= the requested one; 0 for a degenerate patch).
  int order = 0;
  // alpha, NumJetCoefficients(order) values, the rest zero.
  std::array<double, kMaxJetCoefficients> coefficients{};
  uint32_t flags = 0;
  // Finite points used by the fit.
  int num_points = 0;
  // Root mean square of the (weighted) height residual, world units.
  double rms_residual = 0.0;
  // Iterations taken by the orientation refinement (0 when off).
  int refinement_iterations = 0;

  double Height(double u, double v) const { return EvaluateJetHeight(order, coefficients.data(), u, v); }
  Eigen::Vector3d PointInWorld(double u, double v) const {
    return frame.PointToWorld(Eigen::Vector3d(u, v, Height(u, v)));
  }
  Eigen::Vector3d NormalInWorld(double u, double v) const {
    const auto d = EvaluateJetDerivatives(order, coefficients.data(), u, v);
    Eigen::Vector3d n;
    JetNormal(d, n.data());
    return frame.rotation * n;
  }
};

}  // namespace polyfit

#endif  // POLYFIT_PATCH_JET_PATCH_H_
