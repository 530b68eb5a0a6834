#include "drape/motion/blend_pose.h"

#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"
#include "drape/motion/perturb_pose.h"

namespace polyfit {
namespace {

// A connected pose: the whole body moved rigidly, then each joint turned
// about its rest head relative to its parent (TurnJointsInRest).
std::vector<Eigen::Isometry3d> ConnectedPose(const Skeleton& skeleton) {
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
  moved.translation() = Eigen::Vector3d(0.1, -0.05, 0.2);
  std::vector<Eigen::Matrix3d> turns(skeleton.num_joints());
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    turns[j] = Eigen::AngleAxisd(0.3 + 0.1 * j, Eigen::Vector3d(1.0, 0.3 * j, -0.4).normalized()).toRotationMatrix();
  }
  return TurnJointsInRest(skeleton.parents, skeleton.rest_heads,
                          std::vector<Eigen::Isometry3d>(skeleton.num_joints(), moved), turns);
}

TEST(BlendFromRestTest, GoesFromRestToThePoseWithBonesConnected) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& s = body.skeleton;
  const std::vector<Eigen::Isometry3d> pose = ConnectedPose(s);
  for (const auto& t : BlendFromRest(s, pose, 0.0)) EXPECT_TRUE(t.isApprox(Eigen::Isometry3d::Identity(), 1e-12));
  const std::vector<Eigen::Isometry3d> full = BlendFromRest(s, pose, 1.0);
  for (int j = 0; j < s.num_joints(); ++j) EXPECT_TRUE(full[j].isApprox(pose[j], 1e-12)) << j;
  const std::vector<Eigen::Isometry3d> half = BlendFromRest(s, pose, 0.5);
  for (int j = 0; j < s.num_joints(); ++j) {
    // Half the rotation angle of the pose's own.
    const double angle = Eigen::AngleAxisd(pose[j].linear()).angle();
    EXPECT_NEAR(Eigen::AngleAxisd(half[j].linear()).angle(), 0.5 * angle, 1e-9) << j;
    const int p = s.parents[j];
    if (p < 0) continue;
    // The child's head where its parent carries it.
    EXPECT_LT((half[j] * s.rest_heads.col(j) - half[p] * s.rest_heads.col(j)).norm(), 1e-12) << j;
  }
  EXPECT_THROW(BlendFromRest(s, pose, 1.5), std::invalid_argument);
  EXPECT_THROW(BlendFromRest(s, {pose.front()}, 0.5), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
