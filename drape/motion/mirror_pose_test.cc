#include "drape/motion/mirror_pose.h"

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"

namespace polyfit {
namespace {

TEST(MirrorPoseTest, AMirroredPosePlacesEachJointAtItsPartnersMirrorImage) {
  const SkinnedBody body = MakeProceduralBody();
  const std::vector<int> map = MirrorJointMap(body.skeleton);
  const int left_arm = body.skeleton.Find("LeftArm"), right_arm = body.skeleton.Find("RightArm");
  ASSERT_GE(left_arm, 0);
  EXPECT_EQ(map[left_arm], right_arm);
  EXPECT_EQ(map[right_arm], left_arm);
  EXPECT_EQ(map[0], 0);
  // An asymmetric pose: every joint turned and moved its own way.
  std::vector<Eigen::Isometry3d> pose(body.skeleton.num_joints());
  for (int j = 0; j < body.skeleton.num_joints(); ++j) {
    pose[j] = Eigen::Isometry3d::Identity();
    pose[j].linear() =
        Eigen::AngleAxisd(0.2 + 0.1 * j, Eigen::Vector3d(1.0, 0.3 * j, -0.5).normalized()).toRotationMatrix();
    pose[j].translation() = Eigen::Vector3d(0.01 * j, -0.02, 0.03 * (j % 3));
  }
  const std::vector<Eigen::Isometry3d> mirrored = MirrorPose(pose, map);
  const Eigen::Vector3d flip(-1.0, 1.0, 1.0);
  for (int j = 0; j < body.skeleton.num_joints(); ++j) {
    const int k = map[j];
    // The procedural rig is symmetric: h_m(j) = M h_j.
    ASSERT_LT((body.skeleton.rest_heads.col(k) - body.skeleton.rest_heads.col(j).cwiseProduct(flip)).norm(), 1e-12);
    const Eigen::Vector3d original = pose[k] * body.skeleton.rest_heads.col(k);
    const Eigen::Vector3d image = mirrored[j] * body.skeleton.rest_heads.col(j);
    EXPECT_LT((image - original.cwiseProduct(flip)).norm(), 1e-12) << body.skeleton.names[j];
    EXPECT_NEAR(mirrored[j].linear().determinant(), 1.0, 1e-12);
  }
  // Twice is the identity.
  const std::vector<Eigen::Isometry3d> twice = MirrorPose(mirrored, map);
  for (int j = 0; j < body.skeleton.num_joints(); ++j) {
    EXPECT_LT((twice[j].matrix() - pose[j].matrix()).norm(), 1e-12);
  }
  Skeleton lopsided = body.skeleton;
  lopsided.names[right_arm] = "Elbow";
  EXPECT_THROW(MirrorJointMap(lopsided), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
