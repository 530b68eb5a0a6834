// The pinhole camera of PolySfT, in one place: projection of a point, its
// Jacobian, and the camera of a scaled image (a pyramid level). OpenCV's
// convention: x right, y down, z forward; pixel (0, 0) is the centre of the
// top-left pixel.
//
//   (px, py) = (fx x / z + cx, fy y / z + cy)
//   d(px, py, z)/d(x, y, z) = [fx / z, 0, -fx x / z^2; 0, fy / z, -fy y / z^2; 0, 0, 1]
#ifndef POLYFIT_SFT_CAMERA_PINHOLE_CAMERA_H_
#define POLYFIT_SFT_CAMERA_PINHOLE_CAMERA_H_

#include <cmath>
#include <vector>

#include <Eigen/Core>

namespace polyfit {

struct PinholeCamera {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  int width = 0, height = 0;
  // k1, k2, p1, p2, k3, or empty. Frames are undistorted on load, so the
  // solver sees the pinhole model only.
  std::vector<double> distortion;

  Eigen::Vector2d Project(const Eigen::Vector3d& point_in_camera) const {
    return {fx * point_in_camera.x() / point_in_camera.z() + cx, fy * point_in_camera.y() / point_in_camera.z() + cy};
  }

  // The pixel of a point in front of the camera and, optionally, the 3 by 3
  // Jacobian of (px, py, z). False for a point at or behind z = 1e-6, or
  // not finite.
  bool ProjectWithJacobian(const Eigen::Vector3d& point_in_camera, Eigen::Vector2d* pixel,
                           Eigen::Matrix3d* jacobian) const {
    const double x = point_in_camera.x(), y = point_in_camera.y(), z = point_in_camera.z();
    if (!(z > 1e-6) || !std::isfinite(x) || !std::isfinite(y)) return false;
    const double inv_z = 1.0 / z;
    *pixel = Eigen::Vector2d(fx * x * inv_z + cx, fy * y * inv_z + cy);
    if (jacobian != nullptr) {
      *jacobian << fx * inv_z, 0.0, -fx * x * inv_z * inv_z, 0.0, fy * inv_z, -fy * y * inv_z * inv_z, 0.0, 0.0, 1.0;
    }
    return true;
  }

  // The same camera for an image scaled by `factor` (a pyramid level);
  // pixel centres map as x' + 0.5 = factor (x + 0.5). No distortion.
  PinholeCamera Scaled(double factor) const {
    PinholeCamera c = *this;
    c.fx *= factor;
    c.fy *= factor;
    c.cx = factor * (cx + 0.5) - 0.5;
    c.cy = factor * (cy + 0.5) - 0.5;
    c.width = static_cast<int>(std::lround(width * factor));
    c.height = static_cast<int>(std::lround(height * factor));
    c.distortion.clear();
    return c;
  }
};

}  // namespace polyfit

#endif  // POLYFIT_SFT_CAMERA_PINHOLE_CAMERA_H_
