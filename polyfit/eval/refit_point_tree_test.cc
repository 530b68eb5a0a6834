#include "polyfit/eval/refit_point_tree.h"

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace polyfit {
namespace {

void ExpectMatchesBruteForce(const RefitPointTree& tree, const Eigen::Matrix3Xd& points, std::mt19937_64* rng,
                             double spread) {
  std::normal_distribution<double> g(0, spread);
  for (int q = 0; q < 300; ++q) {
    const Eigen::Vector3d query(g(*rng), g(*rng), g(*rng));
    double d2;
    const int nearest = tree.Nearest(query, &d2);
    int expected;
    const double e2 = (points.colwise() - query).colwise().squaredNorm().minCoeff(&expected);
    ASSERT_EQ(nearest, expected) << "query " << q;
    EXPECT_DOUBLE_EQ(d2, e2);
    // A hint, near or far or out of range, changes nothing.
    for (const int hint : {expected, (expected + 1) % static_cast<int>(points.cols()), 0, -5, 1 << 30}) {
      double hinted_d2;
      EXPECT_EQ(tree.Nearest(query, &hinted_d2, hint), expected) << hint;
      EXPECT_EQ(hinted_d2, d2);
    }
  }
  // Groups of 9 queries about a centre (a patch's probes), with hints good,
  // bad, partly missing or none: each answer is brute force's.
  std::uniform_real_distribution<double> near(-0.2 * spread, 0.2 * spread);
  for (int group = 0; group < 60; ++group) {
    const Eigen::Vector3d centre(g(*rng), g(*rng), g(*rng));
    Eigen::Matrix3Xd queries(3, 9);
    for (int i = 0; i < 9; ++i) queries.col(i) = centre + Eigen::Vector3d(near(*rng), near(*rng), near(*rng));
    int expected[9];
    double expected_d2[9];
    for (int i = 0; i < 9; ++i) {
      expected_d2[i] = (points.colwise() - queries.col(i)).colwise().squaredNorm().minCoeff(&expected[i]);
    }
    int hints[9];
    for (int variant = 0; variant < 4; ++variant) {
      for (int i = 0; i < 9; ++i) {
        hints[i] = variant == 0                 ? expected[i]
                   : variant == 1               ? (expected[i] + 7 * i + 1) % static_cast<int>(points.cols())
                   : variant == 2 && i % 3 != 0 ? expected[i]
                                                : -1;
      }
      int nearest[9];
      double d2[9];
      tree.NearestGroup(queries, variant == 3 && group % 2 == 0 ? nullptr : hints, nearest, d2);
      for (int i = 0; i < 9; ++i) {
        ASSERT_EQ(nearest[i], expected[i]) << "group " << group << " variant " << variant << " query " << i;
        EXPECT_DOUBLE_EQ(d2[i], expected_d2[i]);
      }
    }
  }
}

TEST(RefitPointTree, MatchesBruteForceAsBuiltAndAfterTheLayoutIsTornApart) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0, 1);
  Eigen::Matrix3Xd points = Eigen::Matrix3Xd::NullaryExpr(3, 2000, [&] { return g(rng); });
  RefitPointTree tree(points);
  ExpectMatchesBruteForce(tree, points, &rng, 1.0);
  ExpectMatchesBruteForce(tree, points, &rng, 10.0);  // queries far outside
  // A non-rigid motion: the upper half turned by 90 degrees and carried
  // away, the lower half sheared, so the built topology's boxes overlap.
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  for (int i = 0; i < points.cols(); ++i) {
    if (points(1, i) > 0) {
      points.col(i) = turn * points.col(i) + Eigen::Vector3d(0.5, 1.0, 0.0);
    } else {
      points(0, i) += 0.7 * points(2, i);
    }
  }
  tree.Refit(points);
  ExpectMatchesBruteForce(tree, points, &rng, 1.0);
  // Every point collapsed onto a few: ties, but the distance is exact.
  Eigen::Matrix3Xd few = points;
  for (int i = 0; i < few.cols(); ++i) few.col(i) = points.col(i % 3);
  tree.Refit(few);
  double d2;
  const int nearest = tree.Nearest(points.col(1), &d2);
  EXPECT_EQ(d2, 0.0);
  EXPECT_EQ(nearest % 3, 1);
}

TEST(RefitPointTree, BadInput) {
  EXPECT_THROW(RefitPointTree(Eigen::Matrix3Xd(3, 0)), std::invalid_argument);
  RefitPointTree tree(Eigen::Matrix3Xd::Random(3, 20));
  EXPECT_THROW(tree.Refit(Eigen::Matrix3Xd::Random(3, 21)), std::invalid_argument);
  // A query with a NaN finds nothing rather than a wrong point.
  double d2 = 0.0;
  EXPECT_EQ(tree.Nearest(Eigen::Vector3d(std::nan(""), 0, 0), &d2), -1);
  EXPECT_TRUE(std::isinf(d2));
  EXPECT_EQ(tree.Nearest(Eigen::Vector3d(std::nan(""), 0, 0), &d2, 3), -1);
  // In a group, only the query with the NaN finds nothing.
  Eigen::Matrix3Xd queries = Eigen::Matrix3Xd::Random(3, 3);
  queries(1, 1) = std::nan("");
  int nearest[3];
  double group_d2[3];
  tree.NearestGroup(queries, nullptr, nearest, group_d2);
  EXPECT_EQ(nearest[1], -1);
  EXPECT_GE(nearest[0], 0);
  EXPECT_EQ(nearest[2], tree.Nearest(queries.col(2), &d2));
  EXPECT_THROW(tree.NearestGroup(Eigen::Matrix3Xd::Zero(3, RefitPointTree::kMaxGroup + 1), nullptr, nearest, group_d2),
               std::invalid_argument);
  // A hint at a point with a NaN bounds nothing: the group finds what
  // Nearest finds among the others.
  Eigen::Matrix3Xd points = Eigen::Matrix3Xd::Random(3, 200);
  points(0, 7) = std::nan("");
  const RefitPointTree broken(points);
  const Eigen::Matrix3Xd near = Eigen::Matrix3Xd::Random(3, 3) * 0.1;
  const int hints[3] = {7, 7, -1};
  broken.NearestGroup(near, hints, nearest, group_d2);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(nearest[i], broken.Nearest(near.col(i), &d2)) << i;
    EXPECT_EQ(group_d2[i], d2);
    EXPECT_NE(nearest[i], 7);
  }
  // One point: a leaf as the root.
  const RefitPointTree one(Eigen::Matrix3Xd::Zero(3, 1));
  EXPECT_EQ(one.Nearest(Eigen::Vector3d(1, 2, 3), &d2), 0);
  EXPECT_DOUBLE_EQ(d2, 14.0);
}

}  // namespace
}  // namespace polyfit
