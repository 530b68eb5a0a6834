#include "sft/synthetic/footage_imperfections.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "sft/render/mask_distance.h"

namespace polyfit {
namespace {

// A smooth random field in [-1, 1] (cubic upsampling of a coarse grid of
// `cell` pixels).
cv::Mat SmoothNoise(int width, int height, int cell, std::mt19937_64& rng) {
  cv::Mat coarse(height / cell + 2, width / cell + 2, CV_32F);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  for (int y = 0; y < coarse.rows; ++y) {
    for (int x = 0; x < coarse.cols; ++x) coarse.at<float>(y, x) = unit(rng);
  }
  cv::Mat field;
  cv::resize(coarse, field, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
  return cv::min(cv::max(field, -1.0f), 1.0f);
}

int Bounce(int position, int range) {
  if (range <= 0) return 0;
  const int period = 2 * range, p = position % period;
  return p <= range ? p : period - p;
}

}  // namespace

bool FootageImperfections::Any() const {
  return mask_offset != 0.0 || mask_ragged > 0.0 || mask_holes > 0 || gain_drift != 0.0 || bias_drift != 0.0 ||
         shading > 0.0 || blur > 0.0 || moving_background;
}

std::string FootageImperfections::Validate() const {
  if (!std::isfinite(mask_offset) || std::abs(mask_offset) > 50.0) return "mask_offset must be within +-50 px";
  if (!(mask_ragged >= 0.0 && mask_ragged <= 20.0)) return "mask_ragged must be in [0, 20] px";
  if (mask_holes < 0 || mask_holes > 100) return "mask_holes must be in [0, 100]";
  if (!(gain_drift > -1.0 && gain_drift <= 1.0)) return "gain_drift must be in (-1, 1]";
  if (!(std::abs(bias_drift) <= 0.5)) return "bias_drift must be within +-0.5";
  if (!(shading >= 0.0 && shading <= 1.0)) return "shading must be in [0, 1]";
  if (!(blur >= 0.0 && blur <= 10.0)) return "blur must be in [0, 10] px";
  return {};
}

FootageImperfections FootageImperfections::RealLike() {
  FootageImperfections f;
  f.mask_offset = 2.0;
  f.mask_ragged = 1.5;
  f.mask_holes = 2;
  f.gain_drift = 0.25;
  f.bias_drift = 0.05;
  f.shading = 0.3;
  f.blur = 0.8;
  f.moving_background = true;
  return f;
}

std::vector<float> FaceShading(const TriangleMesh& mesh, double shading) {
  const Eigen::Vector3d light = Eigen::Vector3d(-0.5, -0.6, -1.0).normalized();  // y down, camera at -z
  std::vector<float> factor(mesh.num_faces(), 1.0f);
  if (shading <= 0.0) return factor;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.col(mesh.faces(0, f)), b = mesh.vertices.col(mesh.faces(1, f)),
                          c = mesh.vertices.col(mesh.faces(2, f));
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() == 0.0) continue;
    n.normalize();
    if (n.dot(-(a + b + c) / 3.0) < 0.0) n = -n;  // the side the camera sees
    factor[f] = static_cast<float>(1.0 - shading + shading * std::max(0.0, n.dot(light)));
  }
  return factor;
}

cv::Mat MovingBackground(const cv::Mat& backdrop, int width, int height, int frame) {
  const int x = Bounce(2 * frame, backdrop.cols - width), y = Bounce(frame, backdrop.rows - height);
  return backdrop(cv::Rect(x, y, width, height)).clone();
}

void DegradeFrame(const FootageImperfections& f, double tau, cv::Mat* color) {
  const float gain = static_cast<float>(1.0 + f.gain_drift * std::sin(M_PI * tau));
  const float bias = static_cast<float>(f.bias_drift * std::sin(2.0 * M_PI * tau));
  if (gain != 1.0f || bias != 0.0f) {
    for (auto it = color->begin<cv::Vec3f>(); it != color->end<cv::Vec3f>(); ++it) {
      for (int ch = 0; ch < 3; ++ch) (*it)[ch] = std::clamp(gain * (*it)[ch] + bias, 0.0f, 1.0f);
    }
  }
  if (f.blur > 0.0) cv::GaussianBlur(*color, *color, cv::Size(0, 0), f.blur, f.blur, cv::BORDER_REPLICATE);
}

cv::Mat DegradeMask(const FootageImperfections& f, const cv::Mat& coverage, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  cv::Mat inside;
  // Half-covered pixels are inside, as a PNG of the coverage has them (128).
  cv::threshold(coverage, inside, 0.5 - 1e-6, 255.0, cv::THRESH_BINARY);
  inside.convertTo(inside, CV_8U);
  cv::Mat mask = inside / 255;
  mask.convertTo(mask, CV_32F);
  if (f.mask_offset != 0.0 || f.mask_ragged > 0.0) {
    const cv::Mat d = SignedBorderDistance(inside);
    const cv::Mat noise = SmoothNoise(coverage.cols, coverage.rows, 12, rng);
    for (int y = 0; y < d.rows; ++y) {
      for (int x = 0; x < d.cols; ++x) {
        const double reach = f.mask_offset + f.mask_ragged * noise.at<float>(y, x);
        mask.at<float>(y, x) = d.at<float>(y, x) < reach ? 1.0f : 0.0f;
      }
    }
  }
  if (f.mask_holes > 0) {
    std::vector<cv::Point> interior;
    cv::Mat eroded;
    cv::erode(inside, eroded, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(13, 13)));
    cv::findNonZero(eroded, interior);
    std::uniform_int_distribution<int> radius(2, 5);
    for (int k = 0; k < f.mask_holes && !interior.empty(); ++k) {
      const cv::Point centre = interior[std::uniform_int_distribution<size_t>(0, interior.size() - 1)(rng)];
      cv::circle(mask, centre, radius(rng), cv::Scalar(0.0f), cv::FILLED);
    }
  }
  return mask;
}

}  // namespace polyfit
