// A patch's canonical frame: p = s * R * phi + T, phi = (u, v, z) in the patch.
#ifndef POLYFIT_PATCH_PATCH_FRAME_H_
#define POLYFIT_PATCH_PATCH_FRAME_H_

#include <Eigen/Core>

namespace polyfit {

struct PatchFrame {
  // s: scales the patch so that its points have |u|, |v| <= 1.
  double scale = 1.0;
  // R: columns are the u axis, the v axis and the normal axis, in the world.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  // T: the patch origin (the points' centroid) in the world.
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d PointToWorld(const Eigen::Vector3d& point_in_patch) const {
    return scale * (rotation * point_in_patch) + translation;
  }
  Eigen::Vector3d PointToPatch(const Eigen::Vector3d& point_in_world) const {
    return rotation.transpose() * (point_in_world - translation) / scale;
  }
};

}  // namespace polyfit

#endif  // POLYFIT_PATCH_PATCH_FRAME_H_
