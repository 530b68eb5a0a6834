#include "polyfit/synthetic/patch_families.h"

#include <Eigen/LU>
#include <gtest/gtest.h>

namespace polyfit {
namespace {

TEST(SyntheticSurface, GradientMatchesFiniteDifferences) {
  std::mt19937_64 rng(1);
  for (SurfaceFamily f : {SurfaceFamily::kJet4, SurfaceFamily::kTrigonometric, SurfaceFamily::kGaussian,
                          SurfaceFamily::kBessel, SurfaceFamily::kSum}) {
    for (int trial = 0; trial < 20; ++trial) {
      const SyntheticSurface s = SyntheticSurface::Random(f, rng);
      const double u = std::uniform_real_distribution<double>(-1, 1)(rng);
      const double v = std::uniform_real_distribution<double>(-1, 1)(rng);
      const double h = 1e-6;
      const Eigen::Vector2d g = s.Gradient(u, v);
      EXPECT_NEAR(g.x(), (s.Height(u + h, v) - s.Height(u - h, v)) / (2 * h), 1e-6) << SurfaceFamilyName(f);
      EXPECT_NEAR(g.y(), (s.Height(u, v + h) - s.Height(u, v - h)) / (2 * h), 1e-6) << SurfaceFamilyName(f);
      EXPECT_TRUE(std::isfinite(s.Height(0, 0)));
    }
  }
}

TEST(SyntheticSurface, AmplitudesStayInTheirRanges) {
  std::mt19937_64 rng(2);
  for (int trial = 0; trial < 100; ++trial) {
    const SyntheticSurface s = SyntheticSurface::Random(SurfaceFamily::kTrigonometric, rng);
    for (double u : {-1.0, 0.0, 1.0}) EXPECT_LE(std::abs(s.Height(u, 0.3)), 0.5);
  }
}

TEST(SyntheticPatch, IsSeededAndLiesOnItsSurface) {
  SyntheticPatchOptions options;
  options.num_points = 50;
  const SyntheticPatchSet a = GenerateSyntheticPatchSet(options, 3, 42);
  const SyntheticPatchSet b = GenerateSyntheticPatchSet(options, 3, 42);
  EXPECT_EQ(a.points_in_world, b.points_in_world);
  EXPECT_EQ(a.offsets, (std::vector<int>{0, 50, 100, 150}));
  const SyntheticPatch& p = a.patches[1];
  EXPECT_EQ(p.points_in_world, p.surface_points_in_world);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d q = p.rotation.transpose() * (p.surface_points_in_world.col(i) - p.translation);
    EXPECT_NEAR(q.z(), p.surface.Height(q.x(), q.y()), 1e-12);
    EXPECT_LE(std::abs(q.x()), 1.0);
    EXPECT_NEAR(p.surface_normals_in_world.col(i).norm(), 1.0, 1e-12);
  }
  EXPECT_LE(p.translation.cwiseAbs().maxCoeff(), 5.0);
  EXPECT_NEAR(p.rotation.determinant(), 1.0, 1e-12);
}

TEST(SyntheticPatch, NoiseHasTheRequestedSpread) {
  SyntheticPatchOptions options;
  options.num_points = 20000;
  options.noise_sigma = 0.01;
  std::mt19937_64 rng(5);
  const SyntheticPatch p = GenerateSyntheticPatch(options, rng);
  const double rms =
      std::sqrt((p.points_in_world - p.surface_points_in_world).squaredNorm() / (3.0 * options.num_points));
  EXPECT_NEAR(rms, 0.01, 3e-4);
}

TEST(SurfaceFamily, ParsesNames) {
  EXPECT_EQ(ParseSurfaceFamily("bessel"), SurfaceFamily::kBessel);
  EXPECT_THROW(ParseSurfaceFamily("cubic"), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
