#include "polyfit/cluster/acvd_clustering.h"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

// Number of edge-connected pieces of each patch.
std::vector<int> PiecesPerPatch(const TriangleMesh& mesh, const std::vector<int>& labels, int num_patches) {
  const AdjacencyList all = FaceFaceAdjacency(mesh);
  // The face graph restricted to edges inside one patch.
  AdjacencyList inside;
  inside.offsets.assign(1, 0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (const int* g = all.begin(f); g != all.end(f); ++g) {
      if (labels[*g] == labels[f]) inside.indices.push_back(*g);
    }
    inside.offsets.push_back(static_cast<int>(inside.indices.size()));
  }
  std::vector<int> component;
  const int count = ConnectedComponents(inside, &component);
  std::vector<int> pieces(num_patches, 0);
  std::vector<bool> seen(count, false);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (!seen[component[f]]) {
      seen[component[f]] = true;
      ++pieces[labels[f]];
    }
  }
  return pieces;
}

void ExpectUniformConnectedPatches(const TriangleMesh& mesh, int k, double min_area, double max_area) {
  ClusteringOptions options;
  options.num_patches = k;
  ClusteringSummary summary;
  const std::vector<int> labels = ClusterMeshFaces(options, mesh, &summary);
  ASSERT_EQ(static_cast<int>(labels.size()), mesh.num_faces());
  EXPECT_EQ(summary.num_patches, k);
  EXPECT_EQ(*std::max_element(labels.begin(), labels.end()), k - 1);
  for (int pieces : PiecesPerPatch(mesh, labels, k)) EXPECT_EQ(pieces, 1);
  EXPECT_GE(summary.min_relative_area, min_area);
  EXPECT_LE(summary.max_relative_area, max_area);
  // The greedy moves only ever lower the energy.
  EXPECT_LT(summary.final_energy, summary.initial_energy);
  EXPECT_FALSE(summary.soup_fallback);
}

TEST(AcvdClusteringTest, SphereGivesConnectedPatchesOfNearEqualArea) {
  // 20480 faces into 100 patches: measured spread 0.80 to 1.22.
  ExpectUniformConnectedPatches(MakeIcosphere(5), 100, 0.7, 1.35);
}

TEST(AcvdClusteringTest, PlaneGivesConnectedPatchesOfNearEqualArea) {
  ExpectUniformConnectedPatches(MakeGrid(120, 80, 1.0), 60, 0.7, 1.35);
}

TEST(AcvdClusteringTest, AutomaticCountFollowsArea) {
  ClusteringOptions options;  // max(100, min(400, floor(A / 0.008)))
  EXPECT_EQ(options.ResolveNumPatches(0.1), 100);
  EXPECT_EQ(options.ResolveNumPatches(2.0), 250);
  EXPECT_EQ(options.ResolveNumPatches(50.0), 400);
  ClusteringSummary summary;
  const TriangleMesh sphere = MakeIcosphere(5, 0.4);  // area 2.01 m^2 -> 251 patches
  ClusterMeshFaces(options, sphere, &summary);
  EXPECT_EQ(summary.num_patches, 251);
}

TEST(AcvdClusteringTest, SeparatePiecesShareThePatchesByArea) {
  // Two spheres, the second with four times the area.
  TriangleMesh small = MakeIcosphere(4, 1.0), large = MakeIcosphere(4, 2.0);
  large.vertices.row(0).array() += 10.0;
  TriangleMesh both;
  both.vertices.resize(3, small.num_vertices() + large.num_vertices());
  both.vertices << small.vertices, large.vertices;
  both.faces.resize(3, small.num_faces() + large.num_faces());
  both.faces << small.faces, (large.faces.array() + small.num_vertices()).matrix();
  ClusteringOptions options;
  options.num_patches = 50;
  ClusteringSummary summary;
  const std::vector<int> labels = ClusterMeshFaces(options, both, &summary);
  EXPECT_EQ(summary.num_components, 2);
  std::vector<int> on_small, on_large;
  for (int f = 0; f < both.num_faces(); ++f) (f < small.num_faces() ? on_small : on_large).push_back(labels[f]);
  std::sort(on_small.begin(), on_small.end());
  std::sort(on_large.begin(), on_large.end());
  on_small.erase(std::unique(on_small.begin(), on_small.end()), on_small.end());
  on_large.erase(std::unique(on_large.begin(), on_large.end()), on_large.end());
  EXPECT_EQ(on_small.size(), 10u);
  EXPECT_EQ(on_large.size(), 40u);
}

TEST(AcvdClusteringTest, TinyPiecesJoinTheNearestPatch) {
  TriangleMesh mesh = MakeIcosphere(4);
  // A far-off sliver triangle: too small for a patch of its own.
  const int v = mesh.num_vertices();
  mesh.vertices.conservativeResize(3, v + 3);
  mesh.vertices.rightCols(3) << 3.0, 3.001, 3.0, 0, 0, 0.001, 0, 0, 0;
  mesh.faces.conservativeResize(3, mesh.num_faces() + 1);
  mesh.faces.rightCols(1) << v, v + 1, v + 2;
  ClusteringOptions options;
  options.num_patches = 20;
  ClusteringSummary summary;
  const std::vector<int> labels = ClusterMeshFaces(options, mesh, &summary);
  EXPECT_EQ(summary.num_patches, 20);
  EXPECT_EQ(summary.num_debris_faces, 1);
  EXPECT_GE(labels.back(), 0);
}

TEST(AcvdClusteringTest, TriangleSoupFallsBackToKMeans) {
  // Every face its own piece.
  const TriangleMesh sphere = MakeIcosphere(3);
  TriangleMesh soup;
  soup.vertices.resize(3, 3 * sphere.num_faces());
  soup.faces.resize(3, sphere.num_faces());
  for (int f = 0; f < sphere.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      soup.vertices.col(3 * f + c) = sphere.vertices.col(sphere.faces(c, f));
      soup.faces(c, f) = 3 * f + c;
    }
  }
  ClusteringOptions options;
  options.num_patches = 30;
  ClusteringSummary summary;
  const std::vector<int> labels = ClusterMeshFaces(options, soup, &summary);
  EXPECT_TRUE(summary.soup_fallback);
  EXPECT_EQ(summary.num_patches, 30);
  EXPECT_LT(summary.max_relative_area, 2.0);
}

TEST(AcvdClusteringTest, MorePatchesThanFacesIsCapped) {
  ClusteringOptions options;
  options.num_patches = 1000;
  ClusteringSummary summary;
  ClusterMeshFaces(options, MakeIcosphere(1), &summary);  // 80 faces
  EXPECT_EQ(summary.num_patches, 80);
}

TEST(AcvdClusteringTest, InvalidInputThrows) {
  ClusteringOptions options;
  options.num_patches = -1;
  EXPECT_THROW(ClusterMeshFaces(options, MakeIcosphere(1)), std::invalid_argument);
  EXPECT_THROW(ClusterMeshFaces(ClusteringOptions(), TriangleMesh()), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
