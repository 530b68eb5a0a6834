#include "sft/render/background_plate.h"

#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace polyfit {

cv::Mat FillHoleFromAround(const cv::Mat& image, const cv::Mat& hole) {
  if (image.type() != CV_32FC3 || hole.size() != image.size()) {
    throw std::invalid_argument("FillHoleFromAround: a CV_32FC3 image and a hole of its size");
  }
  cv::Mat known;  // 1 where the image is known, 0 in the hole
  if (hole.type() == CV_8U) {
    known = hole == 0;
  } else {
    known = hole <= 0.0;
  }
  if (static_cast<size_t>(cv::countNonZero(known)) == known.total()) return image.clone();
  known.convertTo(known, CV_32F, 1.0 / 255.0);
  // Push: premultiplied colour and weight, halved down to one pixel or
  // until every pixel knows something.
  std::vector<cv::Mat> colour{cv::Mat()}, weight{known};
  cv::Mat weight3;
  cv::merge(std::vector<cv::Mat>{known, known, known}, weight3);
  colour[0] = image.mul(weight3);
  while (weight.back().cols > 1 || weight.back().rows > 1) {
    double lowest;
    cv::minMaxLoc(weight.back(), &lowest);
    if (lowest > 0.0) break;
    const cv::Size size((weight.back().cols + 1) / 2, (weight.back().rows + 1) / 2);
    cv::Mat c, w;
    cv::resize(colour.back(), c, size, 0, 0, cv::INTER_AREA);
    cv::resize(weight.back(), w, size, 0, 0, cv::INTER_AREA);
    colour.push_back(c);
    weight.push_back(w);
  }
  // Pull: each level's colour normalised where it knows anything, the
  // coarser level's filling the rest by 1 - weight.
  cv::Mat filled;
  for (int l = static_cast<int>(colour.size()) - 1; l >= 0; --l) {
    cv::Mat up;
    if (!filled.empty()) cv::resize(filled, up, colour[l].size(), 0, 0, cv::INTER_LINEAR);
    cv::Mat out(colour[l].size(), CV_32FC3);
    for (int y = 0; y < out.rows; ++y) {
      const cv::Vec3f* c = colour[l].ptr<cv::Vec3f>(y);
      const float* w = weight[l].ptr<float>(y);
      const cv::Vec3f* u = up.empty() ? nullptr : up.ptr<cv::Vec3f>(y);
      cv::Vec3f* o = out.ptr<cv::Vec3f>(y);
      for (int x = 0; x < out.cols; ++x) {
        // Premultiplied: c = w * mean of the known pixels.
        const float rest = std::max(0.0f, 1.0f - w[x]);
        o[x] = u != nullptr ? c[x] + rest * u[x] : (w[x] > 0.0f ? c[x] / w[x] : cv::Vec3f(0, 0, 0));
      }
    }
    filled = out;
  }
  // Known pixels exactly as given (the pull's blend leaves them so up to
  // rounding).
  image.copyTo(filled, known > 0.5f);
  return filled;
}

cv::Mat BackgroundPlate(const cv::Mat& image, const cv::Mat& mask, int margin_px) {
  cv::Mat hole = mask > 0;
  if (margin_px > 0) {
    cv::dilate(hole, hole, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * margin_px + 1, 2 * margin_px + 1)));
  }
  return FillHoleFromAround(image, hole);
}

}  // namespace polyfit
