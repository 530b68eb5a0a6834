// Distances to a binary mask's border, in pixels.
#ifndef POLYFIT_SFT_RENDER_MASK_DISTANCE_H_
#define POLYFIT_SFT_RENDER_MASK_DISTANCE_H_

#include <opencv2/core.hpp>

namespace polyfit {

// Signed distance (CV_32F) from each pixel's centre to the border of
// `inside` (CV_8U, non-zero inside): negative inside, positive outside,
// -0.5 and +0.5 on the pixels either side of a straight border.
cv::Mat SignedBorderDistance(const cv::Mat& inside);

// Distance (CV_32F, px) from each pixel's centre to the object's
// silhouette: 0 inside, d - 0.5 outside (d: to the nearest inside pixel's
// centre). The silhouette is `mask` (CV_8U above 127, or CV_32F above
// 0.5) with its holes filled: every point of a surface projects inside its
// outline, hidden or not, but a segmentation's holes say nothing. The
// result is `margin` pixels larger on every side (pixel (x, y) of the mask
// is (x + margin, y + margin)), the mask continued beyond the image by its
// border's pixels: an object that the image cuts off goes on past it.
cv::Mat OutsideDistance(const cv::Mat& mask, int margin = 0);

}  // namespace polyfit

#endif  // POLYFIT_SFT_RENDER_MASK_DISTANCE_H_
