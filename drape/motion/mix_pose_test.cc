#include "drape/motion/mix_pose.h"

#include <cmath>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"

namespace polyfit {
namespace {

// A connected pose by forward kinematics, each joint turned about its rest
// head by an angle that depends on `phase`, the root moved too.
std::vector<Eigen::Isometry3d> ConnectedPose(const Skeleton& skeleton, double phase) {
  std::vector<Eigen::Isometry3d> pose(skeleton.num_joints());
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
    local.linear() = Eigen::AngleAxisd(phase + 0.05 * j, Eigen::Vector3d(1.0, 0.2 * j, -0.4).normalized())
                         .toRotationMatrix();
    local.translation() = skeleton.rest_heads.col(j) - local.linear() * skeleton.rest_heads.col(j);
    const int p = skeleton.parents[j];
    if (p < 0) local.translation() += Eigen::Vector3d(phase, -0.05, 0.2);
    pose[j] = p < 0 ? local : pose[p] * local;
  }
  return pose;
}

Eigen::Matrix3d Local(const std::vector<Eigen::Isometry3d>& pose, const Skeleton& s, int j) {
  return pose[s.parents[j]].linear().transpose() * pose[j].linear();
}

TEST(MixPosesTest, EachGroupMovesAsItsDonorAndBonesStayConnected) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& s = body.skeleton;
  const std::vector<int> groups = JointGroups(s, {"LeftArm", "Neck"});
  EXPECT_EQ(groups[s.Find("LeftArm")], 0);
  EXPECT_EQ(groups[s.Find("LeftForeArm")], 0);
  EXPECT_EQ(groups[s.Find("Neck")], 1);
  EXPECT_EQ(groups[s.Find("Head")], 1);
  EXPECT_EQ(groups[s.Find("RightArm")], -1);
  EXPECT_EQ(groups[s.Find("Hips")], -1);

  const auto base = ConnectedPose(s, 0.1), arm = ConnectedPose(s, 0.7), head = ConnectedPose(s, -0.4);
  const auto mixed = MixPoses(s, base, {&arm, &head}, groups);
  EXPECT_LT((mixed[0].matrix() - base[0].matrix()).norm(), 1e-12);
  for (int j = 1; j < s.num_joints(); ++j) {
    const auto& source = groups[j] == 0 ? arm : groups[j] == 1 ? head : base;
    EXPECT_LT((Local(mixed, s, j) - Local(source, s, j)).norm(), 1e-12) << s.names[j];
    const Eigen::Vector3d h = s.rest_heads.col(j);
    EXPECT_LT((mixed[j] * h - mixed[s.parents[j]] * h).norm(), 1e-12) << s.names[j];
  }
  // Ungrouped joints are exactly the base's.
  EXPECT_LT((mixed[s.Find("RightForeArm")].matrix() - base[s.Find("RightForeArm")].matrix()).norm(), 1e-12);
  // Mixing a pose with itself gives it back.
  const auto same = MixPoses(s, base, {&base, &base}, groups);
  for (int j = 0; j < s.num_joints(); ++j) EXPECT_LT((same[j].matrix() - base[j].matrix()).norm(), 1e-12);
}

TEST(MixPosesTest, NamesAMissingGroupRootAndRefusesBadSizes) {
  const SkinnedBody body = MakeProceduralBody();
  try {
    JointGroups(body.skeleton, {"LeftShoulder"});
    ADD_FAILURE() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("LeftShoulder"), std::string::npos);
  }
  const auto groups = JointGroups(body.skeleton, {"Neck"});
  const auto pose = ConnectedPose(body.skeleton, 0.2);
  const std::vector<Eigen::Isometry3d> short_pose(2);
  EXPECT_THROW(MixPoses(body.skeleton, pose, {&short_pose}, groups), std::invalid_argument);
  EXPECT_THROW(MixPoses(body.skeleton, pose, {}, groups), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
