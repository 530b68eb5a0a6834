#include "sft/render/vertex_visibility.h"

#include <gtest/gtest.h>

#include "sft/camera/test_camera.h"

namespace polyfit {
namespace {

// A 5 x 5 grid (0.1 m spacing, at depth `depth`, its corner at (x0, y0))
// appended to `vertices` and `faces`.
void AddGrid(double x0, double y0, double depth, Eigen::Matrix3Xd* vertices, Eigen::Matrix3Xi* faces) {
  const int base = static_cast<int>(vertices->cols());
  vertices->conservativeResize(3, base + 25);
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) vertices->col(base + 5 * i + j) = Eigen::Vector3d(x0 + 0.1 * j, y0 + 0.1 * i, depth);
  }
  const int f0 = static_cast<int>(faces->cols());
  faces->conservativeResize(3, f0 + 32);
  int f = f0;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      const int a = base + 5 * i + j;
      faces->col(f++) = Eigen::Vector3i(a, a + 1, a + 6);
      faces->col(f++) = Eigen::Vector3i(a, a + 6, a + 5);
    }
  }
}

// A fold-over's two layers: a far grid and a near one over its left half.
// The far grid's vertices under the near one are hidden, the rest seen;
// the near grid is seen everywhere.
TEST(VertexVisibilityTest, TheLayerBehindAFoldIsHiddenWhereTheNearOneCoversIt) {
  for (const double gap : {0.05, 0.003}) {
    Eigen::Matrix3Xd vertices(3, 0);
    Eigen::Matrix3Xi faces(3, 0);
    AddGrid(-0.2, -0.2, 1.0 + gap, &vertices, &faces);  // far: x in [-0.2, 0.2] at depth 1 + gap
    AddGrid(-0.45, -0.25, 1.0, &vertices, &faces);      // near: x in [-0.45, -0.05]
    ScreenMesh screen;
    screen.faces = faces;
    ASSERT_TRUE(ProjectVertices(TestCamera(), vertices, &screen, nullptr));
    std::vector<int> occluders;
    const std::vector<std::uint8_t> occluded = OccludedVertices(screen, 320, 240, 0.01, &occluders);
    EXPECT_EQ(OccludedVertices(screen, 320, 240, 0.01), occluded);
    ASSERT_EQ(occluders.size(), 50u);
    for (int v = 0; v < 50; ++v) {
      // The near grid spans x in [-0.45, -0.05] at depth 1, and the far
      // grid's points project inside it where x / (1 + gap) < -0.05 (its
      // y range, [-0.25, 0.15], covers theirs but for y = 0.2).
      const double x = vertices(0, v), y = vertices(1, v);
      const bool covered = v < 25 && x / (1.0 + gap) < -0.05 && y / (1.0 + gap) < 0.15;
      const bool expected = covered && gap > 0.01;
      EXPECT_EQ(occluded[v], expected) << "gap " << gap << " vertex " << v;
      // What hides it is a face of the near grid (faces 32-63).
      if (expected) {
        EXPECT_GE(occluders[v], 32) << v;
        EXPECT_LT(occluders[v], 64) << v;
      } else {
        EXPECT_EQ(occluders[v], -1) << v;
      }
    }
  }
}

// Vertices outside the image, and a single sheet seen from the front or
// at a slant, are never hidden.
TEST(VertexVisibilityTest, ASingleSheetAndVerticesOutsideTheImageAreSeen) {
  Eigen::Matrix3Xd vertices(3, 0);
  Eigen::Matrix3Xi faces(3, 0);
  AddGrid(-0.2, -0.2, 1.0, &vertices, &faces);
  for (int v = 0; v < 25; ++v) vertices(2, v) += 2.0 * vertices(0, v);  // 63 degrees of slant
  AddGrid(2.0, 0.0, 1.0, &vertices, &faces);                            // beyond the image's right edge
  ScreenMesh screen;
  screen.faces = faces;
  ASSERT_TRUE(ProjectVertices(TestCamera(), vertices, &screen, nullptr));
  const std::vector<std::uint8_t> occluded = OccludedVertices(screen, 320, 240, 0.002);
  for (int v = 0; v < 50; ++v) EXPECT_EQ(occluded[v], 0) << v;
}

}  // namespace
}  // namespace polyfit
