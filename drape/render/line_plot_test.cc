#include "drape/render/line_plot.h"

#include <stdexcept>

#include <gtest/gtest.h>

namespace polyfit {
namespace {

TEST(LinePlotTest, DrawsEachSeriesInItsColourAndRejectsALengthMismatch) {
  const std::vector<double> x = {0, 1, 2, 3};
  const cv::Scalar red(0, 0, 255), green(0, 255, 0);
  std::vector<PlotPanel> panels = {{"a", {{"rising", {0, 1, 2, 3}, red}}},
                                   {"b", {{"flat", {1, 1, 1, 1}, green}, {"gap", {NAN, 1, NAN, 2}, red}}}};
  LinePlotOptions options;
  options.width = 400;
  options.panel_height = 150;
  const cv::Mat image = DrawLinePlot(x, panels, options);
  ASSERT_EQ(image.rows, 300);
  ASSERT_EQ(image.cols, 400);
  int red_top = 0, green_bottom = 0;
  for (int y = 0; y < image.rows; ++y) {
    for (int c = 0; c < image.cols; ++c) {
      const cv::Vec3b p = image.at<cv::Vec3b>(y, c);
      if (p == cv::Vec3b(0, 0, 255) && y < 150) ++red_top;
      if (p == cv::Vec3b(0, 255, 0) && y >= 150) ++green_bottom;
    }
  }
  EXPECT_GT(red_top, 100);  // the rising line, across the panel
  EXPECT_GT(green_bottom, 100);
  panels[0].series[0].y.pop_back();
  EXPECT_THROW(DrawLinePlot(x, panels), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
