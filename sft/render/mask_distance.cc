#include "sft/render/mask_distance.h"

#include <vector>

#include <opencv2/imgproc.hpp>

namespace polyfit {

cv::Mat SignedBorderDistance(const cv::Mat& inside) {
  cv::Mat binary = inside != 0, to_inside, to_outside;
  const cv::Mat outside = binary == 0;
  cv::distanceTransform(outside, to_inside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::distanceTransform(binary, to_outside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::Mat d(inside.size(), CV_32F);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      d.at<float>(y, x) = binary.at<uchar>(y, x) ? 0.5f - to_outside.at<float>(y, x) : to_inside.at<float>(y, x) - 0.5f;
    }
  }
  return d;
}

cv::Mat OutsideDistance(const cv::Mat& mask, int margin) {
  cv::Mat inside = mask.depth() == CV_8U ? mask > 127 : mask > 0.5;
  if (margin > 0) cv::copyMakeBorder(inside, inside, margin, margin, margin, margin, cv::BORDER_REPLICATE);
  std::vector<std::vector<cv::Point>> outlines;
  cv::findContours(inside.clone(), outlines, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::drawContours(inside, outlines, -1, cv::Scalar(255), cv::FILLED);
  cv::Mat distance;
  cv::distanceTransform(inside == 0, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::max(distance - 0.5, 0.0, distance);
  return distance;
}

}  // namespace polyfit
