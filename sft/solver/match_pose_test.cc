#include "sft/solver/match_pose.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "sft/camera/test_camera.h"

namespace polyfit {
namespace {

// A 20 cm square sheet at 0.6 m, n by n vertices, bent by `bend` (metres of
// sag at its centre; 0: planar, as a sheet's template).
void Sheet(int n, double bend, Eigen::Matrix3Xd* vertices, Eigen::Matrix3Xi* faces) {
  vertices->resize(3, n * n);
  faces->resize(3, 2 * (n - 1) * (n - 1));
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double x = -0.1 + 0.2 * j / (n - 1), y = -0.1 + 0.2 * i / (n - 1);
      vertices->col(i * n + j) = Eigen::Vector3d(x, y, 0.6 + bend * (1.0 - 100.0 * (x * x + y * y)));
    }
  }
  int f = 0;
  for (int i = 0; i + 1 < n; ++i) {
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j, b = a + 1, c = a + n, d = c + 1;
      faces->col(f++) = Eigen::Vector3i(a, b, d);
      faces->col(f++) = Eigen::Vector3i(a, d, c);
    }
  }
}

// `count` matches of random surface points seen after the motion (R, t),
// with Gaussian pixel noise; a fraction `outliers` of them anywhere in the
// image.
std::vector<FeatureMatch> Matches(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices,
                                  const Eigen::Matrix3Xi& faces, const Eigen::Matrix3d& rotation,
                                  const Eigen::Vector3d& translation, int count, double outliers, double noise_px,
                                  int* num_true = nullptr) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> face(0, static_cast<int>(faces.cols()) - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  std::vector<FeatureMatch> matches;
  for (int i = 0; i < count; ++i) {
    FeatureMatch m;
    m.face = face(rng);
    double a = unit(rng), b = unit(rng);
    if (a + b > 1.0) a = 1.0 - a, b = 1.0 - b;
    m.barycentric = Eigen::Vector3d(1.0 - a - b, a, b);
    m.pixel = camera.Project(rotation * m.PointOn(vertices, faces) + translation) + Eigen::Vector2d(noise(rng), noise(rng));
    if (unit(rng) < outliers) {
      m.pixel = Eigen::Vector2d(camera.width * unit(rng), camera.height * unit(rng));
    } else if (num_true != nullptr) {
      ++*num_true;
    }
    matches.push_back(m);
  }
  return matches;
}

double AngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180.0 / M_PI;
}

// The motion of a sheet that has moved 12 cm sideways, 10 cm back and
// turned 35 degrees: far beyond what a photometric solve from its last
// pose reaches.
void ExpectPoseFound(double bend) {
  Eigen::Matrix3Xd vertices;
  Eigen::Matrix3Xi faces;
  Sheet(9, bend, &vertices, &faces);
  const Eigen::Matrix3d rotation =
      (Eigen::AngleAxisd(0.6, Eigen::Vector3d(0.3, 1.0, 0.2).normalized())).toRotationMatrix();
  // About the sheet's centre, so that it stays in view.
  const Eigen::Vector3d centre(0.0, 0.0, 0.6);
  const Eigen::Vector3d translation = centre + Eigen::Vector3d(0.12, -0.03, 0.1) - rotation * centre;
  const PinholeCamera camera = TestCamera();
  int num_true = 0;
  const std::vector<FeatureMatch> matches =
      Matches(camera, vertices, faces, rotation, translation, 80, 0.4, 0.5, &num_true);
  MatchPose pose;
  ASSERT_TRUE(PoseFromMatches(camera, vertices, faces, matches, MatchPoseOptions(), &pose));
  EXPECT_LT(AngleDeg(pose.rotation, rotation), 1.5);
  EXPECT_LT((pose.translation + pose.rotation * centre - translation - rotation * centre).norm(), 0.005);
  // Every true match (0.5 px noise against a 4 px threshold), and at most
  // a few outliers that happen to land near the truth.
  EXPECT_GE(static_cast<int>(pose.inliers.size()), num_true);
  EXPECT_LE(static_cast<int>(pose.inliers.size()), num_true + 2);
  EXPECT_LT(pose.median_error_px, 1.0);
}

TEST(PoseFromMatchesTest, FindsAPlanarSheetsMotionAmongOutliers) { ExpectPoseFound(0.0); }

TEST(PoseFromMatchesTest, FindsABentSheetsMotionAmongOutliers) { ExpectPoseFound(0.03); }

TEST(PoseFromMatchesTest, NoPoseFromTooFewOrDisagreeingMatches) {
  Eigen::Matrix3Xd vertices;
  Eigen::Matrix3Xi faces;
  Sheet(5, 0.02, &vertices, &faces);
  const PinholeCamera camera = TestCamera();
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  MatchPose pose;
  pose.translation = Eigen::Vector3d(1.0, 2.0, 3.0);
  // Five exact matches: below the minimum.
  EXPECT_FALSE(PoseFromMatches(camera, vertices, faces,
                               Matches(camera, vertices, faces, identity, Eigen::Vector3d::Zero(), 5, 0.0, 0.0),
                               MatchPoseOptions(), &pose));
  // Pixels that no motion explains.
  EXPECT_FALSE(PoseFromMatches(camera, vertices, faces,
                               Matches(camera, vertices, faces, identity, Eigen::Vector3d::Zero(), 60, 1.0, 0.0),
                               MatchPoseOptions(), &pose));
  std::vector<FeatureMatch> bad =
      Matches(camera, vertices, faces, identity, Eigen::Vector3d::Zero(), 20, 0.0, 0.0);
  bad[3].pixel.x() = std::nan("");
  EXPECT_FALSE(PoseFromMatches(camera, vertices, faces, bad, MatchPoseOptions(), &pose));
  EXPECT_EQ(pose.translation, Eigen::Vector3d(1.0, 2.0, 3.0));  // untouched
}

}  // namespace
}  // namespace polyfit
