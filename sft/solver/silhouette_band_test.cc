#include "sft/solver/silhouette_band.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace polyfit {
namespace {

// A disc of radius r (px) centred at (cx, cy) in a 120 x 100 image, as
// coverage (CV_32F): pixels whose centre lies inside.
cv::Mat Disc(double r, double cx = 60.3, double cy = 49.7) {
  cv::Mat m(100, 120, CV_32F);
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) m.at<float>(y, x) = std::hypot(x - cx, y - cy) < r ? 1.0f : 0.0f;
  }
  return m;
}

TEST(SilhouetteBand, TheBorderOffsetIsHowFarTheMaskIsGrownOrShrunk) {
  const cv::Mat silhouette = Disc(30.0);
  EXPECT_NEAR(MaskBorderOffset(Disc(30.0), silhouette), 0.0, 0.3);  // exact, but for the pixel grid
  EXPECT_NEAR(MaskBorderOffset(Disc(33.0), silhouette), 3.0, 0.25);
  EXPECT_NEAR(MaskBorderOffset(Disc(31.4), silhouette), 1.4, 0.25);  // not on the pixel grid
  EXPECT_NEAR(MaskBorderOffset(Disc(27.5), silhouette), -2.5, 0.25);
  EXPECT_NEAR(MaskBorderOffset(Disc(30.0, 62.3), silhouette), 0.0, 0.6);  // shifted: as much out as in
  cv::Mat holed = Disc(33.0);
  for (int k = 0; k < 3; ++k) cv::circle(holed, cv::Point(50 + 10 * k, 50), 4, cv::Scalar(0.0f), cv::FILLED);
  EXPECT_NEAR(MaskBorderOffset(holed, silhouette), 3.0, 0.4);  // holes barely move it
  EXPECT_EQ(MaskBorderOffset(cv::Mat::zeros(100, 120, CV_32F), silhouette), 0.0);
}

TEST(SilhouetteBand, NoBandForAnExactMaskAndTheOffsetAndAHalfPixelOtherwise) {
  EXPECT_EQ(SilhouetteBandForOffset(0.3), 0.0);
  EXPECT_EQ(SilhouetteBandForOffset(-0.45), 0.0);
  EXPECT_EQ(SilhouetteBandForOffset(1.4), 1.9);
  EXPECT_EQ(SilhouetteBandForOffset(-2.5), 3.0);
}

TEST(SilhouetteBand, BoundsAreTheMaskErodedAndDilatedByTheBand) {
  const cv::Mat mask = Disc(30.0);
  cv::Mat lower, upper;
  MaskBounds(mask, 0.3, &lower, &upper);  // rounds to no band
  EXPECT_EQ(cv::norm(lower, mask, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(upper, mask, cv::NORM_INF), 0.0);
  MaskBounds(mask, 3.0, &lower, &upper);
  EXPECT_NEAR(cv::sum(lower)[0], M_PI * 27.0 * 27.0, 0.04 * M_PI * 27.0 * 27.0);
  EXPECT_NEAR(cv::sum(upper)[0], M_PI * 33.0 * 33.0, 0.04 * M_PI * 33.0 * 33.0);
  EXPECT_EQ(cv::countNonZero(lower > mask), 0);
  EXPECT_EQ(cv::countNonZero(upper < mask), 0);
}

}  // namespace
}  // namespace polyfit
