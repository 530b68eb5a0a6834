#include "sft/solver/brightness.h"

#include <algorithm>
#include <cmath>

namespace polyfit {

Brightness MatchBrightness(const cv::Mat& rendered, const cv::Mat& coverage, const cv::Mat& observed,
                           const cv::Mat& mask, const cv::Rect& roi, int min_pixels) {
  Eigen::Array3d sum_r = Eigen::Array3d::Zero(), sum_rr = sum_r, sum_o = sum_r, sum_oo = sum_r, sum_ro = sum_r;
  int n = 0;
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    for (int x = roi.x; x < roi.x + roi.width; ++x) {
      if (coverage.at<float>(y, x) <= 0.99f || (!mask.empty() && mask.at<float>(y, x) <= 0.5f)) continue;
      const cv::Vec3f r = rendered.at<cv::Vec3f>(y, x), o = observed.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) {
        sum_r[c] += r[c];
        sum_rr[c] += double(r[c]) * r[c];
        sum_o[c] += o[c];
        sum_oo[c] += double(o[c]) * o[c];
        sum_ro[c] += double(r[c]) * o[c];
      }
      ++n;
    }
  }
  Brightness b;
  if (n < std::max(min_pixels, 2)) return b;
  const Eigen::Array3d mean_r = sum_r / n, mean_o = sum_o / n;
  const Eigen::Array3d var_r = (sum_rr / n - mean_r.square()).max(0.0);
  const Eigen::Array3d var_o = (sum_oo / n - mean_o.square()).max(0.0);
  const Eigen::Array3d covariance = sum_ro / n - mean_r * mean_o;
  b.correlation = (covariance / (var_r * var_o).sqrt().max(1e-12)).mean();
  for (int c = 0; c < 3; ++c) {
    // Below about 1% contrast the ratio is noise: match the mean only.
    b.gain[c] = var_r[c] > 1e-4 ? std::clamp(std::sqrt(var_o[c] / var_r[c]), 0.2, 5.0) : 1.0;
    b.bias[c] = mean_o[c] - b.gain[c] * mean_r[c];
  }
  return b;
}

cv::Mat CompensateBrightness(const cv::Mat& observed, const Brightness& b) {
  cv::Mat out(observed.size(), CV_32FC3);
  const cv::Vec3f scale(1.0 / b.gain[0], 1.0 / b.gain[1], 1.0 / b.gain[2]);
  const cv::Vec3f shift(-b.bias[0] / b.gain[0], -b.bias[1] / b.gain[1], -b.bias[2] / b.gain[2]);
  for (int y = 0; y < observed.rows; ++y) {
    const cv::Vec3f* in = observed.ptr<cv::Vec3f>(y);
    cv::Vec3f* o = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < observed.cols; ++x) {
      for (int c = 0; c < 3; ++c) o[x][c] = in[x][c] * scale[c] + shift[c];
    }
  }
  return out;
}

}  // namespace polyfit
