// A segmentation's mask is a few pixels off the surface's true silhouette
// (grown, shrunk, ragged). Matched pixel for pixel, such a mask pulls the
// surface toward or away from the camera until its silhouette fills it;
// within a band around the mask's border the silhouette is therefore left
// free, and the photometric term places the border there.
#ifndef POLYFIT_SFT_SOLVER_SILHOUETTE_BAND_H_
#define POLYFIT_SFT_SOLVER_SILHOUETTE_BAND_H_

#include <opencv2/core.hpp>

namespace polyfit {

// The silhouette's bounds M_lo <= S <= M_hi for a mask (CV_32F in [0, 1])
// with a band of `band` pixels: the mask eroded and dilated by a disc of
// that radius (rounded to whole pixels). At 0, both are the mask.
void MaskBounds(const cv::Mat& mask, double band, cv::Mat* lower, cv::Mat* upper);

// A binary mask (the scene format's: foreground > 127, a camera's
// coverage or a segmentation thresholded at 1/2) says of a pixel on its
// border only on which side of 1/2 the object covers it: there the bounds
// become [1/2, 1] inside and [0, 1/2] outside. Without this, an edge
// that crosses its border pixels at 0.6 reads as 1, and a straight edge
// at a fixed sub-pixel offset (a sheet facing the camera) is pulled
// outwards along its whole length by up to half a pixel. lower and upper:
// MaskBounds' (CV_32F, 0 or 1), modified in place (their own buffers).
void RelaxBinaryBorder(cv::Mat* lower, cv::Mat* upper);

// How far (px) a mask's border lies from a silhouette known to be right
// (the template's, at the first frame, to which it is registered): over
// the pixels on either side of the mask's border, the mean (trimmed by 10%
// at each end) of their signed distance to the silhouette's border
// (positive outside), less the half pixel an exact mask shows there.
// Positive: the mask is too large. This is the mask's systematic offset,
// which pulls the surface in depth; a ragged border averages out, holes
// are filled first (only outer borders count), and a stray blob's few
// border pixels fall in the trimmed tails. mask and silhouette: CV_32F in [0, 1]
// (thresholded at 1/2), of one size. 0 when either is empty.
double MaskBorderOffset(const cv::Mat& mask, const cv::Mat& silhouette);

// The band for a mask offset: none below half a pixel (the pixel grid),
// else the offset and half a pixel more, for the soft silhouette's edge.
double SilhouetteBandForOffset(double offset);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_SILHOUETTE_BAND_H_
