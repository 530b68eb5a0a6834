#include "drape/render/line_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace polyfit {
namespace {

constexpr int kLeft = 70, kRight = 170, kTop = 28, kBottom = 34;

std::string Tick(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g", value);
  return text;
}

// The finite range of a panel's values, widened when flat.
void PanelRange(const PlotPanel& panel, double* low, double* high) {
  *low = std::numeric_limits<double>::infinity();
  *high = -std::numeric_limits<double>::infinity();
  for (const PlotSeries& s : panel.series) {
    for (double y : s.y) {
      if (!std::isfinite(y)) continue;
      *low = std::min(*low, y);
      *high = std::max(*high, y);
    }
  }
  if (!std::isfinite(*low)) *low = 0.0, *high = 1.0;
  *low = std::min(*low, 0.0);  // errors and times: anchored at zero
  if (*high - *low < 1e-12) *high = *low + 1.0;
}

void DrawPanel(const std::vector<double>& x, double x_low, double x_high, const PlotPanel& panel, cv::Mat* canvas,
               const cv::Rect& box) {
  double low, high;
  PanelRange(panel, &low, &high);
  const auto to_pixel = [&](double xv, double yv) {
    const double px = box.x + (xv - x_low) / (x_high - x_low) * box.width;
    const double py = box.y + box.height - (yv - low) / (high - low) * box.height;
    return cv::Point(static_cast<int>(std::lround(px)), static_cast<int>(std::lround(py)));
  };
  const cv::Scalar grey(200, 200, 200), black(0, 0, 0);
  cv::rectangle(*canvas, box, grey);
  for (int t = 0; t <= 4; ++t) {
    const double yv = low + (high - low) * t / 4.0;
    const cv::Point p = to_pixel(x_low, yv);
    cv::line(*canvas, p, cv::Point(box.x + box.width, p.y), grey);
    cv::putText(*canvas, Tick(yv), cv::Point(4, p.y + 4), cv::FONT_HERSHEY_SIMPLEX, 0.4, black);
  }
  cv::putText(*canvas, panel.title, cv::Point(box.x, box.y - 8), cv::FONT_HERSHEY_SIMPLEX, 0.5, black);
  int legend_y = box.y + 14;
  for (const PlotSeries& s : panel.series) {
    for (size_t i = 1; i < x.size(); ++i) {
      if (!std::isfinite(s.y[i - 1]) || !std::isfinite(s.y[i])) continue;
      cv::line(*canvas, to_pixel(x[i - 1], s.y[i - 1]), to_pixel(x[i], s.y[i]), s.color, 2, cv::LINE_AA);
    }
    const int lx = box.x + box.width + 10;
    cv::line(*canvas, cv::Point(lx, legend_y - 4), cv::Point(lx + 20, legend_y - 4), s.color, 2);
    cv::putText(*canvas, s.label, cv::Point(lx + 26, legend_y), cv::FONT_HERSHEY_SIMPLEX, 0.4, black);
    legend_y += 18;
  }
}

}  // namespace

cv::Mat DrawLinePlot(const std::vector<double>& x, const std::vector<PlotPanel>& panels,
                     const LinePlotOptions& options) {
  for (const PlotPanel& panel : panels) {
    for (const PlotSeries& s : panel.series) {
      if (s.y.size() != x.size()) {
        throw std::invalid_argument("DrawLinePlot: series '" + s.label + "' has " + std::to_string(s.y.size()) +
                                    " values for " + std::to_string(x.size()) + " x");
      }
    }
  }
  const int height = std::max<int>(1, static_cast<int>(panels.size())) * options.panel_height;
  cv::Mat canvas(height, options.width, CV_8UC3, cv::Scalar(255, 255, 255));
  double x_low = x.empty() ? 0.0 : *std::min_element(x.begin(), x.end());
  double x_high = x.empty() ? 1.0 : *std::max_element(x.begin(), x.end());
  if (x_high - x_low < 1e-12) x_high = x_low + 1.0;
  for (size_t k = 0; k < panels.size(); ++k) {
    const cv::Rect box(kLeft, static_cast<int>(k) * options.panel_height + kTop, options.width - kLeft - kRight,
                       options.panel_height - kTop - kBottom);
    DrawPanel(x, x_low, x_high, panels[k], &canvas, box);
    cv::putText(canvas, Tick(x_low), cv::Point(box.x, box.y + box.height + 16), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
    cv::putText(canvas, Tick(x_high) + " " + options.x_label,
                cv::Point(box.x + box.width - 60, box.y + box.height + 16), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
  }
  return canvas;
}

}  // namespace polyfit
