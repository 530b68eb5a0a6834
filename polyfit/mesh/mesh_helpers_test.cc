#include <cmath>

#include <gtest/gtest.h>

#include "polyfit/mesh/face_centroids.h"
#include "polyfit/mesh/per_face_normals.h"
#include "polyfit/mesh/primitives.h"
#include "polyfit/mesh/unique_edges.h"

namespace polyfit {
namespace {

TEST(MeshHelpersTest, NormalsPointOutOfASphereAndDegenerateFacesGetZero) {
  TriangleMesh sphere = MakeIcosphere(2, 2.0);
  const Eigen::Matrix3Xd normals = PerFaceNormals(sphere);
  const Eigen::Matrix3Xd centroids = FaceCentroids(sphere);
  ASSERT_EQ(normals.cols(), sphere.num_faces());
  for (int f = 0; f < sphere.num_faces(); ++f) {
    EXPECT_NEAR(normals.col(f).norm(), 1.0, 1e-12);
    // Centroids lie just inside the sphere, along the face normal.
    EXPECT_GT(normals.col(f).dot(centroids.col(f).normalized()), 0.98);
    const Eigen::Vector3d mean = (sphere.vertices.col(sphere.faces(0, f)) + sphere.vertices.col(sphere.faces(1, f)) +
                                  sphere.vertices.col(sphere.faces(2, f))) /
                                 3.0;
    EXPECT_LT((centroids.col(f) - mean).norm(), 1e-14);
  }
  sphere.faces(1, 0) = sphere.faces(0, 0);  // a repeated corner: zero area
  EXPECT_EQ(PerFaceNormals(sphere).col(0), Eigen::Vector3d::Zero());
}

TEST(MeshHelpersTest, UniqueEdgesFollowEulersFormula) {
  const TriangleMesh sphere = MakeIcosphere(2);
  const Eigen::Matrix2Xi edges = UniqueEdges(sphere);
  // A closed genus-0 mesh: E = V + F - 2, and every face edge is found.
  EXPECT_EQ(edges.cols(), sphere.num_vertices() + sphere.num_faces() - 2);
  for (Eigen::Index e = 0; e < edges.cols(); ++e) {
    EXPECT_LT(edges(0, e), edges(1, e));
    if (e > 0) {
      EXPECT_TRUE(edges(0, e - 1) < edges(0, e) || edges(1, e - 1) < edges(1, e));
    }
  }
  for (int f = 0; f < sphere.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int e = FindEdge(edges, sphere.faces((c + 1) % 3, f), sphere.faces(c, f));
      ASSERT_GE(e, 0);
      EXPECT_EQ(std::min(sphere.faces(c, f), sphere.faces((c + 1) % 3, f)), edges(0, e));
    }
  }
  EXPECT_EQ(FindEdge(edges, 0, 0), -1);
  // A grid: (nx + 1) ny + nx (ny + 1) + nx ny edges.
  EXPECT_EQ(UniqueEdges(MakeGrid(3, 2)).cols(), 4 * 2 + 3 * 3 + 3 * 2);
}

}  // namespace
}  // namespace polyfit
