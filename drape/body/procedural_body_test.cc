#include "drape/body/procedural_body.h"

#include <gtest/gtest.h>

#include "drape/collision/signed_distance.h"

namespace polyfit {
namespace {

TEST(ProceduralBodyTest, ClosedOutwardCapsulesWithNormalisedWeights) {
  const SkinnedBody body = MakeProceduralBody();
  EXPECT_TRUE(body.mesh.Validate().empty());
  EXPECT_EQ(body.skeleton.num_joints(), 12);
  for (int j = 1; j < body.skeleton.num_joints(); ++j) EXPECT_LT(body.skeleton.parents[j], j);
  const double height = body.mesh.vertices.row(1).maxCoeff() - body.mesh.vertices.row(1).minCoeff();
  EXPECT_NEAR(height, 1.815, 1e-9);  // head top 0.86 m, soles -0.955 m
  for (int v = 0; v < body.mesh.num_vertices(); ++v) {
    double sum = 0.0;
    for (int k = body.weight_offsets[v]; k < body.weight_offsets[v + 1]; ++k) sum += body.weight_value[k];
    ASSERT_NEAR(sum, 1.0, 1e-12);
  }
  // Outward faces: the body is inside, the space around it outside.
  const BodySignedDistance distance(body.mesh);
  EXPECT_LT(distance.Query(Eigen::Vector3d(0, 0.1, 0)).distance, -0.1);      // the belly
  EXPECT_LT(distance.Query(Eigen::Vector3d(0.1, -0.7, 0)).distance, -0.03);  // a shin
  EXPECT_NEAR(distance.Query(Eigen::Vector3d(0, 0.1, 0.3)).distance, 0.16, 0.01);
  EXPECT_GT(distance.Query(Eigen::Vector3d(0, 1.2, 0)).distance, 0.3);
}

TEST(ProceduralBodyTest, SkinningBendsTheElbow) {
  const SkinnedBody body = MakeProceduralBody();
  const int forearm = body.skeleton.Find("LeftForeArm");
  const Eigen::Vector3d pivot = body.skeleton.rest_heads.col(forearm);
  Eigen::Isometry3d bend = Eigen::Isometry3d::Identity();
  bend.rotate(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()));
  bend.pretranslate(pivot - bend.linear() * pivot);
  std::vector<Eigen::Isometry3d> pose(body.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  pose[forearm] = bend;
  const Eigen::Matrix3Xd posed = SkinVertices(body, pose);
  // The hand end of the forearm moved (bent forward), the shoulder did not.
  int moved = 0, still = 0;
  for (int v = 0; v < body.mesh.num_vertices(); ++v) {
    const double shift = (posed.col(v) - body.mesh.vertices.col(v)).norm();
    bool only_forearm = true, touches = false;
    for (int k = body.weight_offsets[v]; k < body.weight_offsets[v + 1]; ++k) {
      only_forearm &= body.weight_joint[k] == forearm;
      touches |= body.weight_joint[k] == forearm;
    }
    if (only_forearm) {
      EXPECT_LT((posed.col(v) - bend * Eigen::Vector3d(body.mesh.vertices.col(v))).norm(), 1e-12);
      moved += shift > 0.05;
    } else if (!touches) {
      EXPECT_EQ(shift, 0.0);
      ++still;
    }
  }
  EXPECT_GT(moved, 20);
  EXPECT_GT(still, 1000);
}

}  // namespace
}  // namespace polyfit
