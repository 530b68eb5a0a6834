#include "sft/synthetic/footage_imperfections.h"

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "polyfit/util/scoped_temp_dir.h"
#include "sft/scene/scene.h"
#include "sft/synthetic/sheet_scene.h"

namespace polyfit {
namespace {

// Coverage of a disc of radius r (px) at the centre of a w x w image.
cv::Mat Disc(int w, double r) {
  cv::Mat coverage(w, w, CV_32F, cv::Scalar(0.0f));
  for (int y = 0; y < w; ++y) {
    for (int x = 0; x < w; ++x) {
      const double d = std::hypot(x - (w - 1) / 2.0, y - (w - 1) / 2.0);
      coverage.at<float>(y, x) = d < r ? 1.0f : 0.0f;
    }
  }
  return coverage;
}

TEST(FootageImperfections, AnOffsetGrowsOrShrinksTheMaskByThatManyPixels) {
  const cv::Mat coverage = Disc(128, 30.0);
  for (double offset : {-3.0, 3.0}) {
    FootageImperfections f;
    f.mask_offset = offset;
    const cv::Mat mask = DegradeMask(f, coverage, 1);
    const double area = cv::sum(mask)[0];
    const double expected = M_PI * (30.0 + offset) * (30.0 + offset);
    EXPECT_NEAR(area / expected, 1.0, 0.03) << "offset " << offset;
  }
}

TEST(FootageImperfections, ARaggedBorderKeepsTheAreaAndMovesTheBorderWithinItsReach) {
  const cv::Mat coverage = Disc(128, 30.0);
  FootageImperfections f;
  f.mask_ragged = 2.0;
  const cv::Mat mask = DegradeMask(f, coverage, 7);
  EXPECT_NEAR(cv::sum(mask)[0] / cv::sum(coverage)[0], 1.0, 0.05);
  int changed = 0;
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      if (mask.at<float>(y, x) == coverage.at<float>(y, x)) continue;
      ++changed;
      EXPECT_NEAR(std::hypot(x - 63.5, y - 63.5), 30.0, 3.0);  // within reach 2 of the border (+- a pixel)
    }
  }
  EXPECT_GT(changed, 20);
}

TEST(FootageImperfections, HolesArePunchedInsideTheMaskOnlyAndTheMaskIsBinary) {
  const cv::Mat coverage = Disc(128, 30.0);
  FootageImperfections f;
  f.mask_holes = 3;
  const cv::Mat mask = DegradeMask(f, coverage, 3);
  const double removed = cv::sum(coverage)[0] - cv::sum(mask)[0];
  EXPECT_GE(removed, 3 * 12.0);  // three discs of radius >= 2
  EXPECT_LE(removed, 3 * 90.0);  // of radius <= 5
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      const float m = mask.at<float>(y, x);
      ASSERT_TRUE(m == 0.0f || m == 1.0f);
      ASSERT_LE(m, coverage.at<float>(y, x));
    }
  }
  EXPECT_EQ(cv::sum(DegradeMask(f, coverage, 3) != mask)[0], 0.0);  // seeded
}

TEST(FootageImperfections, LightingDriftsByItsGainAndBias) {
  FootageImperfections f;
  f.gain_drift = 0.25;
  f.bias_drift = 0.05;
  for (double tau : {0.0, 0.25, 0.5}) {
    cv::Mat color(4, 4, CV_32FC3, cv::Scalar(0.4f, 0.4f, 0.4f));
    DegradeFrame(f, tau, &color);
    const double expected = (1.0 + 0.25 * std::sin(M_PI * tau)) * 0.4 + 0.05 * std::sin(2.0 * M_PI * tau);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(color.at<cv::Vec3f>(2, 2)[ch], expected, 1e-6) << tau;
  }
}

TEST(FootageImperfections, ShadingDarkensFacesByTheirAngleToTheLight) {
  TriangleMesh mesh;
  mesh.vertices.resize(3, 3);
  mesh.vertices << 0, 1, 0, 0, 0, 1, 1, 1, 1;  // a face at z = 1, facing the camera
  mesh.faces.resize(3, 1);
  mesh.faces << 0, 1, 2;
  const double n_dot_l = 1.0 / Eigen::Vector3d(-0.5, -0.6, -1.0).norm();
  EXPECT_NEAR(FaceShading(mesh, 0.3)[0], 0.7 + 0.3 * n_dot_l, 1e-6);
  EXPECT_EQ(FaceShading(mesh, 0.0)[0], 1.0f);
}

TEST(FootageImperfections, TheBackgroundMovesTwoPixelsRightAndOneDownPerFrame) {
  cv::Mat backdrop(80, 100, CV_32FC3);
  cv::randu(backdrop, 0.0f, 1.0f);
  const cv::Mat b0 = MovingBackground(backdrop, 64, 48, 0), b1 = MovingBackground(backdrop, 64, 48, 1);
  EXPECT_EQ(cv::norm(b1(cv::Rect(0, 0, 60, 46)), b0(cv::Rect(2, 1, 60, 46)), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(b1, b0, cv::NORM_INF), 0.1);
}

TEST(FootageImperfections, RealLikeIsValidAndOutOfRangeValuesAreNamed) {
  EXPECT_EQ(FootageImperfections::RealLike().Validate(), "");
  EXPECT_TRUE(FootageImperfections::RealLike().Any());
  EXPECT_FALSE(FootageImperfections().Any());
  FootageImperfections f;
  f.blur = -1.0;
  EXPECT_NE(f.Validate().find("blur"), std::string::npos);
  f = {};
  f.gain_drift = -1.0;
  EXPECT_NE(f.Validate().find("gain_drift"), std::string::npos);
  f = {};
  f.mask_offset = NAN;
  EXPECT_NE(f.Validate().find("mask_offset"), std::string::npos);
}

// A real-like scene records its camera (fy != fx, the principal point off
// centre) and its imperfections, loads, and its masks are larger than the
// sheet's by about the offset.
TEST(FootageImperfections, ARealLikeSceneRecordsItsCameraAndItsMasksAreGrown) {
  ScopedTempDir clean_dir("polyfit_clean"), real_dir("polyfit_real");
  SheetSceneOptions clean = SheetSceneOptions::Small(96, 6, 2);
  SheetSceneOptions real = clean;
  real.MakeRealLike();
  real.imperfections.mask_holes = 0;  // holes would blur the area count below
  ASSERT_EQ(real.Validate(), "");
  GenerateSheetScene(clean, clean_dir.path().string());
  GenerateSheetScene(real, real_dir.path().string());

  const nlohmann::json j = nlohmann::json::parse(std::ifstream(real_dir.path() / "scene.json"));
  EXPECT_NEAR(j["camera"]["fy"].get<double>(), 1.03 * real.focal_length, 1e-9);
  EXPECT_NEAR(j["camera"]["cx"].get<double>(), (real.width - 1) / 2.0 + 0.025 * real.width, 1e-9);
  EXPECT_EQ(j["generator"]["mask_ragged"].get<double>(), 1.5);
  EXPECT_NO_THROW(LoadScene(real_dir.path().string()));

  // A 2 px offset on a border of P px adds about 2 P pixels, beyond the
  // 3% that fy = 1.03 fx adds (the ragged border adds nothing on average).
  const cv::Mat clean_mask = cv::imread((clean_dir.path() / "masks/000000.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat real_mask = cv::imread((real_dir.path() / "masks/000000.png").string(), cv::IMREAD_GRAYSCALE);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(clean_mask > 127, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  ASSERT_EQ(contours.size(), 1u);
  const double perimeter = cv::arcLength(contours[0], true);
  const double clean_area = cv::countNonZero(clean_mask > 127), real_area = cv::countNonZero(real_mask > 127);
  const double fy_growth = (1.03 - 1.0) * clean_area;  // the taller projection
  EXPECT_NEAR(real_area - clean_area - fy_growth, 2.0 * perimeter, 0.35 * 2.0 * perimeter);
}

}  // namespace
}  // namespace polyfit
