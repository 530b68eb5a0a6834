#include "polyfit/mesh/decimation.h"

#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

int NumEdges(const TriangleMesh& mesh) {
  const auto edges = SortedEdgeCorners(mesh);
  int count = 0;
  for (size_t i = 0; i < edges.size(); ++i) count += i == 0 || edges[i].first != edges[i - 1].first;
  return count;
}

// A closed sphere keeps its topology, the edge count asked for, and
// vertices on the sphere (not averaged into it).
TEST(DecimationTest, ASphereStaysAClosedSphere) {
  const TriangleMesh sphere = MakeIcosphere(4);  // 5120 faces, 7680 edges
  const TriangleMesh coarse = DecimateMesh(sphere, 0.25);
  const int edges = NumEdges(coarse);
  EXPECT_LE(edges, 1920);
  EXPECT_GE(edges, 1900);
  EXPECT_EQ(coarse.num_vertices() - edges + coarse.num_faces(), 2);  // Euler characteristic
  const Eigen::ArrayXd radius = coarse.vertices.colwise().norm().transpose().array();
  // Placement keeps the volume, so the vertices sit just outside the
  // sphere, making up for the chords between them that cut inside (the
  // coarse edges, about 0.15 long, sag by about 3e-3); measured: 7.8e-4 to
  // 5.5e-3, mean 2.3e-3.
  EXPECT_GT(radius.minCoeff(), 1.0);
  EXPECT_LT(radius.maxCoeff(), 1.0 + 1e-2);
  EXPECT_LT(radius.mean(), 1.0 + 3e-3);
  for (int f = 0; f < coarse.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_GE(coarse.faces(c, f), 0);
      ASSERT_LT(coarse.faces(c, f), coarse.num_vertices());
    }
  }
}

// An open sheet keeps its border: its corners' extent stays.
TEST(DecimationTest, AnOpenSheetKeepsItsBorder) {
  TriangleMesh sheet = MakeGrid(30, 30, 1.0);
  for (int v = 0; v < sheet.num_vertices(); ++v) sheet.vertices(2, v) = 0.2 * std::sin(3.0 * sheet.vertices(0, v));
  const TriangleMesh coarse = DecimateMesh(sheet, 0.3);
  EXPECT_LT(coarse.num_vertices(), sheet.num_vertices() / 2);
  EXPECT_NEAR(coarse.vertices.row(0).minCoeff(), -0.5, 1e-3);
  EXPECT_NEAR(coarse.vertices.row(0).maxCoeff(), 0.5, 1e-3);
  EXPECT_NEAR(coarse.vertices.row(1).minCoeff(), -0.5, 1e-3);
  EXPECT_NEAR(coarse.vertices.row(1).maxCoeff(), 0.5, 1e-3);
  for (int v = 0; v < coarse.num_vertices(); ++v) {
    EXPECT_NEAR(coarse.vertices(2, v), 0.2 * std::sin(3.0 * coarse.vertices(0, v)), 5e-3);
  }
}

TEST(DecimationTest, InvalidInputThrows) {
  const TriangleMesh sphere = MakeIcosphere(1);
  EXPECT_THROW(DecimateMesh(sphere, 0.0), std::invalid_argument);
  EXPECT_THROW(DecimateMesh(sphere, 1.5), std::invalid_argument);
  TriangleMesh fan = sphere;
  fan.faces.col(1) = fan.faces.col(0);  // a face twice: not a manifold
  EXPECT_THROW(DecimateMesh(fan, 0.5), std::invalid_argument);
  EXPECT_THROW(DecimateMesh(TriangleMesh{}, 0.5), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
