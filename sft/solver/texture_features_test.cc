#include "sft/solver/texture_features.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace polyfit {
namespace {

// Matches under one affine map, a tenth of them moved far off: the check
// drops those and keeps the rest.
TEST(ConsistentMatchesTest, DropsMatchesTheirNeighboursDisagreeWith) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> coordinate(0.0, 200.0), offset(30.0, 80.0);
  Eigen::Matrix2d a;
  a << 0.9, -0.3, 0.2, 0.6;
  const Eigen::Vector2d t(40.0, -10.0);
  std::vector<Eigen::Vector2d> from, to;
  std::vector<bool> outlier;
  for (int k = 0; k < 200; ++k) {
    from.emplace_back(coordinate(rng), coordinate(rng));
    to.push_back(a * from.back() + t);
    outlier.push_back(k % 10 == 0);
    if (outlier.back()) to.back() += Eigen::Vector2d(offset(rng), -offset(rng));
  }
  const std::vector<bool> keep = ConsistentMatches(from, to, 8, 3.0, 0.15);
  int kept_inliers = 0, kept_outliers = 0;
  for (size_t k = 0; k < keep.size(); ++k) (outlier[k] ? kept_outliers : kept_inliers) += keep[k];
  EXPECT_EQ(kept_outliers, 0);
  EXPECT_GE(kept_inliers, 175);  // of 180
  // Too few to judge: nothing kept.
  EXPECT_EQ(ConsistentMatches({from.begin(), from.begin() + 5}, {to.begin(), to.begin() + 5}, 8, 3.0, 0.15),
            std::vector<bool>(5, false));
}

// Blobs of random colours, blurred: texture with corners at every scale.
cv::Mat RandomTexture(int size, unsigned seed) {
  cv::Mat image(size, size, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  cv::RNG rng(seed);
  for (int k = 0; k < 400; ++k) {
    const cv::Point centre(rng.uniform(0, size), rng.uniform(0, size));
    const cv::Scalar colour(rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0));
    if (k % 2 == 0) {
      cv::circle(image, centre, rng.uniform(3, 14), colour, cv::FILLED, cv::LINE_AA);
    } else {
      cv::rectangle(image, centre, centre + cv::Point(rng.uniform(4, 20), rng.uniform(3, 9)), colour, cv::FILLED);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.7);
  return image;
}

// A square seen as two triangles fills the view: faces (0, 1, 2) and
// (0, 2, 3) over its corners, 2 by 6 per face corner.
Eigen::Matrix2Xd SquareCorners(int size) {
  const double e = size - 1.0;
  Eigen::Matrix2Xd square(2, 4);
  square << 0.0, e, e, 0.0, 0.0, 0.0, e, e;
  const int faces[2][3] = {{0, 1, 2}, {0, 2, 3}};
  Eigen::Matrix2Xd corners(2, 6);
  for (int f = 0; f < 2; ++f)
    for (int k = 0; k < 3; ++k) corners.col(3 * f + k) = square.col(faces[f][k]);
  return corners;
}

// How many matches land within 1.5 px of where `affine` (2 by 3, view to
// frame) puts their surface point.
int MatchesWhereTheMapPutsThem(const std::vector<FeatureMatch>& matches, const Eigen::Matrix2Xd& corners,
                               const cv::Mat& affine) {
  Eigen::Matrix<double, 2, 3> m;
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = affine.at<double>(r, c);
  int within = 0;
  for (const FeatureMatch& match : matches) {
    EXPECT_GE(match.face, 0);
    EXPECT_LT(match.face, 2);
    EXPECT_NEAR(match.barycentric.sum(), 1.0, 1e-9);
    Eigen::Vector2d point = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) point += match.barycentric[k] * corners.col(3 * match.face + k);
    within += (match.pixel - (m.leftCols<2>() * point + m.col(2))).norm() < 1.5;
  }
  return within;
}

// The frame is the view turned, scaled and shifted (`mirrored`: seen from
// behind, its mirror image so moved). Returns the view-to-frame map.
cv::Mat WarpedFrame(const cv::Mat& view, bool mirrored, cv::Mat* frame) {
  cv::Mat affine = cv::getRotationMatrix2D(cv::Point2f(120.0f, 120.0f), 25.0, 0.8);
  affine.at<double>(0, 2) += 30.0;
  affine.at<double>(1, 2) += 15.0;
  if (mirrored) {  // x -> (cols - 1) - x first
    affine.at<double>(0, 2) += affine.at<double>(0, 0) * (view.cols - 1);
    affine.at<double>(1, 2) += affine.at<double>(1, 0) * (view.cols - 1);
    affine.at<double>(0, 0) = -affine.at<double>(0, 0);
    affine.at<double>(1, 0) = -affine.at<double>(1, 0);
  }
  cv::warpAffine(view, *frame, affine, cv::Size(320, 300), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                 cv::Scalar(0.2, 0.2, 0.2));
  return affine;
}

// Every match lands where the warp puts its surface point, within a pixel
// or so.
TEST(TextureFeaturesTest, MatchesAWarpedViewWhereTheWarpPutsTheSurface) {
  const cv::Mat view = RandomTexture(240, 7);
  const Eigen::Matrix2Xd corners = SquareCorners(240);
  const TextureFeatures features(TextureFeatureOptions(), view, cv::Mat(), corners, Eigen::VectorXd());
  ASSERT_GT(features.size(), 100);

  cv::Mat frame;
  const cv::Mat affine = WarpedFrame(view, false, &frame);
  const std::vector<FeatureMatch> matches = features.Match(frame, cv::Mat());
  ASSERT_GT(matches.size(), 60u);
  EXPECT_GE(MatchesWhereTheMapPutsThem(matches, corners, affine), static_cast<int>(0.95 * matches.size()));

  // The same matches, in the same order, every time (detection runs in
  // parallel).
  for (int repeat = 0; repeat < 3; ++repeat) {
    const std::vector<FeatureMatch> again = features.Match(frame, cv::Mat());
    ASSERT_EQ(again.size(), matches.size());
    for (size_t k = 0; k < again.size(); ++k) {
      EXPECT_EQ(again[k].face, matches[k].face);
      EXPECT_EQ(again[k].pixel, matches[k].pixel);
      EXPECT_EQ(again[k].barycentric, matches[k].barycentric);
    }
  }

  // An empty mask: no keypoints, no matches.
  EXPECT_TRUE(features.Match(frame, cv::Mat::zeros(frame.size(), CV_32F)).empty());
}

// The surface seen from behind (a flap turned over): its texture is the
// view's mirror image, which the mirrored keypoints find where the warp
// puts it and the view's alone barely match.
TEST(TextureFeaturesTest, FindsTheSurfaceSeenFromBehind) {
  const cv::Mat view = RandomTexture(240, 7);
  const Eigen::Matrix2Xd corners = SquareCorners(240);
  cv::Mat frame;
  const cv::Mat affine = WarpedFrame(view, true, &frame);

  const TextureFeatures both(TextureFeatureOptions(), view, cv::Mat(), corners, Eigen::VectorXd());
  const std::vector<FeatureMatch> matches = both.Match(frame, cv::Mat());
  ASSERT_GT(matches.size(), 60u);
  EXPECT_GE(MatchesWhereTheMapPutsThem(matches, corners, affine), static_cast<int>(0.95 * matches.size()));

  TextureFeatureOptions front_only;
  front_only.mirrored = false;
  const TextureFeatures front(front_only, view, cv::Mat(), corners, Eigen::VectorXd());
  EXPECT_LT(front.Match(frame, cv::Mat()).size(), matches.size() / 4);
}

// No faces (a template the camera does not see): keypoints are found
// but none lies on the surface, and nothing matches.
TEST(TextureFeaturesTest, NoFacesLocateNothing) {
  const cv::Mat view = RandomTexture(120, 3);
  const TextureFeatures features(TextureFeatureOptions(), view, cv::Mat(), Eigen::Matrix2Xd(2, 0), Eigen::VectorXd());
  EXPECT_EQ(features.size(), 0);
  EXPECT_TRUE(features.Match(view, cv::Mat()).empty());
}

TEST(TextureFeaturesTest, RejectsBadInput) {
  TextureFeatureOptions options;
  options.ratio = 1.5;
  EXPECT_FALSE(options.Validate().empty());
  const cv::Mat grey(10, 10, CV_8U, cv::Scalar(0));
  EXPECT_THROW(TextureFeatures(TextureFeatureOptions(), grey, cv::Mat(), Eigen::Matrix2Xd(2, 3), Eigen::VectorXd()),
               std::invalid_argument);
  const cv::Mat view(10, 10, CV_32FC3, cv::Scalar(0, 0, 0));
  EXPECT_THROW(TextureFeatures(TextureFeatureOptions(), view, cv::Mat(), Eigen::Matrix2Xd(2, 4), Eigen::VectorXd()),
               std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
