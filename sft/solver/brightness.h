// The lighting of a frame against the template's texture: real footage is
// brighter or darker than the texture, with another white balance, and
// changes over time. Per frame and channel, an affine map
//   I_obs = gain * I_texture + bias
// is matched by moments over the pixels the surface covers, and the frame
// is mapped back to the texture's lighting before the photometric term
// compares them. Moments (not a regression) so that a warm start a few
// pixels off, whose colours correlate poorly with the frame's, still gives
// the right gain.
#ifndef POLYFIT_SFT_SOLVER_BRIGHTNESS_H_
#define POLYFIT_SFT_SOLVER_BRIGHTNESS_H_

#include <limits>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace polyfit {

struct Brightness {
  Eigen::Array3d gain = Eigen::Array3d::Ones();
  Eigen::Array3d bias = Eigen::Array3d::Zero();
  // The mean over channels of the render's and the frame's correlation
  // there (1: the frame shows the texture where the surface is; near 0:
  // something else, tracking is lost). NaN when not measured.
  double correlation = std::numeric_limits<double>::quiet_NaN();
};

// Matches the mean and standard deviation of `observed` to those of
// `rendered` (both CV_32FC3) per channel, over the pixels of `roi` where
// `coverage` (CV_32F) is above 0.99 and `mask` (CV_32F, or empty) above 0.5.
// Returns the identity when fewer than `min_pixels` qualify; a channel
// with no contrast in the render keeps gain 1 and matches its mean. Gains
// are kept in [0.2, 5].
Brightness MatchBrightness(const cv::Mat& rendered, const cv::Mat& coverage, const cv::Mat& observed,
                           const cv::Mat& mask, const cv::Rect& roi, int min_pixels = 64);

// The frame mapped to the texture's lighting: (observed - bias) / gain.
cv::Mat CompensateBrightness(const cv::Mat& observed, const Brightness& brightness);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_BRIGHTNESS_H_
