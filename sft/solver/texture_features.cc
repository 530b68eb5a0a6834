#include "sft/solver/texture_features.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <tuple>
#include <utility>

#include <Eigen/Dense>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace polyfit {
namespace {

cv::Mat Grey8(const cv::Mat& rgb) {
  cv::Mat grey, out;
  cv::cvtColor(rgb, grey, cv::COLOR_RGB2GRAY);
  grey.convertTo(out, CV_8U, 255.0);
  return out;
}

// Faces by the cells of a grid over the view that their triangles
// overlap, to find the face under a point.
class FaceLocator {
 public:
  FaceLocator(const Eigen::Matrix2Xd& corners, const Eigen::VectorXd& depths) : corners_(corners), depths_(depths) {
    const int num_faces = static_cast<int>(corners.cols() / 3);
    cells_ = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(num_faces))));
    cell_faces_.resize(static_cast<size_t>(cells_) * cells_);
    if (num_faces == 0) return;  // nothing is located
    lo_ = corners.rowwise().minCoeff();
    hi_ = corners.rowwise().maxCoeff();
    for (int f = 0; f < num_faces; ++f) {
      Eigen::Vector2d a = corners.col(3 * f), b = a;
      for (int k = 1; k < 3; ++k) {
        a = a.cwiseMin(corners.col(3 * f + k));
        b = b.cwiseMax(corners.col(3 * f + k));
      }
      const Eigen::Vector2i c0 = Cell(a), c1 = Cell(b);
      for (int y = c0.y(); y <= c1.y(); ++y) {
        for (int x = c0.x(); x <= c1.x(); ++x) cell_faces_[static_cast<size_t>(y) * cells_ + x].push_back(f);
      }
    }
  }

  // The face whose triangle holds p (the nearest, with depths), and its
  // barycentric coordinates; false when none does.
  bool Locate(const Eigen::Vector2d& p, int* face, Eigen::Vector3d* barycentric) const {
    if ((p.array() < lo_.array()).any() || (p.array() > hi_.array()).any()) return false;
    const Eigen::Vector2i c = Cell(p);
    double nearest = std::numeric_limits<double>::infinity();
    bool found = false;
    for (int f : cell_faces_[static_cast<size_t>(c.y()) * cells_ + c.x()]) {
      const Eigen::Vector2d a = corners_.col(3 * f), b = corners_.col(3 * f + 1), d = corners_.col(3 * f + 2);
      const double area = (b - a).x() * (d - a).y() - (b - a).y() * (d - a).x();
      if (std::abs(area) < 1e-300) continue;
      const double l1 = ((p - a).x() * (d - a).y() - (p - a).y() * (d - a).x()) / area;
      const double l2 = ((b - a).x() * (p - a).y() - (b - a).y() * (p - a).x()) / area;
      const double l0 = 1.0 - l1 - l2;
      constexpr double kSlack = -1e-9;
      if (!(l0 >= kSlack && l1 >= kSlack && l2 >= kSlack)) continue;
      const double depth =
          depths_.size() > 0 ? l0 * depths_[3 * f] + l1 * depths_[3 * f + 1] + l2 * depths_[3 * f + 2] : 0.0;
      if (found && !(depth < nearest)) continue;
      found = true;
      nearest = depth;
      *face = f;
      *barycentric = Eigen::Vector3d(l0, l1, l2);
    }
    return found;
  }

 private:
  Eigen::Vector2i Cell(const Eigen::Vector2d& p) const {
    const Eigen::Vector2d span = (hi_ - lo_).cwiseMax(1e-12);
    const Eigen::Vector2d s = (p - lo_).cwiseQuotient(span) * cells_;
    return Eigen::Vector2i(std::clamp(static_cast<int>(s.x()), 0, cells_ - 1),
                           std::clamp(static_cast<int>(s.y()), 0, cells_ - 1));
  }

  const Eigen::Matrix2Xd& corners_;
  const Eigen::VectorXd& depths_;
  int cells_ = 1;
  Eigen::Vector2d lo_ = Eigen::Vector2d::Zero(), hi_ = Eigen::Vector2d::Zero();
  std::vector<std::vector<int>> cell_faces_;
};

// Keypoints and their descriptors, in an order that depends on the image
// only: OpenCV's detection runs in parallel and may list them in any order,
// which would change the solver's sums, and a lost frame's outcome, from
// run to run.
void DetectKeypoints(cv::SIFT& sift, const cv::Mat& grey, const cv::Mat& mask, std::vector<cv::KeyPoint>* keypoints,
                     cv::Mat* descriptors) {
  sift.detect(grey, *keypoints, mask.empty() ? cv::noArray() : cv::InputArray(mask));
  std::sort(keypoints->begin(), keypoints->end(), [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    return std::make_tuple(a.pt.y, a.pt.x, a.size, a.angle, a.response, a.octave) <
           std::make_tuple(b.pt.y, b.pt.x, b.size, b.angle, b.response, b.octave);
  });
  sift.compute(grey, *keypoints, *descriptors);
}

// The keypoints of `grey` (the view, or its mirror image with `mirrored`)
// that lie on the surface, appended to `surface` and `view_points` (in the
// view's pixels); returns their descriptors (a row each, in that order).
cv::Mat LocatedKeypoints(cv::SIFT& sift, const cv::Mat& grey, const cv::Mat& mask, const FaceLocator& locator,
                         bool mirrored, std::vector<FeatureMatch>* surface, std::vector<Eigen::Vector2d>* view_points) {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  DetectKeypoints(sift, grey, mask, &keypoints, &descriptors);
  std::vector<int> kept;
  for (size_t k = 0; k < keypoints.size(); ++k) {
    const double x = mirrored ? grey.cols - 1 - keypoints[k].pt.x : keypoints[k].pt.x;
    const Eigen::Vector2d pixel(x, keypoints[k].pt.y);
    FeatureMatch point;
    if (!locator.Locate(pixel, &point.face, &point.barycentric)) continue;
    surface->push_back(point);
    view_points->push_back(pixel);
    kept.push_back(static_cast<int>(k));
  }
  cv::Mat out(static_cast<int>(kept.size()), descriptors.cols, descriptors.type());
  for (size_t k = 0; k < kept.size(); ++k) descriptors.row(kept[k]).copyTo(out.row(static_cast<int>(k)));
  return out;
}

}  // namespace

std::string TextureFeatureOptions::Validate() const {
  if (max_texture_keypoints < 1 || max_frame_keypoints < 1) return "keypoint counts must be >= 1";
  if (!(ratio > 0.0 && ratio <= 1.0)) return "ratio must be in (0, 1]";
  if (neighbours < 3) return "neighbours must be >= 3 (an affine map needs three points)";
  if (!(tolerance_px > 0.0) || !(relative_tolerance >= 0.0)) return "tolerances must be > 0";
  if (min_matches < 0) return "min_matches must be >= 0";
  return "";
}

TextureFeatures::TextureFeatures(const TextureFeatureOptions& options, const cv::Mat& view, const cv::Mat& view_mask,
                                 const Eigen::Matrix2Xd& corner_pixels, const Eigen::VectorXd& corner_depths)
    : options_(options) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("TextureFeatureOptions: " + error);
  if (view.empty() || view.type() != CV_32FC3) {
    throw std::invalid_argument("TextureFeatures: the view must be RGB CV_32FC3");
  }
  if (corner_pixels.cols() % 3 != 0 || (corner_depths.size() > 0 && corner_depths.size() != corner_pixels.cols())) {
    throw std::invalid_argument("TextureFeatures: corners must be given per face corner (2 by 3 #F, depths 3 #F)");
  }
  cv::Mat mask;
  if (!view_mask.empty()) {
    if (view_mask.size() != view.size())
      throw std::invalid_argument("TextureFeatures: the mask's size is not the view's");
    cv::compare(view_mask, 0.5, mask, cv::CMP_GT);
  }
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create(options.max_texture_keypoints);
  const FaceLocator locator(corner_pixels, corner_depths);
  const cv::Mat grey = Grey8(view);
  descriptors_ = LocatedKeypoints(*sift, grey, mask, locator, false, &surface_, &view_points_);
  distinct_ = descriptors_.rows;
  if (options.mirrored) {
    cv::Mat flipped, flipped_mask;
    cv::flip(grey, flipped, 1);
    if (!mask.empty()) cv::flip(mask, flipped_mask, 1);
    mirrored_descriptors_ = LocatedKeypoints(*sift, flipped, flipped_mask, locator, true, &surface_, &view_points_);
    // SIFT places a pattern and its mirror image a pixel or two apart.
    constexpr double kSamePlacePx = 3.0;
    for (size_t k = descriptors_.rows; k < view_points_.size(); ++k) {
      const auto near = [&](const Eigen::Vector2d& p) {
        return (p - view_points_[k]).squaredNorm() <= kSamePlacePx * kSamePlacePx;
      };
      distinct_ += std::none_of(view_points_.begin(), view_points_.begin() + descriptors_.rows, near);
    }
  }
}

std::vector<FeatureMatch> TextureFeatures::Match(const cv::Mat& frame, const cv::Mat& mask) const {
  if (surface_.empty() || frame.empty()) return {};
  cv::Mat detect_mask;
  if (!mask.empty()) {
    cv::Mat inside;
    cv::compare(mask, 0.5, inside, cv::CMP_GT);
    if (cv::countNonZero(inside) == 0) return {};
    // A keypoint's support reaches past the outline it sits on.
    cv::dilate(inside, detect_mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(9, 9)));
  }
  // Only the mask's surroundings are searched (the pyramid of the whole
  // frame costs as much again for nothing), with a margin for the
  // detector's own border.
  cv::Rect region(0, 0, frame.cols, frame.rows);
  if (!detect_mask.empty()) {
    constexpr int kMargin = 16;
    const cv::Rect box = cv::boundingRect(detect_mask);
    region = cv::Rect(box.x - kMargin, box.y - kMargin, box.width + 2 * kMargin, box.height + 2 * kMargin) & region;
  }
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create(options_.max_frame_keypoints);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  DetectKeypoints(*sift, Grey8(frame(region)), detect_mask.empty() ? cv::Mat() : cv::Mat(detect_mask(region)),
                  &keypoints, &descriptors);
  if (keypoints.empty()) return {};
  for (cv::KeyPoint& k : keypoints) k.pt += cv::Point2f(static_cast<float>(region.x), static_cast<float>(region.y));
  // Per frame keypoint, its nearest texture keypoint that passes the ratio
  // test among the view's and, apart (a symmetric pattern's two
  // descriptors would fail each other's test), among the mirror image's;
  // the nearer of the two.
  std::vector<int> nearest(keypoints.size(), -1);
  std::vector<float> nearest_distance(keypoints.size(), 0.0f);
  auto match_set = [&](const cv::Mat& set, int offset) {
    if (set.rows == 0) return;
    std::vector<std::vector<cv::DMatch>> knn;
    cv::BFMatcher(cv::NORM_L2).knnMatch(descriptors, set, knn, 2);
    for (const std::vector<cv::DMatch>& m : knn) {
      if (m.empty()) continue;
      if (m.size() == 2 && !(m[0].distance < options_.ratio * m[1].distance)) continue;
      const int q = m[0].queryIdx;
      if (nearest[q] < 0 || m[0].distance < nearest_distance[q]) {
        nearest[q] = offset + m[0].trainIdx;
        nearest_distance[q] = m[0].distance;
      }
    }
  };
  match_set(descriptors_, 0);
  match_set(mirrored_descriptors_, descriptors_.rows);
  // The best frame keypoint per texture keypoint.
  std::vector<int> best(surface_.size(), -1);
  std::vector<float> best_distance(surface_.size(), 0.0f);
  for (size_t q = 0; q < keypoints.size(); ++q) {
    const int t = nearest[q];
    if (t < 0) continue;
    if (best[t] < 0 || nearest_distance[q] < best_distance[t]) {
      best[t] = static_cast<int>(q);
      best_distance[t] = nearest_distance[q];
    }
  }
  std::vector<int> texture_index;
  std::vector<Eigen::Vector2d> from, to;
  for (size_t t = 0; t < best.size(); ++t) {
    if (best[t] < 0) continue;
    texture_index.push_back(static_cast<int>(t));
    from.push_back(view_points_[t]);
    to.emplace_back(keypoints[best[t]].pt.x, keypoints[best[t]].pt.y);
  }
  if (static_cast<int>(from.size()) <= options_.neighbours) return {};
  const std::vector<bool> keep =
      ConsistentMatches(from, to, options_.neighbours, options_.tolerance_px, options_.relative_tolerance);
  std::vector<FeatureMatch> matches;
  for (size_t k = 0; k < keep.size(); ++k) {
    if (!keep[k]) continue;
    FeatureMatch m = surface_[texture_index[k]];
    m.pixel = to[k];
    matches.push_back(m);
  }
  if (static_cast<int>(matches.size()) < options_.min_matches) return {};
  return matches;
}

constexpr int kMaxRounds = 5;

std::vector<bool> ConsistentMatches(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to,
                                    int neighbours, double tolerance_px, double relative_tolerance) {
  const int n = static_cast<int>(from.size());
  std::vector<bool> keep(n, true);
  if (n <= neighbours) return std::vector<bool>(n, false);
  // Each match's K nearest others in `from`, by brute force (a few
  // thousand at most).
  std::vector<std::vector<int>> nearest(n);
  std::vector<std::pair<double, int>> order(n);
  const int candidates = std::min(2 * neighbours, n - 1);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) order[j] = {(from[j] - from[i]).squaredNorm(), j};
    order[i].first = std::numeric_limits<double>::infinity();
    std::partial_sort(order.begin(), order.begin() + candidates, order.end());
    for (int k = 0; k < candidates; ++k) nearest[i].push_back(order[k].second);
  }
  // Rounds until nothing changes (at most a few): each fits only the
  // neighbours the last kept, so that outliers among them (clustered, from
  // a repeated pattern) do not condemn a good match. 2K candidates are kept
  // per match so that K remain after rejections.
  for (int round = 0; round < kMaxRounds; ++round) {
    const std::vector<bool> trusted = keep;
    for (int i = 0; i < n; ++i) {
      Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
      Eigen::Matrix<double, 3, 2> atb = Eigen::Matrix<double, 3, 2>::Zero();
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      int used = 0;
      std::vector<int> group;
      for (int j : nearest[i]) {
        if (round > 0 && !trusted[j]) continue;
        group.push_back(j);
        if (static_cast<int>(group.size()) == neighbours) break;
      }
      if (static_cast<int>(group.size()) < 3) {
        keep[i] = false;
        continue;
      }
      // Centred on this match's `from` for conditioning.
      for (int j : group) {
        const Eigen::Vector3d a((from[j] - from[i]).x(), (from[j] - from[i]).y(), 1.0);
        ata += a * a.transpose();
        atb += a * to[j].transpose();
        mean += to[j];
        ++used;
      }
      mean /= used;
      const Eigen::FullPivLU<Eigen::Matrix3d> lu(ata);
      if (lu.rank() < 3) {
        keep[i] = false;
        continue;
      }
      const Eigen::Matrix<double, 3, 2> affine = lu.solve(atb);
      const Eigen::Vector2d predicted = affine.row(2).transpose();  // at from[i]: offset 0
      double spread = 0.0;
      for (int j : group) spread += (to[j] - mean).squaredNorm();
      spread = std::sqrt(spread / used);
      keep[i] = (predicted - to[i]).norm() <= std::max(tolerance_px, relative_tolerance * spread);
    }
    if (keep == trusted) break;
  }
  return keep;
}

}  // namespace polyfit
