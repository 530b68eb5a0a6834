// Jet fitting at the extremes users reach (CTest label "stress",
// docs/reliability.md): order 8 on near-minimal point counts, patches far
// from the origin and tiny, and weights 1e8 apart. Each must give finite
// frames and coefficients and either recover the surface to what double
// precision allows there or say why not by its flags.
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "polyfit/jet/jet_basis.h"
#include "polyfit/patch/jet_fit.h"

namespace polyfit {
namespace {

// z = f(x, y), a smooth quartic-ish bump, sampled at random (x, y) in
// [-1, 1]^2 times `span`, around `offset` (3 by count).
double Surface(double x, double y) { return 0.3 * x * x - 0.2 * x * y + 0.1 * y * y * y + 0.05 * std::sin(2 * x); }

Eigen::Matrix3Xd Sample(int count, double span, const Eigen::Vector3d& offset, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3Xd points(3, count);
  for (int i = 0; i < count; ++i) {
    const double x = u(rng), y = u(rng);
    points.col(i) = offset + span * Eigen::Vector3d(x, y, Surface(x, y));
  }
  return points;
}

bool Finite(const JetPatch& patch) {
  bool finite = patch.frame.rotation.allFinite() && patch.frame.translation.allFinite() &&
                std::isfinite(patch.frame.scale) && std::isfinite(patch.rms_residual);
  for (double c : patch.coefficients) finite = finite && std::isfinite(c);
  return finite;
}

// The fitted surface's largest height error at the samples (world units).
double MaxError(const JetPatch& patch, const Eigen::Matrix3Xd& points) {
  double worst = 0.0;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const Eigen::Vector3d p = patch.frame.PointToPatch(points.col(i));
    worst = std::max(worst, patch.frame.scale * std::abs(p.z() - patch.Height(p.x(), p.y())));
  }
  return worst;
}

TEST(JetFitStressTest, OrderEightOnNearMinimalPointCounts) {
  JetFitOptions options;
  options.order = 8;
  JetFitter fitter(options);
  const int needed = NumJetCoefficients(8);  // 45
  for (int count : {3, 10, needed - 1, needed, needed + 1, needed + 5}) {
    SCOPED_TRACE(count);
    const Eigen::Matrix3Xd points = Sample(count, 1.0, Eigen::Vector3d::Zero(), 7);
    const JetPatch patch = fitter.Fit(points);
    ASSERT_TRUE(Finite(patch));
    std::printf("order 8, %d points: order %d, %s, max error %.2e\n", count, patch.order,
                JetFitFlagsToString(patch.flags).c_str(), MaxError(patch, points));
    if (count < needed) {
      EXPECT_TRUE(patch.flags & kJetFitReducedOrder);
      EXPECT_LT(patch.order, 8);
    } else {
      EXPECT_EQ(patch.order, 8);
    }
    // As many coefficients as points or fewer: an interpolation, or a
    // least-squares fit of a smooth surface (the jet holds it to 1e-3).
    EXPECT_LT(MaxError(patch, points), count <= needed ? 1e-6 : 1e-3);
  }
}

TEST(JetFitStressTest, FarFromTheOriginAndTiny) {
  JetFitOptions options;
  options.order = 4;
  JetFitter fitter(options);
  struct Case {
    double span;
    double offset;
  };
  for (const Case c : {Case{1.0, 1e6}, Case{1e-6, 0.0}, Case{1e-6, 1e6}, Case{1e6, 0.0}}) {
    SCOPED_TRACE(std::to_string(c.span) + " at " + std::to_string(c.offset));
    const Eigen::Matrix3Xd points = Sample(200, c.span, Eigen::Vector3d::Constant(c.offset), 3);
    const JetPatch patch = fitter.Fit(points);
    ASSERT_TRUE(Finite(patch));
    EXPECT_FALSE(patch.flags & kJetFitDegenerate);
    // What double precision allows: the coordinates carry about 1e-16 of
    // their magnitude; the centred fit keeps the error relative to the
    // span unless the offset swamps the span (1e-6 at 1e6: 1e-10 absolute
    // rounding on a 1e-6 patch).
    const double rounding = 1e-16 * (std::abs(c.offset) + c.span);
    std::printf("span %g at %g: %s, max error %.2e (%.2e of the span)\n", c.span, c.offset,
                JetFitFlagsToString(patch.flags).c_str(), MaxError(patch, points), MaxError(patch, points) / c.span);
    EXPECT_LT(MaxError(patch, points), 0.05 * c.span + 1e3 * rounding);
  }
}

TEST(JetFitStressTest, WeightsEightOrdersApart) {
  JetFitOptions options;
  options.order = 4;
  JetFitter fitter(options);
  const Eigen::Matrix3Xd points = Sample(300, 1.0, Eigen::Vector3d::Zero(), 5);
  // Half the points weigh 1e8, half 1, and the light half is displaced:
  // the fit follows the heavy half as if alone.
  Eigen::Matrix3Xd moved = points;
  std::vector<double> weights(300);
  for (int i = 0; i < 300; ++i) {
    weights[i] = i % 2 == 0 ? 1e8 : 1.0;
    if (i % 2 == 1) moved(2, i) += 0.5;
  }
  const JetPatch patch = fitter.Fit(moved, weights.data());
  ASSERT_TRUE(Finite(patch));
  Eigen::Matrix3Xd heavy(3, 150);
  for (int i = 0; i < 150; ++i) heavy.col(i) = points.col(2 * i);
  const JetPatch alone = fitter.Fit(heavy);
  EXPECT_LT(MaxError(patch, heavy), MaxError(alone, heavy) + 1e-6);
  std::printf("weights 1e8 and 1: max error on the heavy half %.2e (fitted alone %.2e)\n", MaxError(patch, heavy),
              MaxError(alone, heavy));
  // And a weight of zero everywhere but three points: still defined.
  std::vector<double> sparse(300, 0.0);
  sparse[0] = sparse[1] = sparse[2] = 1e8;
  const JetPatch few = fitter.Fit(points, sparse.data());
  ASSERT_TRUE(Finite(few));
  std::printf("three points weighted, the rest 0: order %d, %s\n", few.order, JetFitFlagsToString(few.flags).c_str());
}

}  // namespace
}  // namespace polyfit
