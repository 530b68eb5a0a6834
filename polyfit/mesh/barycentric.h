// Barycentric coordinates of a point on a triangle.
#ifndef POLYFIT_MESH_BARYCENTRIC_H_
#define POLYFIT_MESH_BARYCENTRIC_H_

#include <Eigen/Core>

namespace polyfit {

// (w_a, w_b, w_c) with p = w_a a + w_b b + w_c c for p on the triangle
// (its closest point, up to rounding): clamped to >= 0 and summing to 1;
// the centroid's for a degenerate triangle.
inline Eigen::Vector3d BarycentricOnTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                             const Eigen::Vector3d& c, const Eigen::Vector3d& p) {
  const Eigen::Vector3d e0 = b - a, e1 = c - a, d = p - a;
  const double d00 = e0.dot(e0), d01 = e0.dot(e1), d11 = e1.dot(e1), d20 = d.dot(e0), d21 = d.dot(e1);
  const double denominator = d00 * d11 - d01 * d01;
  if (!(denominator > 0.0)) return Eigen::Vector3d::Constant(1.0 / 3.0);
  const double y = (d11 * d20 - d01 * d21) / denominator, z = (d00 * d21 - d01 * d20) / denominator;
  const Eigen::Vector3d w = Eigen::Vector3d(1.0 - y - z, y, z).cwiseMax(0.0);
  return w / w.sum();
}

}  // namespace polyfit

#endif  // POLYFIT_MESH_BARYCENTRIC_H_
