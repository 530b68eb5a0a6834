#include "polyfit/eval/metrics.h"

#include <random>

#include <gtest/gtest.h>

#include "polyfit/eval/kd_tree.h"

namespace polyfit {
namespace {

TEST(KdTree3, MatchesBruteForce) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> g(0, 1);
  const Eigen::Matrix3Xd points = Eigen::Matrix3Xd::NullaryExpr(3, 2000, [&] { return g(rng); });
  const KdTree3 tree(points);
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d query(g(rng), g(rng), g(rng));
    double d2;
    const int nearest = tree.Nearest(query, &d2);
    int expected;
    const double e2 = (points.colwise() - query).colwise().squaredNorm().minCoeff(&expected);
    EXPECT_EQ(nearest, expected);
    EXPECT_DOUBLE_EQ(d2, e2);
  }
}

TEST(Chamfer, ShiftedGridAndSubset) {
  Eigen::Matrix3Xd a(3, 100);
  for (int i = 0; i < 100; ++i) a.col(i) = Eigen::Vector3d(i % 10, i / 10, 0);
  const Eigen::Matrix3Xd b = a.colwise() + Eigen::Vector3d(0, 0, 0.1);
  const ChamferDistance c = ComputeChamferDistance(a, b);
  EXPECT_NEAR(c.a_to_b, 0.01, 1e-14);
  EXPECT_NEAR(c.sum(), 0.02, 1e-14);
  // b a subset of a: b -> a is 0, a -> b is not.
  const ChamferDistance s = ComputeChamferDistance(a, a.leftCols(50));
  EXPECT_EQ(s.b_to_a, 0.0);
  EXPECT_NEAR(s.a_to_b, 50 * 1.0 / 100 * (1 + 4 + 9 + 16 + 25) / 5, 1e-12);
  EXPECT_THROW(ComputeChamferDistance(a, Eigen::Matrix3Xd(3, 0)), std::invalid_argument);
}

TEST(EvaluatePatchAgainstSurface, MeasuresDistanceToTheFittedSurface) {
  // Fitted: the plane z = 0.1 in a frame scaled by 2; truth: z = 0 tilted 30 degrees.
  JetPatch patch;
  patch.order = 1;
  patch.frame.scale = 2.0;
  patch.coefficients[0] = 0.05;
  const double angle = 30 * M_PI / 180;
  Eigen::Matrix3Xd points(3, 1), normals(3, 1);
  points.col(0) = Eigen::Vector3d(0.5, 0.2, 0.0);
  normals.col(0) = Eigen::Vector3d(std::sin(angle), 0, std::cos(angle));
  const SurfaceErrorAccumulator acc = EvaluatePatchAgainstSurface(patch, points, normals);
  EXPECT_NEAR(acc.height_rmse(), 0.1, 1e-12);
  EXPECT_NEAR(acc.normal_error_deg(), 30.0, 1e-10);
  // Normals are unoriented.
  const SurfaceErrorAccumulator flipped = EvaluatePatchAgainstSurface(patch, points, -normals);
  EXPECT_NEAR(flipped.normal_error_deg(), 30.0, 1e-10);
}

}  // namespace
}  // namespace polyfit
