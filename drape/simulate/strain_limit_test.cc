#include "drape/simulate/strain_limit.h"

#include <cmath>

#include <gtest/gtest.h>

#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

TEST(StrainLimitTest, OnePassRestoresALoneEdgeAboutItsMidpoint) {
  TriangleMesh triangle;
  triangle.vertices.resize(3, 3);
  triangle.vertices << 0, 1, 0, 0, 0, 1, 0, 0, 0;
  triangle.faces.resize(3, 1);
  triangle.faces << 0, 1, 2;
  ClothRest rest = PrepareClothRest(triangle);
  // Keep one edge: (0, 1), rest length 1, stretched to 1.5 along x.
  for (size_t e = 0; e < rest.edges.size(); ++e) {
    if (rest.edges[e][0] + rest.edges[e][1] == 1) rest.edges = {rest.edges[e]}, rest.edge_length = {1.0};
  }
  ASSERT_EQ(rest.edges.size(), 1u);
  Eigen::Matrix3Xd x = triangle.vertices;
  x(0, 1) = 1.5;
  LimitStrain(rest, {}, 1, 0.0, &x);
  EXPECT_NEAR(x(0, 0), 0.25, 1e-12);
  EXPECT_NEAR(x(0, 1), 1.25, 1e-12);
  EXPECT_NEAR((x.col(1) - x.col(0)).norm(), 1.0, 1e-12);
  EXPECT_TRUE(x.col(2).isApprox(triangle.vertices.col(2)));
}

TEST(StrainLimitTest, PassesTakeAStretchedSheetBackToItsRestLengths) {
  const TriangleMesh grid = MakeGrid(10, 10, 0.5);
  const ClothRest rest = PrepareClothRest(grid);
  Eigen::Matrix3Xd x = grid.vertices;
  x.row(0) *= 1.1;  // 10% along x
  double previous = MeasureCloth(rest, x).edge_strain_percent;
  for (int round = 0; round < 4; ++round) {
    LimitStrain(rest, {}, 5, 0.0, &x);
    const double strain = MeasureCloth(rest, x).edge_strain_percent;
    EXPECT_LT(strain, previous);
    previous = strain;
  }
  EXPECT_LT(previous, 1.0);  // from 10: Gauss-Seidel carries a global stretch out slowly
  EXPECT_TRUE(x.allFinite());
}

TEST(StrainLimitTest, ContactsEndAboveTheirPlanes) {
  const TriangleMesh grid = MakeGrid(6, 6, 0.5);
  const ClothRest rest = PrepareClothRest(grid);
  Eigen::Matrix3Xd x = grid.vertices;
  // A bump below the plane z = 0 at one vertex: the plane pushes it up to
  // the offset; its edges then pull it back toward the sheet, the
  // contact's projection comes last.
  const int v = 14;
  x(2, v) = -0.05;
  const double offset = 2e-3;
  const BodyContact contact{v, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()};
  LimitStrain(rest, {contact}, 3, offset, &x);
  EXPECT_GE(x(2, v), offset - 1e-12);
  EXPECT_NEAR(MeasureCloth(rest, x).edge_strain_percent, 0.0, 0.5);
}

TEST(StrainLimitTest, TheInterleavedRunsVisitEveryEdge) {
  // Five separate triangles (15 edges, not a multiple of the runs), each
  // stretched by half: only a triangle all of whose edges are visited
  // returns to its rest lengths.
  TriangleMesh triangles;
  triangles.vertices.resize(3, 15);
  triangles.faces.resize(3, 5);
  for (int t = 0; t < 5; ++t) {
    triangles.vertices.col(3 * t) = Eigen::Vector3d(2.0 * t, 0, 0);
    triangles.vertices.col(3 * t + 1) = Eigen::Vector3d(2.0 * t + 1.0, 0.1 * t, 0);
    triangles.vertices.col(3 * t + 2) = Eigen::Vector3d(2.0 * t + 0.3, 0.8, 0.2 * t);
    triangles.faces.col(t) = Eigen::Vector3i(3 * t, 3 * t + 1, 3 * t + 2);
  }
  const ClothRest rest = PrepareClothRest(triangles);
  ASSERT_NE(rest.edges.size() % StrainLimiter::kRuns, 0u);
  Eigen::Matrix3Xd x = triangles.vertices;
  for (int t = 0; t < 5; ++t) {
    const Eigen::Vector3d centre = x.middleCols(3 * t, 3).rowwise().mean();
    for (int c = 0; c < 3; ++c) x.col(3 * t + c) = centre + 1.5 * (x.col(3 * t + c) - centre);
  }
  StrainLimiter(rest).Apply({}, 200, 0.0, &x);
  for (size_t e = 0; e < rest.edges.size(); ++e) {
    EXPECT_NEAR((x.col(rest.edges[e][1]) - x.col(rest.edges[e][0])).norm(), rest.edge_length[e], 1e-9) << "edge " << e;
  }
}

TEST(StrainLimitTest, ATetherHoldsEveryVertexNearWhereItStarted) {
  const TriangleMesh grid = MakeGrid(10, 10, 0.5);
  const ClothRest rest = PrepareClothRest(grid);
  Eigen::Matrix3Xd x = grid.vertices;
  x.row(0) *= 1.2;  // 20% along x: untethered, the edges move by up to 5 cm
  const Eigen::Matrix3Xd start = x;
  const StrainLimiter limiter(rest);
  Eigen::Matrix3Xd free = x;
  limiter.Apply({}, 20, 0.0, &free);
  const double max_move = 0.01;
  limiter.Apply({}, 20, 0.0, &x, max_move);
  EXPECT_GT((free - start).colwise().norm().maxCoeff(), 3 * max_move);
  EXPECT_LE((x - start).colwise().norm().maxCoeff(), max_move + 1e-12);
  // Strain between neighbours (each vertex off by up to 3 mm, on 5 cm
  // edges) is given up within the tether.
  Eigen::Matrix3Xd noisy = grid.vertices + 0.003 * Eigen::Matrix3Xd::Random(3, grid.vertices.cols());
  const double before = MeasureCloth(rest, noisy).edge_strain_percent;
  limiter.Apply({}, 10, 0.0, &noisy, max_move);
  EXPECT_GT(before, 3.0);
  EXPECT_LT(MeasureCloth(rest, noisy).edge_strain_percent, 0.2 * before);
}

TEST(StrainLimitTest, CoincidentVerticesStayFinite) {
  const TriangleMesh grid = MakeGrid(4, 4, 0.5);
  const ClothRest rest = PrepareClothRest(grid);
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, grid.vertices.cols());
  LimitStrain(rest, {}, 3, 0.0, &x);
  EXPECT_TRUE(x.allFinite());
}

}  // namespace
}  // namespace polyfit
