#include "polyfit/mesh/mesh_topology.h"

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace polyfit {
namespace {

TriangleMesh Mesh(const std::vector<Eigen::Vector3i>& faces, int num_vertices) {
  TriangleMesh mesh;
  mesh.vertices = Eigen::Matrix3Xd::Zero(3, num_vertices);
  mesh.faces.resize(3, static_cast<Eigen::Index>(faces.size()));
  for (size_t f = 0; f < faces.size(); ++f) mesh.faces.col(static_cast<Eigen::Index>(f)) = faces[f];
  return mesh;
}

TEST(InteriorHingesTest, EachSharedEdgeOnceAsItRunsInItsFirstFace) {
  // A square in two triangles: the diagonal runs 2 -> 0 in face 0.
  const std::vector<MeshHinge> square = InteriorHinges(Mesh({{0, 1, 2}, {0, 2, 3}}, 4));
  ASSERT_EQ(square.size(), 1u);
  EXPECT_EQ(square[0].vertices, (std::array<int, 4>{2, 0, 1, 3}));
  EXPECT_EQ(square[0].faces, (std::array<int, 2>{0, 1}));

  // A 3 by 3 grid of vertices, 8 faces: 16 edges, 8 on the boundary.
  std::vector<Eigen::Vector3i> grid;
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 2; ++c) {
      const int v = 3 * r + c;
      grid.emplace_back(v, v + 1, v + 4);
      grid.emplace_back(v, v + 4, v + 3);
    }
  }
  const std::vector<MeshHinge> hinges = InteriorHinges(Mesh(grid, 9));
  ASSERT_EQ(hinges.size(), 8u);
  for (size_t h = 0; h + 1 < hinges.size(); ++h) {
    const auto key = [](const MeshHinge& m) {
      return std::make_pair(std::min(m.vertices[0], m.vertices[1]), std::max(m.vertices[0], m.vertices[1]));
    };
    EXPECT_LT(key(hinges[h]), key(hinges[h + 1]));
  }
  for (const MeshHinge& hinge : hinges) {
    // k and l are the faces' third corners, on either side.
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector3i face = Mesh(grid, 9).faces.col(hinge.faces[side]);
      int found = 0;
      for (int c = 0; c < 3; ++c) {
        found += face[c] == hinge.vertices[0] || face[c] == hinge.vertices[1] || face[c] == hinge.vertices[2 + side];
      }
      EXPECT_EQ(found, 3);
    }
  }

  // An edge of three faces is no hinge.
  EXPECT_TRUE(InteriorHinges(Mesh({{0, 1, 2}, {1, 0, 3}, {0, 1, 4}}, 5)).empty());
}

}  // namespace
}  // namespace polyfit
