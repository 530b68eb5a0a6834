#include "sft/solver/silhouette_band.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "sft/render/mask_distance.h"

namespace polyfit {

void MaskBounds(const cv::Mat& mask, double band, cv::Mat* lower, cv::Mat* upper) {
  const int radius = static_cast<int>(std::lround(band));
  if (radius <= 0) {
    *lower = mask;
    *upper = mask;
    return;
  }
  const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
  cv::Mat eroded, dilated;  // new buffers: *lower may share the mask's
  cv::erode(mask, eroded, disc, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  cv::dilate(mask, dilated, disc, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  *lower = eroded;
  *upper = dilated;
}

void RelaxBinaryBorder(cv::Mat* lower, cv::Mat* upper) {
  const cv::Mat square = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3));
  // Pixels of `bound` on the other side of 1/2 from a neighbour (8-connected;
  // the image's edge is no border) set to 1/2.
  auto relax = [&](cv::Mat* bound, bool inside) {
    const cv::Mat in = *bound >= 0.5f, out = *bound < 0.5f;
    cv::Mat near_other;
    cv::dilate(inside ? out : in, near_other, square, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
    cv::Mat relaxed = bound->clone();  // not shared with the other bound or the mask
    relaxed.setTo(0.5f, (inside ? in : out) & near_other);
    *bound = relaxed;
  };
  relax(lower, true);
  relax(upper, false);
}

namespace {

// The regions of a binary image with their holes filled: only outer
// borders are compared (a segmentation's holes are no offset).
cv::Mat FilledOuterRegions(const cv::Mat& binary) {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(binary, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::Mat filled = cv::Mat::zeros(binary.size(), CV_8U);
  cv::drawContours(filled, contours, -1, cv::Scalar(255), cv::FILLED);
  return filled;
}

}  // namespace

double MaskBorderOffset(const cv::Mat& mask, const cv::Mat& silhouette) {
  const cv::Mat in_mask = FilledOuterRegions(mask > 0.5f), in_silhouette = FilledOuterRegions(silhouette > 0.5f);
  if (cv::countNonZero(in_mask) == 0 || cv::countNonZero(in_silhouette) == 0) return 0.0;
  const cv::Mat d = SignedBorderDistance(in_silhouette);
  std::vector<float> offset;
  for (int y = 1; y + 1 < mask.rows; ++y) {
    for (int x = 1; x + 1 < mask.cols; ++x) {
      const bool in = in_mask.at<uchar>(y, x) != 0;
      const bool border = (in_mask.at<uchar>(y - 1, x) != 0) != in || (in_mask.at<uchar>(y + 1, x) != 0) != in ||
                          (in_mask.at<uchar>(y, x - 1) != 0) != in || (in_mask.at<uchar>(y, x + 1) != 0) != in;
      // An exact mask's border pixels lie 1/2 px inside (or outside) the
      // silhouette's border.
      if (border) offset.push_back(d.at<float>(y, x) + (in ? 0.5f : -0.5f));
    }
  }
  if (offset.size() < 10) return 0.0;
  // A trimmed mean: continuous (each offset is on a half-pixel grid), and
  // blind to the tails that holes or a stray blob would add.
  std::sort(offset.begin(), offset.end());
  const size_t trim = offset.size() / 10;
  double sum = 0.0;
  for (size_t i = trim; i < offset.size() - trim; ++i) sum += offset[i];
  return sum / static_cast<double>(offset.size() - 2 * trim);
}

double SilhouetteBandForOffset(double offset) { return std::abs(offset) < 0.5 ? 0.0 : std::abs(offset) + 0.5; }

}  // namespace polyfit
