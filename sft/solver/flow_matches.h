// Correspondences carried from one frame to the next by dense optical flow:
// each vertex of the surface as solved in the previous frame, where that
// frame saw it, moved by the flow at its pixel (DIS, Kroeger et al. 2016:
// coarse-to-fine patch search, so motions of tens of pixels are found,
// beyond what a blurred pyramid level of the photometric term reaches).
// A vertex is kept where it is the nearest layer at its pixel (a hard
// z-buffer of the surface: a fold's hidden layer gets no match), inside
// both frames' masks (when given), and where the backward flow brings its
// target back to it (occlusions and flow errors fail that check).
#ifndef POLYFIT_SFT_SOLVER_FLOW_MATCHES_H_
#define POLYFIT_SFT_SOLVER_FLOW_MATCHES_H_

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "sft/camera/pinhole_camera.h"
#include "sft/solver/texture_features.h"

namespace polyfit {

struct FlowMatchOptions {
  // Forward-backward disagreement (pixels) above which a vertex's flow is
  // not trusted.
  double max_inconsistency_px = 1.0;
  // A vertex is hidden when its depth exceeds the nearest surface's at its
  // pixel by more than this (metres; the caller scales it to the mesh).
  double depth_tolerance = 0.01;
  // At most this many matches, taken evenly over the vertices (the term's
  // cost grows with them; a few hundred pin a smooth surface down).
  int max_matches = 600;
};

// The nearest surface's depth per pixel (CV_32F, width by height of the
// camera; +inf where no face covers the pixel's centre). vertices: 3 by #V
// in the camera frame; faces: 3 by #F.
cv::Mat NearestDepth(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces);

// Per vertex, whether it is the nearest layer at its pixel, in the image,
// and in front of the camera.
std::vector<bool> VisibleVertices(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices,
                                  const Eigen::Matrix3Xi& faces, double depth_tolerance);

// The matches (a vertex as a corner of one of its faces, barycentric e_k;
// its pixel in `image`, in the camera's pixels) of the surface `vertices`
// (3 by #V, camera frame) seen in `previous_image`, carried into `image`.
// Images: RGB CV_32FC3 in [0, 1] (or 8-bit grey), the camera's size;
// masks: CV_32F (> 0.5 inside) or empty (no mask check).
std::vector<FeatureMatch> FlowMatches(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices,
                                      const Eigen::Matrix3Xi& faces, const cv::Mat& previous_image,
                                      const cv::Mat& image, const cv::Mat& previous_mask, const cv::Mat& mask,
                                      const FlowMatchOptions& options);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_FLOW_MATCHES_H_
