#include "sft/solver/flow_matches.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace polyfit {
namespace {

// 8-bit grey, what DIS reads.
cv::Mat Grey(const cv::Mat& image) {
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
  if (grey.depth() != CV_8U) grey.convertTo(grey, CV_8U, 255.0);
  return grey;
}

// The flow at a continuous pixel (centres at integers), bilinear, clamped
// to the image.
Eigen::Vector2d Sample(const cv::Mat& flow, const Eigen::Vector2d& p) {
  const double x = std::clamp(p.x(), 0.0, flow.cols - 1.0), y = std::clamp(p.y(), 0.0, flow.rows - 1.0);
  const int x0 = std::min(static_cast<int>(x), std::max(flow.cols - 2, 0));
  const int y0 = std::min(static_cast<int>(y), std::max(flow.rows - 2, 0));
  const int x1 = std::min(x0 + 1, flow.cols - 1), y1 = std::min(y0 + 1, flow.rows - 1);
  const double ax = x - x0, ay = y - y0;
  const auto at = [&](int r, int c) {
    const cv::Vec2f v = flow.at<cv::Vec2f>(r, c);
    return Eigen::Vector2d(v[0], v[1]);
  };
  return (1 - ay) * ((1 - ax) * at(y0, x0) + ax * at(y0, x1)) + ay * ((1 - ax) * at(y1, x0) + ax * at(y1, x1));
}

bool Inside(const cv::Mat& mask, const Eigen::Vector2d& p) {
  if (mask.empty()) return true;
  const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
  if (x < 0 || y < 0 || x >= mask.cols || y >= mask.rows) return false;
  return mask.depth() == CV_8U ? mask.at<unsigned char>(y, x) > 0 : mask.at<float>(y, x) > 0.5f;
}

}  // namespace

cv::Mat NearestDepth(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces) {
  cv::Mat depth(camera.height, camera.width, CV_32F, cv::Scalar(std::numeric_limits<float>::infinity()));
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    Eigen::Vector2d p[3];
    double inverse_z[3];
    bool in_front = true;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d& x = vertices.col(faces(k, f));
      in_front = in_front && x.z() > 0.0;
      if (!in_front) break;
      p[k] = camera.Project(x);
      inverse_z[k] = 1.0 / x.z();
    }
    if (!in_front) continue;
    const double area = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
    if (!(std::abs(area) > 1e-12)) continue;
    const int x_begin = std::max(0, static_cast<int>(std::ceil(std::min({p[0].x(), p[1].x(), p[2].x()}))));
    const int x_end = std::min(camera.width - 1, static_cast<int>(std::floor(std::max({p[0].x(), p[1].x(), p[2].x()}))));
    const int y_begin = std::max(0, static_cast<int>(std::ceil(std::min({p[0].y(), p[1].y(), p[2].y()}))));
    const int y_end = std::min(camera.height - 1, static_cast<int>(std::floor(std::max({p[0].y(), p[1].y(), p[2].y()}))));
    for (int y = y_begin; y <= y_end; ++y) {
      float* row = depth.ptr<float>(y);
      for (int x = x_begin; x <= x_end; ++x) {
        // Barycentric coordinates by edge functions; 1/z is affine in the
        // image, so the depth is perspective-correct.
        double b[3];
        bool inside = true;
        for (int k = 0; k < 3; ++k) {
          const Eigen::Vector2d& a = p[(k + 1) % 3];
          const Eigen::Vector2d& c = p[(k + 2) % 3];
          b[k] = ((c - a).x() * (y - a.y()) - (c - a).y() * (x - a.x())) / area;
          inside = inside && b[k] >= -1e-9;
        }
        if (!inside) continue;
        const float z = static_cast<float>(1.0 / (b[0] * inverse_z[0] + b[1] * inverse_z[1] + b[2] * inverse_z[2]));
        row[x] = std::min(row[x], z);
      }
    }
  }
  return depth;
}

std::vector<bool> VisibleVertices(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices,
                                  const Eigen::Matrix3Xi& faces, double depth_tolerance) {
  const cv::Mat depth = NearestDepth(camera, vertices, faces);
  std::vector<bool> visible(vertices.cols(), false);
  for (Eigen::Index v = 0; v < vertices.cols(); ++v) {
    if (!(vertices(2, v) > 0.0)) continue;
    const Eigen::Vector2d p = camera.Project(vertices.col(v));
    if (!p.allFinite()) continue;  // a non-finite vertex has no pixel
    const long x = std::lround(p.x()), y = std::lround(p.y());
    if (x < 0 || y < 0 || x >= camera.width || y >= camera.height) continue;
    visible[v] = vertices(2, v) <= depth.at<float>(static_cast<int>(y), static_cast<int>(x)) + depth_tolerance;
  }
  return visible;
}

std::vector<FeatureMatch> FlowMatches(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices,
                                      const Eigen::Matrix3Xi& faces, const cv::Mat& previous_image,
                                      const cv::Mat& image, const cv::Mat& previous_mask, const cv::Mat& mask,
                                      const FlowMatchOptions& options) {
  std::vector<FeatureMatch> matches;
  if (previous_image.empty() || image.empty() || previous_image.size() != image.size() || options.max_matches < 1) {
    return matches;
  }
  const std::vector<bool> visible = VisibleVertices(camera, vertices, faces, options.depth_tolerance);
  // Each vertex as a corner of its first face.
  std::vector<int> face_of(vertices.cols(), -1), corner_of(vertices.cols(), 0);
  for (Eigen::Index f = faces.cols() - 1; f >= 0; --f) {
    for (int k = 0; k < 3; ++k) {
      face_of[faces(k, f)] = static_cast<int>(f);
      corner_of[faces(k, f)] = k;
    }
  }
  std::vector<int> candidates;
  for (Eigen::Index v = 0; v < vertices.cols(); ++v) {
    if (visible[v] && face_of[v] >= 0 && Inside(previous_mask, camera.Project(vertices.col(v)))) {
      candidates.push_back(static_cast<int>(v));
    }
  }
  if (candidates.empty()) return matches;
  const cv::Mat from = Grey(previous_image), to = Grey(image);
  cv::Ptr<cv::DISOpticalFlow> dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
  cv::Mat forward, backward;
  dis->calc(from, to, forward);
  dis->calc(to, from, backward);
  const size_t stride = (candidates.size() + options.max_matches - 1) / options.max_matches;
  for (size_t i = 0; i < candidates.size(); i += stride) {
    const int v = candidates[i];
    const Eigen::Vector2d p = camera.Project(vertices.col(v));
    const Eigen::Vector2d f = Sample(forward, p);
    const Eigen::Vector2d q = p + f;
    if (q.x() < 0.0 || q.y() < 0.0 || q.x() > image.cols - 1.0 || q.y() > image.rows - 1.0) continue;
    if ((f + Sample(backward, q)).norm() > options.max_inconsistency_px || !Inside(mask, q)) continue;
    FeatureMatch m;
    m.face = face_of[v];
    m.barycentric = Eigen::Vector3d::Zero();
    m.barycentric[corner_of[v]] = 1.0;
    m.pixel = q;
    matches.push_back(m);
  }
  return matches;
}

}  // namespace polyfit
