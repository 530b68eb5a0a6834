#include "sft/solver/match_pose.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace polyfit {

bool PoseFromMatches(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces,
                     const std::vector<FeatureMatch>& matches, const MatchPoseOptions& options, MatchPose* pose) {
  const int n = static_cast<int>(matches.size());
  if (n < std::max(options.min_inliers, 6)) return false;
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  object.reserve(n);
  image.reserve(n);
  std::vector<Eigen::Vector3d> points;
  points.reserve(n);
  for (const FeatureMatch& m : matches) {
    const Eigen::Vector3d x = m.PointOn(vertices, faces);
    if (!x.allFinite() || !m.pixel.allFinite()) return false;
    points.push_back(x);
    object.emplace_back(x.x(), x.y(), x.z());
    image.emplace_back(m.pixel.x(), m.pixel.y());
  }
  const cv::Matx33d k(camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  bool found = false;
  try {
    found = cv::solvePnPRansac(object, image, k, cv::noArray(), rvec, tvec, false, options.ransac_iterations,
                               static_cast<float>(options.max_error_px), 0.999, inliers, cv::SOLVEPNP_ITERATIVE);
  } catch (const cv::Exception&) {
    return false;  // a degenerate sample set (all points on a line)
  }
  const int needed = std::max(options.min_inliers, static_cast<int>(std::ceil(options.min_inlier_fraction * n)));
  if (!found || static_cast<int>(inliers.size()) < needed) return false;
  // RANSAC's inliers are its best sample's: the refined motion's are taken
  // again and the motion refined on them once more.
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  std::vector<double> errors;
  for (int pass = 0; pass < 2; ++pass) {
    cv::Mat r;
    cv::Rodrigues(rvec, r);
    cv::cv2eigen(r, rotation);
    cv::cv2eigen(tvec, translation);
    if (!rotation.allFinite() || !translation.allFinite()) return false;
    inliers.clear();
    errors.clear();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d x = rotation * points[i] + translation;
      if (!(x.z() > 0.0)) continue;
      const double error = (camera.Project(x) - matches[i].pixel).norm();
      if (error <= options.max_error_px) {
        inliers.push_back(i);
        errors.push_back(error);
      }
    }
    if (static_cast<int>(inliers.size()) < needed) return false;
    if (pass == 1) break;
    std::vector<cv::Point3d> inlier_object;
    std::vector<cv::Point2d> inlier_image;
    for (int i : inliers) {
      inlier_object.push_back(object[i]);
      inlier_image.push_back(image[i]);
    }
    try {
      cv::solvePnPRefineLM(inlier_object, inlier_image, k, cv::noArray(), rvec, tvec);
    } catch (const cv::Exception&) {
      return false;
    }
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  pose->rotation = rotation;
  pose->translation = translation;
  pose->inliers = std::move(inliers);
  pose->median_error_px = errors[errors.size() / 2];
  return true;
}

}  // namespace polyfit
