#include "drape/garment/skin_transfer.h"

#include <cmath>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"
#include "polyfit/mesh/edge_split.h"
#include "polyfit/mesh/primitives.h"
#include "polyfit/mesh/subdivision.h"
#include "polyfit/mesh/unique_edges.h"

namespace polyfit {
namespace {

// Body vertices pushed 5 mm out along their capsule's axis-normal: each
// lies over its own vertex.
TEST(SkinTransferTest, PointsOnTheBodyTakeItsWeights) {
  const SkinnedBody body = MakeProceduralBody();
  TriangleMesh garment = body.mesh;
  SkinTransferOptions options;
  options.smoothing_length = 0.0;
  options.min_weight = 0.0;
  const SkinWeights weights = TransferSkinWeights(body, garment, options);
  ASSERT_EQ(weights.num_vertices(), body.mesh.num_vertices());
  int checked = 0;
  for (int v = 0; v < body.mesh.num_vertices(); v += 37, ++checked) {
    Eigen::VectorXd expected = Eigen::VectorXd::Zero(body.skeleton.num_joints());
    Eigen::VectorXd got = expected;
    for (int k = body.weight_offsets[v]; k < body.weight_offsets[v + 1]; ++k)
      expected[body.weight_joint[k]] += body.weight_value[k];
    for (int k = weights.offsets[v]; k < weights.offsets[v + 1]; ++k) got[weights.joint[k]] += weights.value[k];
    // Capsules overlap, so a vertex buried in another capsule may take
    // that one's surface; compare where the weights are a single bone's.
    if (expected.maxCoeff() < 0.999) continue;
    EXPECT_LT((got - expected).norm(), 1e-6) << "vertex " << v;
  }
  EXPECT_GT(checked, 10);
}

TEST(SkinTransferTest, RowsSumToOneAndIdentityPosesNothing) {
  const SkinnedBody body = MakeProceduralBody();
  TriangleMesh garment = body.mesh;
  garment.vertices *= 1.02;
  const SkinWeights weights = TransferSkinWeights(body, garment);
  for (int v = 0; v < weights.num_vertices(); ++v) {
    double sum = 0.0;
    for (int k = weights.offsets[v]; k < weights.offsets[v + 1]; ++k) {
      EXPECT_GE(weights.value[k], 0.0);
      sum += weights.value[k];
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
  }
  const std::vector<Eigen::Isometry3d> identity(body.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  EXPECT_LT((SkinPoints(weights, garment.vertices, identity) - garment.vertices).cwiseAbs().maxCoeff(), 1e-12);
  // A translation of every bone moves every point by it.
  std::vector<Eigen::Isometry3d> moved = identity;
  for (Eigen::Isometry3d& t : moved) t.translation() = Eigen::Vector3d(0.1, -0.2, 0.3);
  const Eigen::Matrix3Xd x = SkinPoints(weights, garment.vertices, moved);
  EXPECT_LT(((x - garment.vertices).colwise() - Eigen::Vector3d(0.1, -0.2, 0.3)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(SkinTransferTest, LooseDistanceKeepsVerticesOnTheBodyAndDiffusesFarOnes) {
  const SkinnedBody body = MakeProceduralBody();
  TriangleMesh garment = body.mesh;
  SkinTransferOptions exact;
  exact.smoothing_length = 0.0;
  exact.min_weight = 0.0;
  const SkinWeights on_body = TransferSkinWeights(body, garment, exact);
  SkinTransferOptions loose = exact;
  loose.smoothing_iterations = 50;
  loose.loose_distance = 0.02;
  const SkinWeights smoothed = TransferSkinWeights(body, garment, loose);
  // On the body (distance 0): no step at all, the weights stay exact.
  for (int v = 0; v < garment.num_vertices(); v += 53) {
    ASSERT_EQ(smoothed.offsets[v + 1] - smoothed.offsets[v], on_body.offsets[v + 1] - on_body.offsets[v]);
    for (int k = smoothed.offsets[v]; k < smoothed.offsets[v + 1]; ++k) {
      EXPECT_EQ(smoothed.joint[k], on_body.joint[k]);
      EXPECT_NEAR(smoothed.value[k], on_body.value[k], 1e-12);
    }
  }
}

// Mean over the first n vertices of |w_a - w_b| (dense rows).
double MeanWeightDifference(const SkinWeights& a, const SkinWeights& b, int n, int num_joints) {
  double total = 0.0;
  for (int v = 0; v < n; ++v) {
    Eigen::VectorXd d = Eigen::VectorXd::Zero(num_joints);
    for (int k = a.offsets[v]; k < a.offsets[v + 1]; ++k) d[a.joint[k]] += a.value[k];
    for (int k = b.offsets[v]; k < b.offsets[v + 1]; ++k) d[b.joint[k]] -= b.value[k];
    total += d.cwiseAbs().sum() / n;
  }
  return total;
}

double MeanEdgeLength(const TriangleMesh& mesh) {
  const Eigen::Matrix2Xi edges = UniqueEdges(mesh);
  double total = 0.0;
  for (Eigen::Index e = 0; e < edges.cols(); ++e)
    total += (mesh.vertices.col(edges(0, e)) - mesh.vertices.col(edges(1, e))).norm();
  return total / static_cast<double>(edges.cols());
}

TEST(SkinTransferTest, AFinerMeshingOfAGarmentGetsTheSameWeights) {
  // A sleeve-like tube over the body's seams and the same tube subdivided
  // (its vertices first): diffusion over the surface gives the tube's
  // vertices about the same weights in both; a fixed count of steps
  // reaches half as far on the finer one.
  const SkinnedBody body = MakeProceduralBody();
  const TriangleMesh coarse = MakeTube(0.15, 0.1, 0.4, 24, 8);
  const TriangleMesh fine = SubdivideMidpoint(coarse);
  ASSERT_TRUE(fine.vertices.leftCols(coarse.num_vertices()).isApprox(coarse.vertices));
  const int joints = body.skeleton.num_joints();
  SkinTransferOptions by_length;
  by_length.smoothing = SkinSmoothing::kSurface;
  by_length.loose_distance = 0.0;
  by_length.smoothing_length = 0.15;
  SkinTransferOptions steps_by_length = by_length;
  steps_by_length.smoothing = SkinSmoothing::kEdgeSteps;
  EXPECT_NEAR(SkinSmoothingSteps(fine, steps_by_length), 4 * SkinSmoothingSteps(coarse, steps_by_length), 4);
  const double length_gap =
      MeanWeightDifference(TransferSkinWeights(body, coarse, by_length), TransferSkinWeights(body, fine, by_length),
                           coarse.num_vertices(), joints);
  // The Jacobi count that spreads as far on the coarse tube, (L / h)^2.
  SkinTransferOptions by_steps = by_length;
  by_steps.smoothing_iterations = static_cast<int>(std::lround(std::pow(0.15 / MeanEdgeLength(coarse), 2)));
  EXPECT_EQ(by_steps.smoothing_iterations, SkinSmoothingSteps(coarse, steps_by_length));
  const double steps_gap =
      MeanWeightDifference(TransferSkinWeights(body, coarse, by_steps), TransferSkinWeights(body, fine, by_steps),
                           coarse.num_vertices(), joints);
  EXPECT_LT(length_gap, 0.5 * steps_gap) << length_gap << " " << steps_gap;
  // The diffusion time is calibrated to that count: on the coarse tube
  // both give about the same weights.
  const double calibration_gap =
      MeanWeightDifference(TransferSkinWeights(body, coarse, by_length), TransferSkinWeights(body, coarse, by_steps),
                           coarse.num_vertices(), joints);
  EXPECT_LT(calibration_gap, 0.5 * steps_gap) << calibration_gap;
  EXPECT_GT(steps_gap, 0.01);
}

TEST(SkinTransferTest, ResamplingGivesAGradedMeshingTheWeightsOfAUniformOne) {
  // The tube, and the same tube with its upper half's faces split (its
  // vertices first): Jacobi steps spread the weights by counts of edges,
  // so the half with short edges diffuses less far. Transferred on copies
  // split to a quarter of the edge, both meshings smooth on about the same
  // mesh.
  const SkinnedBody body = MakeProceduralBody();
  const TriangleMesh tube = MakeTube(0.15, 0.1, 0.4, 24, 8);
  TriangleMesh graded = tube;
  auto stretch = [](double y, double f) { return y < 0.25 ? y : 0.25 + f * (y - 0.25); };
  for (int v = 0; v < graded.num_vertices(); ++v) graded.vertices(1, v) = stretch(graded.vertices(1, v), 3.0);
  const double h = MeanEdgeLength(tube);
  graded = SplitLongEdges(graded, 1.5 * h);
  for (int v = 0; v < graded.num_vertices(); ++v) graded.vertices(1, v) = stretch(graded.vertices(1, v), 1.0 / 3.0);
  ASSERT_GT(graded.num_vertices(), tube.num_vertices());
  ASSERT_TRUE(graded.vertices.leftCols(tube.num_vertices()).isApprox(tube.vertices));
  const int joints = body.skeleton.num_joints();
  SkinTransferOptions own;
  own.loose_distance = 0.0;
  own.smoothing_length = 0.15;
  const double own_gap = MeanWeightDifference(TransferSkinWeights(body, tube, own),
                                              TransferSkinWeights(body, graded, own), tube.num_vertices(), joints);
  SkinTransferOptions resampled = own;
  resampled.resample_edge_length = 0.25 * h;
  const SkinWeights tube_resampled = TransferSkinWeights(body, tube, resampled);
  ASSERT_EQ(tube_resampled.num_vertices(), tube.num_vertices());
  const double resampled_gap =
      MeanWeightDifference(tube_resampled, TransferSkinWeights(body, graded, resampled), tube.num_vertices(), joints);
  EXPECT_GT(own_gap, 0.004);
  EXPECT_LT(resampled_gap, 0.3 * own_gap) << resampled_gap << " " << own_gap;
  resampled.resample_edge_length = -1.0;
  EXPECT_THROW(TransferSkinWeights(body, tube, resampled), std::invalid_argument);
}

TEST(SkinTransferTest, RejectsEmptyAndNonFiniteGarments) {
  const SkinnedBody body = MakeProceduralBody();
  EXPECT_THROW(TransferSkinWeights(body, TriangleMesh{}), std::invalid_argument);
  TriangleMesh garment = body.mesh;
  garment.vertices(1, 4) = std::nan("");
  EXPECT_THROW(TransferSkinWeights(body, garment), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
