#include "sft/render/mask_distance.h"

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

}  // namespace polyfit
