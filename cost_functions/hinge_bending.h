// Bending at a hinge, the two triangles (i, j, k) and (j, i, l) that share
// the edge i -> j (discrete shells, Grinspun et al. 2003):
//
//   theta = atan2(((n_1 x n_2) . e) / |e|, n_1 . n_2),
//   n_1 = e x (x_k - x_i),  n_2 = (x_l - x_i) x e,  e = x_j - x_i,
//   r = w (theta - theta_rest),
//
// theta the signed dihedral angle (0 flat, > 0 where the second face
// turns away from the first's normal n_1), the difference wrapped into
// (-pi, pi]. With
// w^2 = k 3 |e|^2 / (A_1 + A_2) (rest edge length and face areas) the sum
// of r^2 over a mesh's hinges approximates k times the integral of the
// squared mean curvature (times 4) against the rest shape's: dimensionless,
// whatever the mesh's resolution. Parameter blocks, in order: x_i, x_j,
// x_k, x_l (3 each).
#ifndef COST_FUNCTIONS_HINGE_BENDING_H_
#define COST_FUNCTIONS_HINGE_BENDING_H_

#include <cmath>
#include <stdexcept>

#include <ceres/autodiff_cost_function.h>

namespace polyfit {

// The signed dihedral angle above (radians, in (-pi, pi]); 0 where a face
// or the edge has collapsed (no angle, and no derivative, to give).
template <typename T>
T SignedDihedralAngle(const T* x_i, const T* x_j, const T* x_k, const T* x_l) {
  using std::atan2;
  using std::sqrt;
  T e[3], a[3], b[3], n1[3], n2[3], m[3];
  for (int c = 0; c < 3; ++c) {
    e[c] = x_j[c] - x_i[c];
    a[c] = x_k[c] - x_i[c];
    b[c] = x_l[c] - x_i[c];
  }
  auto cross = [](const T* u, const T* v, T* out) {
    out[0] = u[1] * v[2] - u[2] * v[1];
    out[1] = u[2] * v[0] - u[0] * v[2];
    out[2] = u[0] * v[1] - u[1] * v[0];
  };
  auto dot = [](const T* u, const T* v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
  cross(e, a, n1);
  cross(b, e, n2);
  const T ee = dot(e, e), n11 = dot(n1, n1), n22 = dot(n2, n2);
  // Relative to the edge's scale, so that a tiny but sound hinge keeps its angle.
  const T tiny = T(1e-24) * ee * ee;
  if (!(ee > T(0.0)) || !(n11 > tiny) || !(n22 > tiny)) return T(0.0);
  cross(n1, n2, m);
  return atan2(dot(m, e) / sqrt(ee), dot(n1, n2));
}

class HingeBendingResidual {
 public:
  HingeBendingResidual(double rest_angle, double weight) : rest_angle_(rest_angle), weight_(weight) {}

  template <typename T>
  bool operator()(const T* x_i, const T* x_j, const T* x_k, const T* x_l, T* residual) const {
    constexpr double kPi = 3.14159265358979323846;
    T d = SignedDihedralAngle(x_i, x_j, x_k, x_l) - T(rest_angle_);
    // A hinge folded through +-pi is the same fold either way round.
    if (d > T(kPi)) d -= T(2.0 * kPi);
    if (d <= T(-kPi)) d += T(2.0 * kPi);
    residual[0] = T(weight_) * d;
    return true;
  }

  // rest_angle finite, weight >= 0, else std::invalid_argument.
  static ceres::CostFunction* Create(double rest_angle, double weight = 1.0) {
    if (!std::isfinite(rest_angle)) throw std::invalid_argument("HingeBendingResidual: rest_angle must be finite");
    if (!(weight >= 0.0)) throw std::invalid_argument("HingeBendingResidual: weight must be >= 0");
    return new ceres::AutoDiffCostFunction<HingeBendingResidual, 1, 3, 3, 3, 3>(
        new HingeBendingResidual(rest_angle, weight));
  }

 private:
  double rest_angle_;
  double weight_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_HINGE_BENDING_H_
