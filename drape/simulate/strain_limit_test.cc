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

TEST(StrainLimitTest, CoincidentVerticesStayFinite) {
  const TriangleMesh grid = MakeGrid(4, 4, 0.5);
  const ClothRest rest = PrepareClothRest(grid);
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, grid.vertices.cols());
  LimitStrain(rest, {}, 3, 0.0, &x);
  EXPECT_TRUE(x.allFinite());
}

}  // namespace
}  // namespace polyfit
