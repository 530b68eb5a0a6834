#include "sft/render/soft_rasterizer.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

namespace polyfit {
namespace {

// A smooth colourful texture (no flat texels, so derivatives are exercised).
cv::Mat SmoothTexture(int size) {
  cv::Mat texture(size, size, CV_32FC3);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      texture.at<cv::Vec3f>(y, x) = cv::Vec3f(0.5f + 0.4f * std::sin(0.3f * x), 0.5f + 0.4f * std::cos(0.25f * y),
                                              0.5f + 0.3f * std::sin(0.2f * (x + y)));
    }
  }
  return texture;
}

// A quad (two triangles) in front of a tilted third triangle that it
// partly hides.
ScreenMesh TestMesh() {
  ScreenMesh mesh;
  mesh.pixels.resize(2, 7);
  mesh.pixels << 4.3, 17.6, 18.2, 5.1, 9.4, 22.7, 12.2,  //
      5.2, 4.6, 16.8, 17.9, 9.1, 13.3, 21.4;
  mesh.depths.resize(7);
  mesh.depths << 1.0, 1.05, 1.1, 1.02, 1.3, 1.25, 1.2;
  mesh.faces.resize(3, 3);
  mesh.faces << 0, 0, 4,  //
      1, 2, 5,            //
      2, 3, 6;
  mesh.corner_texcoords.resize(2, 9);
  mesh.corner_texcoords << 0.1, 0.9, 0.9, 0.1, 0.9, 0.1, 0.2, 0.8, 0.5,  //
      0.1, 0.1, 0.9, 0.1, 0.9, 0.9, 0.2, 0.3, 0.9;
  mesh.depth_near = 0.9;
  mesh.depth_far = 1.5;
  mesh.boundary_edges = MeshBoundaryEdgeFlags(mesh.faces);
  return mesh;
}

constexpr int kWidth = 26, kHeight = 24;

TEST(SoftRasterizerTest, SilhouetteAndColourAreSoftRasCompositions) {
  SoftRasterizerOptions options;
  options.num_threads = 1;
  const cv::Mat texture = SmoothTexture(32);
  SoftRasterizer rasterizer(options, texture);
  SoftRenderOutput out;
  rasterizer.Render(TestMesh(), kWidth, kHeight, cv::Mat(), false, &out);
  // Deep inside the front quad the silhouette is 1 and the colour is the
  // quad's texture; far away it is background.
  EXPECT_NEAR(out.silhouette.at<float>(12, 8), 1.0f, 1e-4);
  EXPECT_NEAR(out.silhouette.at<float>(0, 25), 0.0f, 1e-6);
  EXPECT_EQ(out.color.at<cv::Vec3f>(0, 25), cv::Vec3f(0, 0, 0));
  // On the quad's shared diagonal the silhouette stays 1 (interior edges
  // are hard); on its outer edge a lone triangle covers half.
  EXPECT_NEAR(out.silhouette.at<float>(10, 10), 1.0f, 1e-4);
  ScreenMesh plain = TestMesh();
  plain.boundary_edges.clear();  // plain SoftRas: the diagonal dips to ~3/4
  SoftRenderOutput plain_out;
  rasterizer.Render(plain, kWidth, kHeight, cv::Mat(), false, &plain_out);
  EXPECT_LT(plain_out.silhouette.at<float>(10, 10), 0.9f);
  EXPECT_GT(out.num_covered_pixels, 150);
}

TEST(SoftRasterizerTest, GradientsMatchFiniteDifferences) {
  SoftRasterizerOptions options;
  options.num_threads = 1;
  options.gamma = 0.05;  // a soft z-blend, so depth derivatives are not negligible
  const cv::Mat texture = SmoothTexture(32);
  SoftRasterizer rasterizer(options, texture);
  cv::Mat background(kHeight, kWidth, CV_32FC3, cv::Scalar(0.2, 0.4, 0.6));
  const ScreenMesh mesh = TestMesh();
  SoftRenderOutput out;
  rasterizer.Render(mesh, kWidth, kHeight, background, true, &out);

  const double h = 1e-5;
  int checked = 0, large = 0, nonzero = 0;
  double max_error = 0.0;
  std::vector<double> errors;
  for (int vertex = 0; vertex < 7; ++vertex) {
    for (int var = 0; var < 3; ++var) {
      ScreenMesh plus = mesh, minus = mesh;
      if (var < 2) {
        plus.pixels(var, vertex) += h;
        minus.pixels(var, vertex) -= h;
      } else {
        plus.depths[vertex] += h;
        minus.depths[vertex] -= h;
      }
      SoftRenderOutput op, om;
      rasterizer.Render(plus, kWidth, kHeight, background, false, &op);
      rasterizer.Render(minus, kWidth, kHeight, background, false, &om);
      for (int y = 0; y < kHeight; ++y) {
        for (int x = 0; x < kWidth; ++x) {
          const int pixel = y * kWidth + x;
          float analytic[4] = {0, 0, 0, 0};
          for (int k = out.begin[pixel]; k < out.end[pixel]; ++k) {
            if (out.gradients[k].vertex != vertex) continue;
            for (int r = 0; r < 4; ++r) analytic[r] = out.gradients[k].d[r][var];
          }
          const cv::Vec3f cp = op.color.at<cv::Vec3f>(y, x), cm = om.color.at<cv::Vec3f>(y, x);
          const double numeric[4] = {(cp[0] - cm[0]) / (2 * h), (cp[1] - cm[1]) / (2 * h), (cp[2] - cm[2]) / (2 * h),
                                     (op.silhouette.at<float>(y, x) - om.silhouette.at<float>(y, x)) / (2 * h)};
          for (int r = 0; r < 4; ++r) {
            // Images are float: the differences carry ~1e-7 / h noise.
            const double error = std::abs(analytic[r] - numeric[r]);
            nonzero += std::abs(numeric[r]) > 1e-2;
            max_error = std::max(max_error, error);
            large += error > 2e-2 + 0.02 * std::abs(numeric[r]);
            ++checked;
          }
        }
      }
    }
  }
  // Kinks (the closest edge switching, bilinear texel borders) could make a
  // few finite differences meaningless; none are hit here.
  EXPECT_LT(large, checked / 500) << "max error " << max_error;
  EXPECT_GT(checked, 10000);
  EXPECT_GT(nonzero, 1000);  // the derivatives compared are not all zero
  // Measured: 52,416 derivatives, 3,884 of them above 1e-2, largest
  // difference 3e-3 (float images with h = 1e-5).
  EXPECT_LT(max_error, 1e-2);
}

TEST(SoftRasterizerTest, NearerSurfaceWinsTheBlend) {
  SoftRasterizerOptions options;
  options.gamma = 1e-3;
  cv::Mat red(4, 4, CV_32FC3, cv::Scalar(1, 0, 0)), unused;
  SoftRasterizer rasterizer(options, red);
  ScreenMesh mesh = TestMesh();
  mesh.corner_texcoords.setConstant(0.5);
  SoftRenderOutput out;
  rasterizer.Render(mesh, kWidth, kHeight, cv::Mat(), false, &out);
  // Where the quad hides the third triangle the colour is the texture's.
  EXPECT_NEAR(out.color.at<cv::Vec3f>(12, 14)[0], 1.0f, 1e-3);
}

}  // namespace
}  // namespace polyfit
