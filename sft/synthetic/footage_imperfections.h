// What real footage does that the generator's clean world does not, applied
// to generated frames so that tests and benchmarks cover it: masks a few
// pixels off (grown or shrunk, ragged, with holes), lighting that differs
// from the texture and drifts over time (gain, bias, shading), blur, and a
// textured background that moves. The camera's fx != fy and off-centre
// principal point are SheetSceneOptions' (they change the projection).
// Each imperfection is off at 0.
#ifndef POLYFIT_SFT_SYNTHETIC_FOOTAGE_IMPERFECTIONS_H_
#define POLYFIT_SFT_SYNTHETIC_FOOTAGE_IMPERFECTIONS_H_

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

struct FootageImperfections {
  // Masks grown (> 0) or shrunk (< 0) by this many pixels, as a
  // segmentation that bleeds into the background or eats the border.
  double mask_offset = 0.0;
  // The mask's border moved in and out by smooth random noise of up to
  // this many pixels (a ragged segmentation).
  double mask_ragged = 0.0;
  // Holes (discs of 2–5 px radius) punched into each mask inside the sheet.
  int mask_holes = 0;
  // Frame t (tau = t / (T - 1)) has colours c' = g(tau) c + b(tau) with
  // g = 1 + gain_drift sin(pi tau) and b = bias_drift sin(2 pi tau): the
  // camera's exposure and white level drifting, none of it in the texture.
  double gain_drift = 0.0;
  double bias_drift = 0.0;
  // Lambertian shading of the sheet by a light from the upper left:
  // colours times 1 - shading + shading max(0, n . l), so bends change the
  // brightness the texture shows.
  double shading = 0.0;
  // Gaussian blur (standard deviation, px) of every frame: defocus and
  // motion blur.
  double blur = 0.0;
  // A textured background that slides a few pixels per frame, instead of
  // the smooth backdrop.
  bool moving_background = false;

  bool Any() const;
  std::string Validate() const;
  // The imperfections of the "real-like" scenes (docs/sft.md): a mask 2 px
  // too large and ragged by 1.5 px with 2 holes, 25% gain and 0.05 bias
  // drift, shading 0.3, blur 0.8 px, a moving background.
  static FootageImperfections RealLike();
};

// Per face, the shading factor (in [1 - shading, 1]) of its normal, taken
// towards the camera (at the origin, looking along +z).
std::vector<float> FaceShading(const TriangleMesh& mesh, double shading);

// A background for frame `frame` (CV_32FC3, width x height): a crop of
// `backdrop` (larger than the frame) moving by 2 px right and 1 px down per
// frame, bouncing at the backdrop's edges.
cv::Mat MovingBackground(const cv::Mat& backdrop, int width, int height, int frame);

// Applies the lighting drift and blur to a frame (CV_32FC3, in [0, 1]) at
// tau in [0, 1].
void DegradeFrame(const FootageImperfections& imperfections, double tau, cv::Mat* color);

// Degrades a coverage mask (CV_32F in [0, 1]) as a segmentation would: the
// result is binary (0 or 1), thresholded at half coverage after the offset,
// the ragged border and the holes. Seeded per frame.
cv::Mat DegradeMask(const FootageImperfections& imperfections, const cv::Mat& coverage, std::uint64_t seed);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SYNTHETIC_FOOTAGE_IMPERFECTIONS_H_
