#include "polyfit/mesh/hinge_rest.h"

#include <cmath>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace polyfit {
namespace {

// A unit square in two triangles, its vertex 3 turned by `deg` about the
// diagonal 0 -> 2 (3 by 4).
Eigen::Matrix3Xd FoldedSquare(double deg) {
  Eigen::Matrix3Xd v(3, 4);
  v << 0, 1, 1, 0, 0, 0, 1, 1, 0, 0, 0, 0;
  const Eigen::AngleAxisd fold(deg * M_PI / 180.0, Eigen::Vector3d(1, 1, 0).normalized());
  v.col(3) = fold * v.col(3);
  return v;
}

TEST(HingeTurnsDegTest, AFoldTurnsItsHingeByItsAngleWrappedIntoAHalfTurn) {
  TriangleMesh square;
  square.vertices = FoldedSquare(0.0);
  square.faces.resize(3, 2);
  square.faces << 0, 0, 1, 2, 2, 3;
  const std::vector<MeshHinge> hinges = InteriorHinges(square);
  ASSERT_EQ(hinges.size(), 1u);
  EXPECT_NEAR(HingeTurnsDeg(hinges, FoldedSquare(30.0), square.vertices)[0], 30.0, 1e-9);
  EXPECT_NEAR(HingeTurnsDeg(hinges, square.vertices, FoldedSquare(30.0))[0], 30.0, 1e-9);
  // +150 to -150 degrees is a turn of 60 through the half turn, not 300.
  EXPECT_NEAR(HingeTurnsDeg(hinges, FoldedSquare(150.0), FoldedSquare(-150.0))[0], 60.0, 1e-9);
  EXPECT_NEAR(HingeTurnsDeg(hinges, FoldedSquare(40.0), FoldedSquare(-20.0))[0], 60.0, 1e-9);
}

}  // namespace
}  // namespace polyfit
