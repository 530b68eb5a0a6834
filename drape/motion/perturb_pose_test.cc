#include "drape/motion/perturb_pose.h"

#include <cmath>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"

namespace polyfit {
namespace {

// A connected pose by forward kinematics: each joint turned about its rest
// head relative to its parent, the root also moved.
std::vector<Eigen::Isometry3d> ConnectedPose(const Skeleton& skeleton) {
  std::vector<Eigen::Isometry3d> pose(skeleton.num_joints());
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
    local.linear() =
        Eigen::AngleAxisd(0.1 + 0.05 * j, Eigen::Vector3d(1.0, 0.2 * j, -0.4).normalized()).toRotationMatrix();
    local.translation() = skeleton.rest_heads.col(j) - local.linear() * skeleton.rest_heads.col(j);
    const int p = skeleton.parents[j];
    if (p < 0) local.translation() += Eigen::Vector3d(0.1, -0.05, 0.2);
    pose[j] = p < 0 ? local : pose[p] * local;
  }
  return pose;
}

TEST(PosePerturbationTest, TurnsEachJointAboutItsHeadWithinTheAmplitude) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& s = body.skeleton;
  const std::vector<Eigen::Isometry3d> pose = ConnectedPose(s);
  const double amplitude = 10.0 * M_PI / 180.0;
  const PosePerturbation perturbation(s, amplitude, 7);
  for (const double t : {0.0, 0.37, 2.5}) {
    const std::vector<Eigen::Isometry3d> out = perturbation.Apply(pose, t);
    EXPECT_LT((out[0].matrix() - pose[0].matrix()).norm(), 1e-12);  // the root keeps its transform
    for (int j = 1; j < s.num_joints(); ++j) {
      const int p = s.parents[j];
      // Bones stay connected: the joint's head moves with its parent.
      EXPECT_LT((out[j] * s.rest_heads.col(j) - out[p] * s.rest_heads.col(j)).norm(), 1e-12) << s.names[j];
      // Relative to its parent, the joint turned by exactly delta_j(t).
      const Eigen::Matrix3d local = pose[p].linear().transpose() * pose[j].linear();
      const Eigen::Matrix3d turned = out[p].linear().transpose() * out[j].linear();
      const Eigen::AngleAxisd extra(local.transpose() * turned);
      const Eigen::Vector3d delta = perturbation.Angles(j, t);
      EXPECT_NEAR(extra.angle(), delta.norm(), 1e-9) << s.names[j];
      EXPECT_LE(delta.cwiseAbs().maxCoeff(), amplitude + 1e-12);
    }
  }
  // Smooth in time: |d delta / dt| <= 2 pi A f_max per axis (f_max = 1 Hz).
  for (int j = 1; j < s.num_joints(); ++j) {
    const Eigen::Vector3d rate = (perturbation.Angles(j, 1.0 + 1e-4) - perturbation.Angles(j, 1.0)) / 1e-4;
    EXPECT_LE(rate.cwiseAbs().maxCoeff(), 2.0 * M_PI * amplitude + 1e-6);
  }
  // Zero amplitude leaves the pose; a bad amplitude is refused.
  const std::vector<Eigen::Isometry3d> same = PosePerturbation(s, 0.0, 7).Apply(pose, 1.0);
  for (int j = 0; j < s.num_joints(); ++j) EXPECT_LT((same[j].matrix() - pose[j].matrix()).norm(), 1e-12);
  EXPECT_THROW(PosePerturbation(s, -1.0, 7), std::invalid_argument);
  EXPECT_THROW(PosePerturbation(s, NAN, 7), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
