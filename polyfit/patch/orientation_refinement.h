// Orientation refinement by variable projection.
//
// The paper rotates each patch with a learned STN before fitting, so that it
// is closer to a height graph. Here the rotation is optimised per patch: for
// a tilt R_c of the frame the best jet is the closed-form fit, leaving
//
//   f(R_c) = || (I - P(R_c)) z(R_c) ||^2,   P = A (A^T A)^-1 A^T,
//
// with (u, v, z) = R_c^T q the local points q seen in the tilted frame and A
// their monomials. Only the tilt matters: a rotation about the normal maps a
// full n-jet onto another one. The Jacobian is Kaufman's approximation
// J = (I - P) dr/dR_c at fixed alpha, with r = z - h(u, v).
#ifndef POLYFIT_PATCH_ORIENTATION_REFINEMENT_H_
#define POLYFIT_PATCH_ORIENTATION_REFINEMENT_H_

#include <Eigen/Core>

#include "polyfit/patch/jet_fit.h"

namespace polyfit {

// Minimal rotation taking e_z to the unit vector n (n_z > -1):
// R = I + [k]x + [k]x^2 / (1 + n_z), k = e_z x n. Templated for autodiff.
template <typename T>
Eigen::Matrix<T, 3, 3> RotationFromZAxis(const T* n) {
  Eigen::Matrix<T, 3, 3> kx;
  kx << T(0.0), T(0.0), n[0], T(0.0), T(0.0), n[1], -n[0], -n[1], T(0.0);
  return Eigen::Matrix<T, 3, 3>::Identity() + kx + kx * kx / (T(1.0) + n[2]);
}

// Solves the var-pro problem above with ceres::Solve, the normal direction
// n (in the initial frame, starting at e_z) on ceres::SphereManifold<3>.
// local: 3 by >= m points in the initial frame; sqrt_w: m or null.
// On return *tilt = RotationFromZAxis(n). Returns the iterations used.
int RefineOrientationWithCeres(const OrientationRefinementOptions& options, int order, const Eigen::Matrix3Xd& local,
                               int m, const double* sqrt_w, Eigen::Matrix3d* tilt);

}  // namespace polyfit

#endif  // POLYFIT_PATCH_ORIENTATION_REFINEMENT_H_
