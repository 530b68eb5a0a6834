#include "sft/render/soft_rasterizer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
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

TEST(SoftRasterizerTest, ARenderWithoutGradientsIsTheSameImage) {
  SoftRasterizerOptions options;
  options.num_threads = 2;
  options.gamma = 0.05;
  const cv::Mat texture = SmoothTexture(32);
  SoftRasterizer rasterizer(options, texture);
  const cv::Mat background(kHeight, kWidth, CV_32FC3, cv::Scalar(0.2, 0.4, 0.6));
  SoftRenderOutput with, without;
  rasterizer.Render(TestMesh(), kWidth, kHeight, background, true, &with);
  rasterizer.Render(TestMesh(), kWidth, kHeight, background, false, &without);
  EXPECT_EQ(cv::norm(with.color, without.color, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(with.silhouette, without.silhouette, cv::NORM_INF), 0.0);
  EXPECT_EQ(with.num_covered_pixels, without.num_covered_pixels);
  // Rendered again into the same output (its scratch reused), after another
  // mesh: the same image and gradients.
  const std::vector<VertexGradient> gradients = with.gradients;
  const std::vector<int> begin = with.begin;
  ScreenMesh moved = TestMesh();
  moved.pixels.array() += 3.0;
  rasterizer.Render(moved, kWidth, kHeight, background, true, &with);
  rasterizer.Render(TestMesh(), kWidth, kHeight, background, true, &with);
  EXPECT_EQ(cv::norm(with.color, without.color, cv::NORM_INF), 0.0);
  EXPECT_EQ(with.begin, begin);
  ASSERT_EQ(with.gradients.size(), gradients.size());
  for (size_t i = 0; i < gradients.size(); ++i) {
    EXPECT_EQ(with.gradients[i].vertex, gradients[i].vertex);
    for (int r = 0; r < 4; ++r) {
      for (int k = 0; k < 3; ++k) EXPECT_EQ(with.gradients[i].d[r][k], gradients[i].d[r][k]);
    }
  }
}

// Every colour and silhouette derivative of TestMesh's render against
// central finite differences: the count compared, how many are not small,
// how many disagree and by how much at most.
struct FiniteDifferenceCheck {
  int checked = 0, nonzero = 0, large = 0;
  double max_error = 0.0;
};

FiniteDifferenceCheck CheckAgainstFiniteDifferences(const SoftRasterizerOptions& options, const cv::Mat& texture) {
  SoftRasterizer rasterizer(options, texture);
  cv::Mat background(kHeight, kWidth, CV_32FC3, cv::Scalar(0.2, 0.4, 0.6));
  ScreenMesh mesh = TestMesh();
  // The mip levels are constants of the derivatives: held at the mesh's.
  if (options.mipmap) {
    FaceMipLevels(mesh, texture.cols, texture.rows, rasterizer.num_mip_levels(), options.mip_level_bias,
                  &mesh.face_mip_levels);
  }
  SoftRenderOutput out;
  rasterizer.Render(mesh, kWidth, kHeight, background, true, &out);
  const double h = 1e-5;
  FiniteDifferenceCheck check;
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
            check.nonzero += std::abs(numeric[r]) > 1e-2;
            check.max_error = std::max(check.max_error, error);
            check.large += error > 2e-2 + 0.02 * std::abs(numeric[r]);
            ++check.checked;
          }
        }
      }
    }
  }
  return check;
}

TEST(SoftRasterizerTest, GradientsMatchFiniteDifferences) {
  SoftRasterizerOptions options;
  options.num_threads = 1;
  options.gamma = 0.05;  // a soft z-blend, so depth derivatives are not negligible
  const FiniteDifferenceCheck check = CheckAgainstFiniteDifferences(options, SmoothTexture(32));
  // Kinks (the closest edge switching, bilinear texel borders) could make a
  // few finite differences meaningless; none are hit here.
  EXPECT_LT(check.large, check.checked / 500) << "max error " << check.max_error;
  EXPECT_GT(check.checked, 10000);
  EXPECT_GT(check.nonzero, 1000);  // the derivatives compared are not all zero
  // Measured: 52,416 derivatives, 3,884 of them above 1e-2, largest
  // difference 3e-3 (float images with h = 1e-5).
  EXPECT_LT(check.max_error, 1e-2);
}

// The depth-sorted composite and the mip-mapped texture (a texture four
// times finer than the test mesh's pixels, so that faces read between
// levels): exact derivatives too, with the depth order and the levels
// held (they are piecewise constant and constants).
TEST(SoftRasterizerTest, OverCompositingAndMipLevelsMatchFiniteDifferences) {
  for (const Compositing compositing : {Compositing::kOver, Compositing::kOverBackground, Compositing::kSoftZ}) {
    for (const bool mipmap : {false, true}) {
      if (compositing == Compositing::kSoftZ && !mipmap) continue;  // the test above
      SoftRasterizerOptions options;
      options.num_threads = 1;
      options.gamma = 0.05;
      options.compositing = compositing;
      options.mipmap = mipmap;
      const FiniteDifferenceCheck check = CheckAgainstFiniteDifferences(options, SmoothTexture(128));
      const int variant = 2 * static_cast<int>(compositing) + mipmap;
      EXPECT_LT(check.large, check.checked / 500) << variant << " max error " << check.max_error;
      EXPECT_GT(check.nonzero, 1000) << variant;
      EXPECT_LT(check.max_error, 2e-2) << variant;
    }
  }
}

// Over the background, a pixel shows its coverage's share of the surface
// and the rest of the background, as a camera's pixel over an object's
// rim does: I = S C + (1 - S) B for a surface of one colour C, at every
// pixel (the rim's and the seams' between triangles alike). kOver shows C
// wherever the surface reaches.
TEST(SoftRasterizerTest, OverTheBackgroundARimPixelMixesByItsCoverage) {
  const cv::Mat texture(8, 8, CV_32FC3, cv::Scalar(0.9, 0.5, 0.1));
  cv::Mat background(kHeight, kWidth, CV_32FC3);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) background.at<cv::Vec3f>(y, x) = cv::Vec3f(0.01f * x, 0.02f * y, 0.3f);
  }
  for (const Compositing compositing : {Compositing::kOverBackground, Compositing::kOver}) {
    SoftRasterizerOptions options;
    options.compositing = compositing;
    SoftRenderOutput out;
    SoftRasterizer(options, texture).Render(TestMesh(), kWidth, kHeight, background, false, &out);
    double max_error = 0.0;
    int rim = 0;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const double s = out.silhouette.at<float>(y, x);
        rim += s > 0.05 && s < 0.95;
        const cv::Vec3f b = background.at<cv::Vec3f>(y, x), c = out.color.at<cv::Vec3f>(y, x);
        for (int ch = 0; ch < 3; ++ch) {
          const double expected = compositing == Compositing::kOver && s > 0.0 ? texture.at<cv::Vec3f>(0, 0)[ch]
                                                                               : s * texture.at<cv::Vec3f>(0, 0)[ch] +
                                                                                     (1.0 - s) * b[ch];
          max_error = std::max(max_error, std::abs(c[ch] - expected));
        }
      }
    }
    EXPECT_GT(rim, 20);
    EXPECT_LT(max_error, 1e-5) << static_cast<int>(compositing);
  }
}

// The hand-derived triangle terms against Ceres' jets: the same image and
// the same gradients, pixel by pixel and vertex by vertex, with and
// without the depth gradient and with every edge soft, and composited over
// a mip-mapped texture.
TEST(SoftRasterizerTest, TheHandDerivedDerivativesAreTheJets) {
  const cv::Mat texture = SmoothTexture(32);
  cv::Mat background(kHeight, kWidth, CV_32FC3, cv::Scalar(0.2, 0.4, 0.6));
  for (int variant = 0; variant < 6; ++variant) {
    const bool depth_gradient = variant % 2 == 0, flags = variant % 4 < 2;
    {
      SoftRasterizerOptions options;
      options.num_threads = 1;
      options.gamma = 0.05;
      options.depth_gradient = depth_gradient;
      // The last two: depth-sorted compositing over a mip-mapped texture.
      options.compositing = variant >= 4 ? Compositing::kOver : Compositing::kSoftZ;
      options.mipmap = variant >= 4;
      ScreenMesh mesh = TestMesh();
      if (!flags) mesh.boundary_edges.clear();
      const cv::Mat fine = variant >= 4 ? SmoothTexture(128) : texture;  // faces between mip levels
      SoftRenderOutput jets, hand;
      options.analytic_derivatives = false;
      SoftRasterizer(options, fine).Render(mesh, kWidth, kHeight, background, true, &jets);
      options.analytic_derivatives = true;
      SoftRasterizer(options, fine).Render(mesh, kWidth, kHeight, background, true, &hand);
      EXPECT_EQ(cv::norm(jets.color, hand.color, cv::NORM_INF), 0.0);
      EXPECT_EQ(cv::norm(jets.silhouette, hand.silhouette, cv::NORM_INF), 0.0);
      ASSERT_EQ(jets.begin, hand.begin);
      ASSERT_EQ(jets.end, hand.end);
      ASSERT_EQ(jets.gradients.size(), hand.gradients.size());
      double max_error = 0.0, max_value = 0.0;
      for (size_t k = 0; k < jets.gradients.size(); ++k) {
        ASSERT_EQ(jets.gradients[k].vertex, hand.gradients[k].vertex);
        for (int r = 0; r < 4; ++r) {
          for (int c = 0; c < 3; ++c) {
            const double a = jets.gradients[k].d[r][c], b = hand.gradients[k].d[r][c];
            max_error = std::max(max_error, std::abs(a - b) / (1.0 + std::abs(a)));
            max_value = std::max(max_value, std::abs(a));
          }
        }
      }
      EXPECT_GT(jets.gradients.size(), 300u);
      EXPECT_GT(max_value, 0.1);
      EXPECT_LT(max_error, 1e-6) << variant;  // float storage
    }
  }
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

// A cloth folded over itself: two layers with the same outline, the
// hidden one `gap` metres behind at 0.4 m, the depth range the solver
// takes for a 0.3 m template there. The front layer samples the texture's
// red half, the hidden one its blue half.
ScreenMesh FoldedLayers(double gap) {
  ScreenMesh mesh;
  mesh.pixels.resize(2, 8);
  mesh.pixels << 4, 20, 20, 4, 4, 20, 20, 4,  //
      4, 4, 20, 20, 4, 4, 20, 20;
  mesh.depths.resize(8);
  mesh.depths << 0.4, 0.4, 0.4, 0.4, 0.4 + gap, 0.4 + gap, 0.4 + gap, 0.4 + gap;
  mesh.faces.resize(3, 4);
  mesh.faces << 0, 0, 4, 4,  //
      1, 2, 5, 6,            //
      2, 3, 6, 7;
  // Each layer spans its half of the texture (u in [0.05, 0.45] or
  // [0.55, 0.95]), corners in the faces' order.
  mesh.corner_texcoords.resize(2, 12);
  const double u[4] = {0.05, 0.45, 0.45, 0.05}, v[4] = {0.1, 0.1, 0.9, 0.9};
  for (int f = 0; f < 4; ++f) {
    for (int c = 0; c < 3; ++c) {
      const int corner = mesh.faces(c, f) % 4;
      mesh.corner_texcoords.col(3 * f + c) = Eigen::Vector2d(u[corner] + (f < 2 ? 0.0 : 0.5), v[corner]);
    }
  }
  mesh.depth_near = 0.1;
  mesh.depth_far = 0.4 + gap + 0.3;
  mesh.boundary_edges = MeshBoundaryEdgeFlags(mesh.faces);
  return mesh;
}

// Red ramps along v on the left half, blue on the right: each layer's
// colour moves with it, and shows which layer a pixel sees.
cv::Mat RedBlueTexture() {
  cv::Mat texture(32, 32, CV_32FC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < 32; ++y) {
    const float ramp = 0.5f + 0.4f * std::sin(0.2f * y);
    for (int x = 0; x < 32; ++x) texture.at<cv::Vec3f>(y, x) = x < 16 ? cv::Vec3f(ramp, 0, 0) : cv::Vec3f(0, 0, ramp);
  }
  return texture;
}

// The hidden layer's share of a pixel's colour, and the largest colour
// derivative with respect to a hidden and to a front vertex's pixel
// position over the layers' interior: the photometric pull that drags a
// layer across the image.
struct FoldRender {
  double hidden_share = 0.0, hidden_derivative = 0.0, front_derivative = 0.0;
  double hidden_depth_derivative = 0.0;  // the colour's, with respect to a hidden vertex's depth
};

FoldRender RenderFold(double gap, double gamma, bool depth_gradient = true) {
  SoftRasterizerOptions options;
  options.gamma = gamma;
  options.depth_gradient = depth_gradient;
  options.num_threads = 1;
  const cv::Mat texture = RedBlueTexture();
  SoftRenderOutput out;
  SoftRasterizer(options, texture).Render(FoldedLayers(gap), kWidth, kHeight, cv::Mat(), true, &out);
  FoldRender r;
  const cv::Vec3f centre = out.color.at<cv::Vec3f>(12, 12);
  r.hidden_share = centre[2] / (centre[0] + centre[2]);
  for (int y = 7; y <= 17; ++y) {
    for (int x = 7; x <= 17; ++x) {
      const int pixel = y * kWidth + x;
      for (int k = out.begin[pixel]; k < out.end[pixel]; ++k) {
        double largest = 0.0;
        for (int c = 0; c < 3; ++c) {
          for (int v = 0; v < 2; ++v) largest = std::max(largest, std::abs(double(out.gradients[k].d[c][v])));
        }
        double& slot = out.gradients[k].vertex >= 4 ? r.hidden_derivative : r.front_derivative;
        slot = std::max(slot, largest);
        for (int c = 0; c < 3 && out.gradients[k].vertex >= 4; ++c) {
          r.hidden_depth_derivative = std::max(r.hidden_depth_derivative, std::abs(double(out.gradients[k].d[c][2])));
        }
      }
    }
  }
  return r;
}

TEST(SoftRasterizerTest, AFoldOverShowsItsNearLayerOnceTheSoftnessIsInMetres) {
  const double gap = 5e-3, near = 0.1, far = 0.4 + gap + 0.3;
  // gamma 0.01 of this depth range is 14 mm at 0.4 m: a hidden layer 5 mm
  // behind still gives 41% of the colour and pulls on its vertices.
  const FoldRender soft = RenderFold(gap, 1e-2);
  EXPECT_GT(soft.hidden_share, 0.35);
  EXPECT_GT(soft.hidden_derivative, 0.1 * soft.front_derivative);
  // A softness of 1 mm: the near layer wins, the hidden one gets
  // exp(-5) / (1 + exp(-5)) of the colour and almost no pull.
  const FoldRender metric = RenderFold(gap, SoftnessToGamma(1e-3, 0.4, near, far));
  EXPECT_NEAR(metric.hidden_share, std::exp(-5.0) / (1.0 + std::exp(-5.0)), 1e-3);
  EXPECT_LT(metric.hidden_derivative, 0.02 * metric.front_derivative);
  EXPECT_GT(metric.front_derivative, 0.0);
  // The softness's meaning: a layer 1 mm behind weighs e times less
  // (exactly so to first order in the gap).
  const double one = RenderFold(1e-3, SoftnessToGamma(1e-3, 0.4, near, 0.4 + 1e-3 + 0.3)).hidden_share;
  EXPECT_NEAR(one, 1.0 / (1.0 + std::exp(1.0)), 3e-3);
}

// Composited in depth order, the near layer hides the far one whatever the
// gap (a soft z-blend lets a layer within its softness show through), and
// the hidden layer gets no pull at all; where the near layer's soft edge
// only partly covers a pixel, the far layer shows by the rest.
TEST(SoftRasterizerTest, OverCompositingShowsTheNearLayerAndNothingOfTheHiddenOne) {
  for (const double gap : {1e-4, 5e-3, 0.05}) {
    SoftRasterizerOptions options;
    options.compositing = Compositing::kOver;
    options.num_threads = 1;
    SoftRenderOutput out;
    SoftRasterizer(options, RedBlueTexture()).Render(FoldedLayers(gap), kWidth, kHeight, cv::Mat(), true, &out);
    const cv::Vec3f centre = out.color.at<cv::Vec3f>(12, 12);
    EXPECT_EQ(centre[2], 0.0f) << gap;
    EXPECT_GT(centre[0], 0.1f) << gap;
    double hidden = 0.0, front = 0.0;
    for (int y = 7; y <= 17; ++y) {
      for (int x = 7; x <= 17; ++x) {
        const int pixel = y * kWidth + x;
        for (int k = out.begin[pixel]; k < out.end[pixel]; ++k) {
          for (int c = 0; c < 3; ++c) {
            for (int v = 0; v < 3; ++v) {
              (out.gradients[k].vertex >= 4 ? hidden : front) += std::abs(double(out.gradients[k].d[c][v]));
            }
          }
        }
      }
    }
    EXPECT_EQ(hidden, 0.0) << gap;
    EXPECT_GT(front, 0.1) << gap;
  }
  // The near layer's left edge moved to x = 7.33, over the hidden layer's
  // interior: pixel x = 7 mixes the two by the near layer's coverage D
  // there, and the background (black) does not enter.
  ScreenMesh shifted = FoldedLayers(5e-3);
  for (int v = 0; v < 4; ++v) shifted.pixels(0, v) += 3.33;
  shifted.boundary_edges = MeshBoundaryEdgeFlags(shifted.faces);
  SoftRasterizerOptions options;
  options.compositing = Compositing::kOver;
  SoftRenderOutput out;
  SoftRasterizer(options, RedBlueTexture()).Render(shifted, kWidth, kHeight, cv::Mat(), false, &out);
  const cv::Vec3f edge = out.color.at<cv::Vec3f>(12, 7);
  const double d = 1.0 / (1.0 + std::exp(0.33 * 0.33 / options.sigma));  // sigmoid(-d^2 / sigma)
  const double red = edge[0], blue = edge[2];
  // Colour shares, against coverage shares: the ramps differ by layer.
  const cv::Vec3f red_alone = out.color.at<cv::Vec3f>(12, 12), blue_alone = out.color.at<cv::Vec3f>(12, 5);
  EXPECT_NEAR(red / red_alone[0], d, 0.02);
  EXPECT_NEAR(blue / blue_alone[2], 1.0 - d, 0.02);
  EXPECT_GT(red, 0.05);
  EXPECT_GT(blue, 0.05);
}

// A texture of one-texel stripes read at 3.8 texels per pixel: a single
// level aliases (each pixel lands on a stripe or between), the mip levels
// give the stripes' mean; FaceMipLevels gives that footprint's level.
TEST(SoftRasterizerTest, MipLevelsFollowTheFootprintAndRemoveAliasing) {
  cv::Mat stripes(64, 64, CV_32FC3);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) stripes.at<cv::Vec3f>(y, x) = cv::Vec3f::all(x % 2 == 0 ? 1.0f : 0.0f);
  }
  ScreenMesh quad;
  quad.pixels.resize(2, 4);
  quad.pixels << 2.3, 19.3, 19.3, 2.3,  // 17 pixels across for 64 texels
      2.3, 2.3, 19.3, 19.3;
  quad.depths = Eigen::VectorXd::Ones(4);
  quad.faces.resize(3, 2);
  quad.faces << 0, 0,  //
      1, 2,            //
      2, 3;
  quad.corner_texcoords.resize(2, 6);
  quad.corner_texcoords << 0, 1, 1, 0, 1, 0,  //
      1, 1, 0, 1, 0, 0;
  quad.boundary_edges = MeshBoundaryEdgeFlags(quad.faces);
  std::vector<float> levels;
  FaceMipLevels(quad, 64, 64, 7, -0.25, &levels);
  ASSERT_EQ(levels.size(), 2u);
  EXPECT_NEAR(levels[0], std::log2(64.0 / 17.0) - 0.25, 1e-5);
  EXPECT_NEAR(levels[1], std::log2(64.0 / 17.0) - 0.25, 1e-5);
  FaceMipLevels(quad, 64, 64, 7, 0.0, &levels);
  EXPECT_NEAR(levels[0], std::log2(64.0 / 17.0), 1e-5);
  ScreenMesh edge_on = quad;
  edge_on.pixels.row(1).setConstant(5.0);  // no area: the coarsest
  FaceMipLevels(edge_on, 64, 64, 7, 0.0, &levels);
  EXPECT_EQ(levels[0], 6.0f);

  double single_spread = 0.0, mip_spread = 0.0;
  for (const bool mipmap : {false, true}) {
    SoftRasterizerOptions options;
    options.mipmap = mipmap;
    SoftRasterizer rasterizer(options, stripes);
    EXPECT_EQ(rasterizer.num_mip_levels(), mipmap ? 6 : 1);  // 64 down to 2
    SoftRenderOutput out;
    rasterizer.Render(quad, 22, 22, cv::Mat(), false, &out);
    double lo = 1.0, hi = 0.0;
    for (int y = 5; y <= 15; ++y) {
      for (int x = 5; x <= 15; ++x) {
        lo = std::min(lo, double(out.color.at<cv::Vec3f>(y, x)[0]));
        hi = std::max(hi, double(out.color.at<cv::Vec3f>(y, x)[0]));
      }
    }
    (mipmap ? mip_spread : single_spread) = hi - lo;
    if (mipmap) {
      EXPECT_NEAR(out.color.at<cv::Vec3f>(10, 10)[0], 0.5, 0.02);
    }
  }
  EXPECT_GT(single_spread, 0.5);
  EXPECT_LT(mip_spread, 0.05);
}

// The hard blend's weights change fast with depth: a hidden layer 5 mm
// behind, at 1 mm of softness, still has a colour derivative of several
// units per metre of its depth (the photometric term could pull it in
// front). Without the depth gradient that pull is gone, and the image
// is the same.
TEST(SoftRasterizerTest, WithoutTheDepthGradientAHiddenLayerGetsNoDepthPull) {
  const double gamma = SoftnessToGamma(1e-3, 0.4, 0.1, 0.705);
  const FoldRender exact = RenderFold(5e-3, gamma, true), frozen = RenderFold(5e-3, gamma, false);
  EXPECT_GT(exact.hidden_depth_derivative, 1.0);
  EXPECT_LT(frozen.hidden_depth_derivative, 1e-3 * exact.hidden_depth_derivative);
  EXPECT_EQ(frozen.hidden_share, exact.hidden_share);
  EXPECT_GT(frozen.front_derivative, 0.5 * exact.front_derivative);
}

// A sheet of n by n quads, `cell` pixels each, from (x0, y0), at depth 1.
ScreenMesh GridSheet(int n, double cell, double x0, double y0) {
  ScreenMesh mesh;
  const int side = n + 1;
  mesh.pixels.resize(2, side * side);
  mesh.depths = Eigen::VectorXd::Ones(side * side);
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) mesh.pixels.col(i * side + j) = Eigen::Vector2d(x0 + cell * j, y0 + cell * i);
  }
  mesh.faces.resize(3, 2 * n * n);
  for (int i = 0, f = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const int a = i * side + j, b = a + 1, c = a + side + 1, d = a + side;
      mesh.faces.col(f++) = Eigen::Vector3i(a, b, c);
      mesh.faces.col(f++) = Eigen::Vector3i(a, c, d);
    }
  }
  mesh.corner_texcoords = Eigen::Matrix2Xd::Constant(2, 3 * mesh.faces.cols(), 0.5);
  mesh.depth_near = 0.5;
  mesh.depth_far = 2.0;
  mesh.boundary_edges = MeshBoundaryEdgeFlags(mesh.faces);
  return mesh;
}

// Beyond a boundary vertex, each of the triangles that meet there covers a
// pixel by sigmoid(-d^2 / sigma), and the silhouette unites them
// (1 - prod(1 - D_j)): outside a mesh's rim the soft silhouette adds more
// than it takes away inside, so it reads larger than the mesh. The excess
// shrinks with sigma (what PolySftOptions::finest_sigma relies on); a
// camera's box-filtered pixels add none.
TEST(SoftRasterizerTest, TheSoftSilhouetteReadsLargerThanTheMeshByLessAtASmallerSigma) {
  const cv::Mat texture = SmoothTexture(8);
  // 40 by 40 pixels in quads of 2.5 pixels, off the pixel grid.
  const ScreenMesh sheet = GridSheet(16, 2.5, 10.3, 10.6);
  const double area = 40.0 * 40.0;
  double excess[3];
  const double sigmas[3] = {0.5, 0.25, 0.06};
  for (int k = 0; k < 3; ++k) {
    SoftRasterizerOptions options;
    options.sigma = sigmas[k];
    options.num_threads = 1;
    SoftRenderOutput out;
    SoftRasterizer(options, texture).Render(sheet, 64, 64, cv::Mat(), false, &out);
    excess[k] = (cv::sum(out.silhouette)[0] - area) / area;
  }
  EXPECT_GT(excess[0], excess[1]);
  EXPECT_GT(excess[1], excess[2]);
  EXPECT_GT(excess[0], 0.0);
  EXPECT_LT(std::abs(excess[2]), 0.25 * excess[0]);
  std::printf("silhouette area over the mesh's: sigma 0.5 %+.3f%%, 0.25 %+.3f%%, 0.06 %+.3f%%\n", 100 * excess[0],
              100 * excess[1], 100 * excess[2]);
}

}  // namespace
}  // namespace polyfit
