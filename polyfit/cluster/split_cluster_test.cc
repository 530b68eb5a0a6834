#include "polyfit/cluster/split_cluster.h"

#include <random>

#include <gtest/gtest.h>

#include "polyfit/cluster/kmeans.h"
#include "polyfit/mesh/face_centroids.h"
#include "polyfit/mesh/per_face_normals.h"
#include "polyfit/mesh/primitives.h"
#include "polyfit/model/orient_patches.h"
#include "polyfit/pipeline/adaptive_patches.h"

namespace polyfit {
namespace {

TEST(KMeansTest, TwoBlobsAreSeparatedAndTheCentresAreTheirMeans) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.1);
  Eigen::Matrix<double, 2, Eigen::Dynamic> points(2, 200);
  for (int i = 0; i < 200; ++i) points.col(i) << (i < 100 ? 0.0 : 3.0) + noise(rng), noise(rng);
  Eigen::Matrix<double, 2, Eigen::Dynamic> centres(2, 2);
  centres << points.col(0), points.col(150);  // one seed in each blob
  std::vector<int> labels;
  LloydKMeans<2>(points, Eigen::VectorXd(), &centres, &labels, 20);
  for (int i = 0; i < 200; ++i) EXPECT_EQ(labels[i], i < 100 ? 0 : 1);
  EXPECT_LT((centres.col(0) - points.leftCols(100).rowwise().mean()).norm(), 1e-12);
  EXPECT_LT((centres.col(1) - points.rightCols(100).rowwise().mean()).norm(), 1e-12);
}

TEST(KMeansTest, KdTreeAndBruteForceAgreeInThreeDimensions) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::Matrix3Xd points(3, 500);
  for (int i = 0; i < 500; ++i) points.col(i) << uniform(rng), uniform(rng), uniform(rng);
  Eigen::Matrix3Xd centres = points.leftCols(20);  // 20 > 16: the kd-tree path
  std::vector<int> labels;
  LloydKMeans<3>(points, Eigen::VectorXd::Ones(500), &centres, &labels, 1);
  for (int i = 0; i < 500; ++i) {
    int best = 0;
    for (int c = 1; c < 20; ++c) {
      if ((points.col(i) - points.col(c)).squaredNorm() < (points.col(i) - points.col(best)).squaredNorm()) best = c;
    }
    EXPECT_EQ(labels[i], best);
  }
}

// Two 1 x 1 squares meeting at a right angle along x = 0: the floor
// (z = 0, x < 0) and the wall (x = 0, z > 0).
TriangleMesh MakeFold() {
  TriangleMesh floor = MakeGrid(6, 6);
  TriangleMesh mesh = floor;
  mesh.vertices.row(0).array() -= 0.5;
  TriangleMesh wall = floor;
  wall.vertices.row(2) = (floor.vertices.row(0).array() + 0.5).matrix();
  wall.vertices.row(0).setZero();
  mesh.vertices.conservativeResize(3, 2 * floor.num_vertices());
  mesh.vertices.rightCols(floor.num_vertices()) = wall.vertices;
  mesh.faces.conservativeResize(3, 2 * floor.num_faces());
  mesh.faces.rightCols(floor.num_faces()) = floor.faces.array() + floor.num_vertices();
  mesh.corner_texcoords.resize(2, 0);
  return mesh;
}

TEST(SplitClusterTest, AFoldSplitsAlongItsCrease) {
  const TriangleMesh fold = MakeFold();
  const Eigen::Matrix3Xd normals = PerFaceNormals(fold), centroids = FaceCentroids(fold);
  std::vector<int> faces(fold.num_faces());
  for (int f = 0; f < fold.num_faces(); ++f) faces[f] = f;
  const std::vector<int> side = SplitClusterInTwo(normals, centroids, faces);
  ASSERT_EQ(side.size(), faces.size());
  const int half = fold.num_faces() / 2;
  for (int f = 0; f < fold.num_faces(); ++f) EXPECT_EQ(side[f], side[f < half ? 0 : half]) << f;
  EXPECT_NE(side[0], side[half]);
  EXPECT_TRUE(SplitClusterInTwo(normals, centroids, {0, 1, 2}).empty());  // too few faces
}

TEST(AdaptivePatchesTest, PatchesAreSplitUntilEveryJetHoldsItsVertices) {
  const TriangleMesh tube = MakeTube(0.15, 0.0, 0.3, 24, 8);
  AdaptivePatchOptions options;
  options.clustering.num_patches = 1;  // one patch cannot hold a tube
  options.max_fit_error = 2e-3;
  options.max_splits = 6;
  const PolyFitModel model = FitAdaptivePatches(options, tube);
  EXPECT_GT(model.num_patches(), 2);
  EXPECT_EQ(model.Validate(), "");
  const std::vector<double> errors = PatchMaxFitErrors(tube, model);
  for (double e : errors) EXPECT_LE(e, options.max_fit_error);
  options.max_splits = 0;
  EXPECT_EQ(FitAdaptivePatches(options, tube).num_patches(), 1);
  options.max_fit_error = 0.0;
  EXPECT_THROW(FitAdaptivePatches(options, tube), std::invalid_argument);
}

TEST(OrientPatchesTest, FramesAgreeWithFacesAndTheSurfaceIsUnchanged) {
  const TriangleMesh tube = MakeTube(0.15, 0.0, 0.3, 24, 8);
  AdaptivePatchOptions options;
  options.clustering.num_patches = 8;
  PolyFitModel model = FitAdaptivePatches(options, tube);
  std::vector<Eigen::Vector3d> before;
  for (int k = 0; k < model.num_memberships(); ++k) before.push_back(model.MembershipPoint(k));
  OrientPatchesLikeFaces(tube, &model);
  const Eigen::Matrix3Xd normals = PerFaceNormals(tube);
  for (int f = 0; f < tube.num_faces(); ++f) {
    EXPECT_GT(normals.col(f).dot(model.patches[model.face_patch[f]].frame.rotation.col(2)), 0.0) << f;
  }
  for (int k = 0; k < model.num_memberships(); ++k) EXPECT_LT((model.MembershipPoint(k) - before[k]).norm(), 1e-12);
  EXPECT_EQ(OrientPatchesLikeFaces(tube, &model), 0);  // already oriented
}

}  // namespace
}  // namespace polyfit
