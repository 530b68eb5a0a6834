#include "sft/solver/flow_matches.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "sft/camera/test_camera.h"

namespace polyfit {
namespace {

// An n by n grid of vertices over [x0, x0 + size] x [y0, y0 + size] at
// depth z, appended to `vertices` and `faces`.
void AddGrid(double x0, double y0, double size, double z, int n, Eigen::Matrix3Xd* vertices,
             Eigen::Matrix3Xi* faces) {
  const int first = static_cast<int>(vertices->cols());
  vertices->conservativeResize(3, first + n * n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      vertices->col(first + i * n + j) = Eigen::Vector3d(x0 + size * j / (n - 1), y0 + size * i / (n - 1), z);
    }
  }
  const int faces_before = static_cast<int>(faces->cols());
  faces->conservativeResize(3, faces_before + 2 * (n - 1) * (n - 1));
  int f = faces_before;
  for (int i = 0; i + 1 < n; ++i) {
    for (int j = 0; j + 1 < n; ++j) {
      const int a = first + i * n + j, b = a + 1, c = a + n, d = c + 1;
      faces->col(f++) = Eigen::Vector3i(a, b, d);
      faces->col(f++) = Eigen::Vector3i(a, d, c);
    }
  }
}

// Smooth random texture, RGB CV_32FC3 in [0, 1].
cv::Mat Texture(int width, int height) {
  cv::Mat noise(height, width, CV_32FC3);
  cv::RNG rng(3);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.0);
  cv::normalize(noise, noise, 0.0, 1.0, cv::NORM_MINMAX);
  return noise;
}

TEST(NearestDepthTest, TheNearerOfTwoOverlappingSheetsWinsPerspectiveCorrectly) {
  Eigen::Matrix3Xd vertices(3, 0);
  Eigen::Matrix3Xi faces(3, 0);
  AddGrid(-0.2, -0.2, 0.4, 1.0, 5, &vertices, &faces);  // far, large
  AddGrid(0.0, -0.1, 0.1, 0.8, 3, &vertices, &faces);   // near, small, over its right half
  const PinholeCamera camera = TestCamera();
  const cv::Mat depth = NearestDepth(camera, vertices, faces);
  const auto at = [&](const Eigen::Vector3d& x) {
    const Eigen::Vector2d p = camera.Project(x);
    return depth.at<float>(static_cast<int>(std::lround(p.y())), static_cast<int>(std::lround(p.x())));
  };
  EXPECT_NEAR(at({-0.1, 0.0, 1.0}), 1.0, 1e-5);  // only the far sheet
  EXPECT_NEAR(at({0.05, -0.05, 0.8}), 0.8, 1e-5);  // both: the near one
  EXPECT_TRUE(std::isinf(depth.at<float>(0, 0)));  // nothing
  // A slanted face: 1/z is affine in the image, z is not.
  Eigen::Matrix3Xd slanted(3, 3);
  slanted << -0.3, 0.3, 0.3, -0.2, -0.2, 0.2, 1.0, 3.0, 3.0;
  const cv::Mat slanted_depth = NearestDepth(camera, slanted, Eigen::Matrix3Xi(Eigen::Vector3i(0, 1, 2)));
  const Eigen::Vector2d p = camera.Project(slanted.rowwise().mean());  // the centroid's pixel: inside
  const Eigen::Vector3d ray((std::round(p.x()) - camera.cx) / camera.fx, (std::round(p.y()) - camera.cy) / camera.fy,
                            1.0);
  // The plane through the face: z = 1 + (x + 0.3) / 0.3 along the ray x = ray.x z.
  const double z = (1.0 + 1.0) / (1.0 - ray.x() / 0.3);
  EXPECT_NEAR(slanted_depth.at<float>(static_cast<int>(std::round(p.y())), static_cast<int>(std::round(p.x()))), z,
              1e-4);
}

TEST(FlowMatchesTest, VisibleVerticesFollowTheImagesShiftAndHiddenOnesGetNone) {
  Eigen::Matrix3Xd vertices(3, 0);
  Eigen::Matrix3Xi faces(3, 0);
  AddGrid(-0.2, -0.15, 0.3, 1.0, 13, &vertices, &faces);  // the sheet
  const int sheet = static_cast<int>(vertices.cols());
  AddGrid(-0.05, -0.05, 0.1, 0.9, 3, &vertices, &faces);  // a flap in front of part of it
  const PinholeCamera camera = TestCamera();
  const std::vector<bool> visible = VisibleVertices(camera, vertices, faces, 0.01);
  int hidden = 0;
  for (int v = 0; v < sheet; ++v) {
    const Eigen::Vector3d& x = vertices.col(v);
    // Behind the flap: its shadow on the sheet is |x|, |y| < 0.05 / 0.9.
    const bool behind = std::abs(x.x()) < 0.054 && std::abs(x.y()) < 0.054;
    if (behind) {
      EXPECT_FALSE(visible[v]) << v;
      ++hidden;
    }
  }
  EXPECT_GT(hidden, 0);
  for (int v = sheet; v < vertices.cols(); ++v) EXPECT_TRUE(visible[v]);

  // The image moves 6 px right and 4 px down between the frames.
  const cv::Mat before = Texture(camera.width, camera.height);
  cv::Mat after;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 6, 0, 1, 4);
  cv::warpAffine(before, after, shift, before.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  FlowMatchOptions options;
  options.depth_tolerance = 0.01;
  const std::vector<FeatureMatch> matches =
      FlowMatches(camera, vertices, faces, before, after, cv::Mat(), cv::Mat(), options);
  ASSERT_GT(matches.size(), 120u);
  for (const FeatureMatch& m : matches) {
    int v = -1;
    for (int k = 0; k < 3; ++k) {
      if (m.barycentric[k] == 1.0) v = faces(k, m.face);
    }
    ASSERT_GE(v, 0);
    EXPECT_TRUE(visible[v]);
    EXPECT_LT((m.pixel - camera.Project(vertices.col(v)) - Eigen::Vector2d(6.0, 4.0)).norm(), 0.5) << v;
  }

  // Masks: the frame's mask keeps only the targets inside it; max_matches
  // thins them evenly.
  cv::Mat left_half = cv::Mat::zeros(camera.height, camera.width, CV_32F);
  left_half(cv::Rect(0, 0, camera.width / 2, camera.height)).setTo(1.0f);
  for (const FeatureMatch& m : FlowMatches(camera, vertices, faces, before, after, cv::Mat(), left_half, options)) {
    EXPECT_LT(m.pixel.x(), camera.width / 2 + 0.5);
  }
  options.max_matches = 40;
  const size_t thinned = FlowMatches(camera, vertices, faces, before, after, cv::Mat(), cv::Mat(), options).size();
  EXPECT_LE(thinned, 40u);
  EXPECT_GT(thinned, 30u);
  // A non-finite vertex is neither visible nor matched.
  Eigen::Matrix3Xd broken = vertices;
  broken(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(VisibleVertices(camera, broken, faces, 0.01)[0]);
  for (const FeatureMatch& m : FlowMatches(camera, broken, faces, before, after, cv::Mat(), cv::Mat(), options)) {
    EXPECT_TRUE(m.pixel.allFinite());
  }
  // Nothing to carry: no matches, no crash.
  EXPECT_TRUE(FlowMatches(camera, vertices, faces, cv::Mat(), after, cv::Mat(), cv::Mat(), options).empty());
}

}  // namespace
}  // namespace polyfit
