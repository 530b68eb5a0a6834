#include "sft/render/background_plate.h"

#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace polyfit {
namespace {

constexpr int kWidth = 80, kHeight = 60;

// A smooth background (what lies behind the object).
cv::Vec3f Background(double x, double y) {
  return cv::Vec3f(0.3f + 0.2f * std::sin(0.1f * x), 0.2f + 0.6f * y / kHeight, 0.4f + 0.002f * x);
}

// A disc of one colour over the background, as a camera sees it: each
// pixel's coverage by 8 x 8 samples, and its colour their mix.
void DiscFrame(cv::Mat* image, cv::Mat* coverage, cv::Vec3f colour) {
  *image = cv::Mat(kHeight, kWidth, CV_32FC3);
  *coverage = cv::Mat(kHeight, kWidth, CV_32F);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      int inside = 0;
      for (int sy = 0; sy < 8; ++sy) {
        for (int sx = 0; sx < 8; ++sx) {
          const double px = x - 0.5 + (sx + 0.5) / 8, py = y - 0.5 + (sy + 0.5) / 8;
          inside += std::hypot(px - 37.3, py - 28.6) < 15.4;
        }
      }
      const float a = inside / 64.0f;
      coverage->at<float>(y, x) = a;
      image->at<cv::Vec3f>(y, x) = a * colour + (1.0f - a) * Background(x, y);
    }
  }
}

TEST(BackgroundPlateTest, KnownPixelsKeptAndAConstantFilledExactly) {
  cv::Mat image(kHeight, kWidth, CV_32FC3, cv::Scalar(0.25, 0.5, 0.75));
  cv::Mat hole = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  cv::rectangle(hole, cv::Rect(0, 10, 30, 45), cv::Scalar(255), cv::FILLED);  // touches the border
  image(cv::Rect(0, 10, 30, 45)).setTo(cv::Scalar(9, 9, 9));                  // what the hole hides
  const cv::Mat filled = FillHoleFromAround(image, hole);
  EXPECT_LT(cv::norm(filled, cv::Mat(kHeight, kWidth, CV_32FC3, cv::Scalar(0.25, 0.5, 0.75)), cv::NORM_INF), 1e-6);

  cv::Mat ramp(kHeight, kWidth, CV_32FC3);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) ramp.at<cv::Vec3f>(y, x) = Background(x, y);
  }
  const cv::Mat kept = FillHoleFromAround(ramp, hole);
  cv::Mat diff = cv::abs(kept - ramp);
  diff.setTo(cv::Scalar(0, 0, 0), hole);
  EXPECT_EQ(cv::norm(diff, cv::NORM_INF), 0.0);
  // An empty hole: the image; a hole over everything: black.
  EXPECT_EQ(cv::norm(FillHoleFromAround(ramp, cv::Mat::zeros(kHeight, kWidth, CV_8U)), ramp, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(FillHoleFromAround(ramp, cv::Mat(kHeight, kWidth, CV_32F, cv::Scalar(1.0))), cv::NORM_INF),
            0.0);
  EXPECT_THROW(FillHoleFromAround(ramp, cv::Mat::zeros(kHeight - 1, kWidth, CV_8U)), std::invalid_argument);
}

// The point of the plate: over it, a rim pixel that the object covers by
// its true coverage a reads a C + (1 - a) plate, near what the camera saw
// (the fill is the background around, not its gradient: 0.05 at most on
// this background, which changes by 0.02 a pixel); over the observed frame
// (which already holds the object) it reads a C + (1 - a) observed, off
// by a (1 - a) |C - B|. Measured: 2.6% of that squared error.
TEST(BackgroundPlateTest, ARimOverThePlateIsWhatTheCameraSaw) {
  const cv::Vec3f colour(0.9f, 0.1f, 0.8f);
  cv::Mat image, coverage;
  DiscFrame(&image, &coverage, colour);
  const cv::Mat plate = BackgroundPlate(image, coverage, 1);
  double over_plate = 0.0, over_image = 0.0, worst = 0.0;
  int rim = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const float a = coverage.at<float>(y, x);
      if (a <= 0.0f || a >= 1.0f) continue;
      ++rim;
      const cv::Vec3f seen = image.at<cv::Vec3f>(y, x);
      const double e_plate = cv::norm(a * colour + (1.0f - a) * plate.at<cv::Vec3f>(y, x) - seen);
      over_plate += e_plate * e_plate;
      worst = std::max(worst, e_plate);
      const double e_image = cv::norm(a * colour + (1.0f - a) * seen - seen);
      over_image += e_image * e_image;
    }
  }
  EXPECT_GT(rim, 60);
  EXPECT_LT(worst, 0.06);
  EXPECT_LT(over_plate, 0.04 * over_image) << over_plate << " " << over_image;
  // Inside the object, the plate is the background around it, not the object.
  EXPECT_LT(cv::norm(plate.at<cv::Vec3f>(28, 37) - Background(37, 28)), 0.15);
}

}  // namespace
}  // namespace polyfit
