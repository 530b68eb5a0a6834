// Distances to a binary mask's border, in pixels.
#ifndef POLYFIT_SFT_RENDER_MASK_DISTANCE_H_
#define POLYFIT_SFT_RENDER_MASK_DISTANCE_H_

#include <opencv2/core.hpp>

namespace polyfit {

// Signed distance (CV_32F) from each pixel's centre to the border of
// `inside` (CV_8U, non-zero inside): negative inside, positive outside,
// -0.5 and +0.5 on the pixels either side of a straight border.
cv::Mat SignedBorderDistance(const cv::Mat& inside);

}  // namespace polyfit

#endif  // POLYFIT_SFT_RENDER_MASK_DISTANCE_H_
