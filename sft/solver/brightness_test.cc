#include "sft/solver/brightness.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace polyfit {
namespace {

// A smooth random texture (CV_32FC3) in about [0.2, 0.8].
cv::Mat Texture(int w, int h) {
  cv::Mat t(h, w, CV_32FC3);
  cv::theRNG().state = 7;
  cv::randu(t, cv::Scalar::all(0.0), cv::Scalar::all(1.0));
  cv::GaussianBlur(t, t, cv::Size(0, 0), 2.0);
  t.convertTo(t, -1, 0.6 / 0.4, 0.2 - 0.6 * 0.3 / 0.4);  // every channel (a MatExpr's scalar reaches the first only)
  return t;
}

cv::Mat Affine(const cv::Mat& image, cv::Vec3f gain, cv::Vec3f bias) {
  cv::Mat out = image.clone();
  for (auto it = out.begin<cv::Vec3f>(); it != out.end<cv::Vec3f>(); ++it) {
    for (int c = 0; c < 3; ++c) (*it)[c] = gain[c] * (*it)[c] + bias[c];
  }
  return out;
}

TEST(Brightness, MatchesAPerChannelGainAndBiasEvenWhenTheRenderIsOffByAFewPixels) {
  const cv::Mat rendered = Texture(120, 90);
  const cv::Vec3f gain(1.3f, 0.8f, 1.1f), bias(0.1f, -0.05f, 0.0f);
  cv::Mat shifted;  // the surface 3 px right of where the render has it
  const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, 3, 0, 1, 0);
  cv::warpAffine(rendered, shifted, m, rendered.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  const cv::Mat observed = Affine(shifted, gain, bias);
  cv::Mat coverage(rendered.size(), CV_32F, cv::Scalar(0.0f));
  coverage(cv::Rect(10, 10, 100, 70)).setTo(1.0f);
  const Brightness b = MatchBrightness(rendered, coverage, observed, cv::Mat(), cv::Rect(0, 0, 120, 90));
  EXPECT_GT(b.correlation, 0.5);  // 3 px off a smooth texture
  cv::Mat noise(rendered.size(), CV_32FC3);
  cv::randu(noise, cv::Scalar::all(0.0), cv::Scalar::all(1.0));
  EXPECT_LT(std::abs(MatchBrightness(rendered, coverage, noise, cv::Mat(), cv::Rect(0, 0, 120, 90)).correlation), 0.1);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(b.gain[c], gain[c], 0.03 * gain[c]) << c;
    EXPECT_NEAR(b.bias[c], bias[c], 0.02) << c;
  }
  // Mapped back, the observed colours are the texture's again.
  const cv::Mat back = CompensateBrightness(Affine(rendered, gain, bias), b);
  EXPECT_LT(cv::norm(back(cv::Rect(10, 10, 100, 70)), rendered(cv::Rect(10, 10, 100, 70)), cv::NORM_INF), 0.03);
}

TEST(Brightness, PixelsOutsideTheCoverageOrTheMaskAreNotCounted) {
  const cv::Mat rendered = Texture(64, 64);
  cv::Mat observed = rendered.clone();
  observed(cv::Rect(0, 0, 32, 64)).setTo(cv::Scalar::all(1.0));  // background, bright
  cv::Mat coverage(rendered.size(), CV_32F, cv::Scalar(1.0f)), mask = coverage.clone();
  coverage(cv::Rect(0, 0, 16, 64)).setTo(0.0f);
  mask(cv::Rect(0, 0, 32, 64)).setTo(0.0f);
  const Brightness b = MatchBrightness(rendered, coverage, observed, mask, cv::Rect(0, 0, 64, 64));
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(b.gain[c], 1.0, 1e-4);
    EXPECT_NEAR(b.bias[c], 0.0, 1e-4);
  }
}

TEST(Brightness, TooFewPixelsOrNoContrastStaySafe) {
  const cv::Mat rendered = Texture(32, 32);
  cv::Mat coverage(rendered.size(), CV_32F, cv::Scalar(0.0f));
  coverage(cv::Rect(0, 0, 4, 4)).setTo(1.0f);  // 16 pixels
  Brightness b = MatchBrightness(rendered, coverage, rendered * 2.0, cv::Mat(), cv::Rect(0, 0, 32, 32));
  EXPECT_EQ(b.gain[0], 1.0);
  EXPECT_EQ(b.bias[0], 0.0);
  // A flat texture: the gain is undefined, so only the mean is matched.
  const cv::Mat flat(32, 32, CV_32FC3, cv::Scalar::all(0.5));
  coverage.setTo(1.0f);
  b = MatchBrightness(flat, coverage, flat + cv::Scalar::all(0.1), cv::Mat(), cv::Rect(0, 0, 32, 32));
  EXPECT_EQ(b.gain[1], 1.0);
  EXPECT_NEAR(b.bias[1], 0.1, 1e-6);
  EXPECT_TRUE(std::isfinite(CompensateBrightness(flat, b).at<cv::Vec3f>(3, 3)[1]));
}

}  // namespace
}  // namespace polyfit
