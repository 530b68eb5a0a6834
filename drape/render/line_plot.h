// A small line chart for reports: panels stacked vertically, each with
// its series against a shared x axis, drawn with OpenCV (no plotting
// dependency).
#ifndef POLYFIT_DRAPE_RENDER_LINE_PLOT_H_
#define POLYFIT_DRAPE_RENDER_LINE_PLOT_H_

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace polyfit {

struct PlotSeries {
  std::string label;
  std::vector<double> y;  // one value per x; non-finite values are gaps
  cv::Scalar color;       // BGR
};

struct PlotPanel {
  std::string title;  // also the y axis' unit, e.g. "epsilon_c (%)"
  std::vector<PlotSeries> series;
};

struct LinePlotOptions {
  int width = 900;
  int panel_height = 220;
  std::string x_label = "frame";
};

// x: the shared abscissa (one per value of every series). Throws
// std::invalid_argument when a series' length differs from x's.
cv::Mat DrawLinePlot(const std::vector<double>& x, const std::vector<PlotPanel>& panels,
                     const LinePlotOptions& options = {});

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_RENDER_LINE_PLOT_H_
