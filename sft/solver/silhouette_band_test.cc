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

// A binary mask of a straight edge crossing its border pixels at a third:
// the bounds there become [1/2, 1] inside and [0, 1/2] outside, so that the
// coverage the camera saw (and a soft silhouette near it) costs nothing,
// while a silhouette a pixel off still does. The image's edge is no border,
// and the mask itself is left as it was.
TEST(SilhouetteBand, ABinaryMasksBorderPixelsAreBoundedByAHalf) {
  cv::Mat mask = cv::Mat::zeros(20, 30, CV_32F);
  mask.colRange(0, 12).setTo(1.0f);  // the edge at x = 11.17 thresholds to columns 0-11
  const cv::Mat kept = mask.clone();
  cv::Mat lower, upper;
  MaskBounds(mask, 0.0, &lower, &upper);
  RelaxBinaryBorder(&lower, &upper);
  EXPECT_EQ(cv::norm(mask, kept, cv::NORM_INF), 0.0);
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 30; ++x) {
      const float lo = lower.at<float>(y, x), hi = upper.at<float>(y, x);
      ASSERT_EQ(lo, x < 11 ? 1.0f : x == 11 ? 0.5f : 0.0f) << x << "," << y;
      ASSERT_EQ(hi, x <= 11 ? 1.0f : x == 12 ? 0.5f : 0.0f) << x << "," << y;
    }
  }
  // The edge's true coverage of column 11 (2/3) and 12 (0) lies within
  // the bounds; a silhouette one pixel short (column 11 at 0) does not.
  EXPECT_TRUE(2.0f / 3.0f >= lower.at<float>(5, 11) && 2.0f / 3.0f <= upper.at<float>(5, 11));
  EXPECT_LT(0.0f, lower.at<float>(5, 11));
  // With a band, the eroded and dilated bounds' borders.
  MaskBounds(mask, 3.0, &lower, &upper);
  RelaxBinaryBorder(&lower, &upper);
  EXPECT_EQ(lower.at<float>(5, 8), 0.5f);
  EXPECT_EQ(lower.at<float>(5, 7), 1.0f);
  EXPECT_EQ(upper.at<float>(5, 15), 0.5f);
  EXPECT_EQ(upper.at<float>(5, 16), 0.0f);
}

}  // namespace
}  // namespace polyfit
