#include "polyfit/mesh/edge_split.h"

#include <gtest/gtest.h>

#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/mesh/per_face_normals.h"
#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

double LongestEdge(const TriangleMesh& mesh) {
  double longest = 0.0;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      longest = std::max(longest,
                         (mesh.vertices.col(mesh.faces(c, f)) - mesh.vertices.col(mesh.faces((c + 1) % 3, f))).norm());
    }
  }
  return longest;
}

int BoundaryEdges(const TriangleMesh& mesh) {
  const auto edges = SortedEdgeCorners(mesh);
  int boundary = 0;
  for (size_t i = 0; i < edges.size(); ++i) {
    const bool alone = (i == 0 || edges[i - 1].first != edges[i].first) &&
                       (i + 1 == edges.size() || edges[i + 1].first != edges[i].first);
    boundary += alone;
  }
  return boundary;
}

// A grid with one stretched column: only its long edges split, the surface
// (area, orientation, boundary) kept, the vertices first and unchanged.
TEST(SplitLongEdgesTest, SplitsOnlyLongEdgesAndKeepsTheSurface) {
  TriangleMesh grid = MakeGrid(6, 4, 1.0);
  for (int v = 0; v < grid.num_vertices(); ++v) {
    if (grid.vertices(0, v) > 0.3) grid.vertices(0, v) = 0.3 + 4.0 * (grid.vertices(0, v) - 0.3);
  }
  const double length = 0.25;
  const TriangleMesh split = SplitLongEdges(grid, length);
  EXPECT_TRUE(split.Validate().empty());
  EXPECT_LE(LongestEdge(split), length);
  EXPECT_GT(split.num_vertices(), grid.num_vertices());
  EXPECT_TRUE(split.vertices.leftCols(grid.num_vertices()).isApprox(grid.vertices));
  EXPECT_NEAR(SurfaceArea(split), SurfaceArea(grid), 1e-12);
  // Conforming: the boundary is the grid's, split (no cracks inside).
  std::vector<int> labels;
  EXPECT_EQ(ConnectedComponents(FaceFaceAdjacency(split), &labels), 1);
  const Eigen::Matrix3Xd before = PerFaceNormals(grid), after = PerFaceNormals(split);
  for (int f = 0; f < split.num_faces(); ++f) EXPECT_GT(after.col(f).dot(before.col(0)), 0.99);
  EXPECT_GE(BoundaryEdges(split), BoundaryEdges(grid));
  // Faces in the unstretched part are left as they were.
  const TriangleMesh again = SplitLongEdges(split, length);
  EXPECT_EQ(again.num_faces(), split.num_faces());
}

TEST(SplitLongEdgesTest, ClosedSurfaceStaysClosedAndBadLengthsAreRefused) {
  const TriangleMesh sphere = MakeIcosphere(1, 1.0);
  const TriangleMesh split = SplitLongEdges(sphere, 0.3);
  EXPECT_EQ(BoundaryEdges(split), 0);
  EXPECT_LE(LongestEdge(split), 0.3);
  EXPECT_EQ(split.num_vertices() - split.num_faces() / 2, 2);  // Euler: V - E + F = 2 on a triangulated sphere
  EXPECT_THROW(SplitLongEdges(sphere, 0.0), std::invalid_argument);
  EXPECT_THROW(SplitLongEdges(sphere, -1.0), std::invalid_argument);
  EXPECT_THROW(SplitLongEdges(sphere, 1e-5), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
