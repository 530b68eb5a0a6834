// The rigid motion of a surface from its correspondences in an image: the
// surface's points named by matches (a face and barycentric coordinates)
// placed by a perspective-n-point solve inside RANSAC (OpenCV's
// solvePnPRansac: minimal samples, then a Levenberg-Marquardt refinement on
// the inliers). Where tracking is lost there is no frame before to start
// from, and the template's keypoints found in the frame say where it is
// (a deforming surface's rigid part; the photometric solve does the rest).
#ifndef POLYFIT_SFT_SOLVER_MATCH_POSE_H_
#define POLYFIT_SFT_SOLVER_MATCH_POSE_H_

#include <vector>

#include <Eigen/Core>

#include "sft/camera/pinhole_camera.h"
#include "sft/solver/texture_features.h"

namespace polyfit {

struct MatchPoseOptions {
  // A match is an inlier within this reprojection error (the camera's
  // pixels).
  double max_error_px = 4.0;
  int ransac_iterations = 300;
  // A pose is returned only with this many inliers, and this fraction of
  // the matches.
  int min_inliers = 8;
  double min_inlier_fraction = 0.3;
};

struct MatchPose {
  // point_in_camera = rotation * point_on_surface + translation.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  // Indices into the matches; their median reprojection error (pixels).
  std::vector<int> inliers;
  double median_error_px = 0.0;
};

// The rigid motion taking the surface `vertices` (3 by #V; faces 3 by #F)
// to where `matches` (pixels of `camera`) see it. False, with `pose`
// untouched, where too few matches agree on one motion (a match is an
// inlier in front of the camera only).
bool PoseFromMatches(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces,
                     const std::vector<FeatureMatch>& matches, const MatchPoseOptions& options, MatchPose* pose);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_MATCH_POSE_H_
