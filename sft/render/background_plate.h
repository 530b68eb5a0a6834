// What lies behind an object in a frame, estimated from around it: the
// background a soft render's rim is composited over (Compositing::
// kOverBackground), so that a pixel the object covers by D reads D of the
// object and 1 - D of what is around it, as the camera saw it. Against the
// observed frame itself (which already holds the object) a rim pixel's
// residual is not zero even at the true surface, and it pulls the
// silhouette inwards.
#ifndef POLYFIT_SFT_RENDER_BACKGROUND_PLATE_H_
#define POLYFIT_SFT_RENDER_BACKGROUND_PLATE_H_

#include <opencv2/core.hpp>

namespace polyfit {

// `image` (CV_32FC3) with the pixels where `hole` (CV_8U or CV_32F, same
// size) is non-zero filled smoothly from the pixels around the hole, by
// push-pull: the known pixels averaged over a pyramid of halving sizes,
// and each hole pixel given the coarsest average that reaches it, blended
// back to the finer levels by how much of each is known. Pixels outside
// the hole keep their value exactly. An empty hole returns the image; a
// hole that covers the whole image returns black.
cv::Mat FillHoleFromAround(const cv::Mat& image, const cv::Mat& hole);

// The plate for an object within `mask` (CV_32F coverage or CV_8U; any
// non-zero pixel may hold some of the object): the image with the mask
// and `margin_px` pixels around it filled from around (FillHoleFromAround).
cv::Mat BackgroundPlate(const cv::Mat& image, const cv::Mat& mask, int margin_px);

}  // namespace polyfit

#endif  // POLYFIT_SFT_RENDER_BACKGROUND_PLATE_H_
