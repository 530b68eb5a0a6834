#include "drape/motion/retarget.h"

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"

namespace polyfit {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A T-pose clip for the procedural body's joint names, twice its size,
// facing +X (its left is -Z), with its root turned by 30 degrees at frame 0.
// Frame 1: the root 1 unit further along the clip's x and the left elbow bent.
MotionClip MakeTPoseClip() {
  MotionClip clip;
  clip.fps = 30.0;
  const auto add = [&](const char* name, int parent, const Eigen::Vector3d& offset_forward_x) {
    clip.joints.push_back({name, parent, 2.0 * offset_forward_x});
  };
  // Offsets with left = -Z, up = +Y, forward = +X.
  add("Hips", -1, {0, 0, 0});
  add("Spine", 0, {0, 0.25, 0});
  add("Neck", 1, {0, 0.27, 0});
  add("Head", 2, {0, 0.08, 0});
  add("LeftArm", 1, {0, 0.2, -0.18});
  add("LeftForeArm", 4, {0, 0, -0.3});
  add("RightArm", 1, {0, 0.2, 0.18});
  add("RightForeArm", 6, {0, 0, 0.3});
  add("LeftUpLeg", 0, {0, -0.05, -0.1});
  add("LeftLeg", 8, {0, -0.45, 0});
  add("RightUpLeg", 0, {0, -0.05, 0.1});
  add("RightLeg", 10, {0, -0.45, 0});
  MotionFrame frame;
  frame.root_translation = Eigen::Vector3d(0, 2.0, 0);
  frame.local_rotations.assign(clip.joints.size(), Eigen::Quaterniond::Identity());
  frame.local_rotations[0] = Eigen::AngleAxisd(kPi / 6, Eigen::Vector3d::UnitY());
  clip.frames.push_back(frame);
  frame.root_translation += Eigen::Vector3d(1, 0, 0);
  frame.local_rotations[5] = Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitY());
  clip.frames.push_back(frame);
  return clip;
}

std::vector<Eigen::Vector3d> PosedHeads(const Skeleton& skeleton, const std::vector<Eigen::Isometry3d>& pose) {
  std::vector<Eigen::Vector3d> heads;
  for (int j = 0; j < skeleton.num_joints(); ++j)
    heads.push_back(pose[j] * Eigen::Vector3d(skeleton.rest_heads.col(j)));
  return heads;
}

TEST(MotionRetargeterTest, BlendZeroIsTheRestPose) {
  const SkinnedBody body = MakeProceduralBody();
  const MotionRetargeter retargeter(MakeTPoseClip(), body.skeleton);
  EXPECT_EQ(retargeter.num_matched_joints(), 12);
  for (const Eigen::Isometry3d& t : retargeter.Pose(1, 0.0)) {
    EXPECT_LT((t.matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
  }
}

TEST(MotionRetargeterTest, TPoseClipPutsTheRigInATPoseFacingItsOwnWay) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& skeleton = body.skeleton;
  const MotionRetargeter retargeter(MakeTPoseClip(), skeleton);
  const std::vector<Eigen::Vector3d> heads = PosedHeads(skeleton, retargeter.Pose(0));
  // The rig's left is +X: the left upper arm points there, horizontally,
  // although the clip faced +X and was turned by 30 degrees.
  const int arm = skeleton.Find("LeftArm"), forearm = skeleton.Find("LeftForeArm");
  const Eigen::Vector3d upper_arm = (heads[forearm] - heads[arm]).normalized();
  EXPECT_NEAR(upper_arm.x(), 1.0, 1e-9);
  // Legs straight down.
  const int up_leg = skeleton.Find("LeftUpLeg"), leg = skeleton.Find("LeftLeg");
  EXPECT_NEAR((heads[leg] - heads[up_leg]).normalized().y(), -1.0, 1e-9);
  // The root stays where it rests at frame 0.
  EXPECT_LT((heads[0] - Eigen::Vector3d(skeleton.rest_heads.col(0))).norm(), 1e-12);
}

TEST(MotionRetargeterTest, KeepsBoneLengthsAndScalesTheRootPath) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& skeleton = body.skeleton;
  const MotionClip clip = MakeTPoseClip();
  const MotionRetargeter retargeter(clip, skeleton);
  const std::vector<Eigen::Vector3d> h0 = PosedHeads(skeleton, retargeter.Pose(0));
  const std::vector<Eigen::Vector3d> h1 = PosedHeads(skeleton, retargeter.Pose(1));
  for (int j = 1; j < skeleton.num_joints(); ++j) {
    const int p = skeleton.parents[j];
    const double rest = (skeleton.rest_heads.col(j) - skeleton.rest_heads.col(p)).norm();
    EXPECT_NEAR((h1[j] - h1[p]).norm(), rest, 1e-9) << skeleton.names[j];
  }
  // The procedural rig has no feet, so the scale is the ratio of all bone
  // lengths; the clip moved 1 unit along its own +X.
  const Eigen::Vector3d step = h1[0] - h0[0];
  double rig_length = 0.0, clip_length = 0.0;
  for (int j = 1; j < skeleton.num_joints(); ++j) {
    rig_length += (skeleton.rest_heads.col(j) - skeleton.rest_heads.col(skeleton.parents[j])).norm();
    clip_length += clip.joints[j].offset.norm();
  }
  const double scale = rig_length / clip_length;
  EXPECT_NEAR(step.norm(), scale, 1e-9);
  EXPECT_NEAR(step.y(), 0.0, 1e-12);
  // Heading: the clip's forward (+X) turned by 30 degrees maps to the rig's
  // forward (+Z), so the clip's +X maps to +Z turned back by 30 degrees.
  const Eigen::Vector3d expected =
      scale * (Eigen::AngleAxisd(-kPi / 6, Eigen::Vector3d::UnitY()) * Eigen::Vector3d::UnitZ());
  EXPECT_LT((step - expected).norm(), 1e-9);
  // The bent elbow: the left forearm turned by 90 degrees about the vertical.
  const int forearm = skeleton.Find("LeftForeArm");
  const Eigen::Vector3d forearm_dir = retargeter.Pose(1)[forearm].linear() *
                                      (retargeter.Pose(0)[forearm].linear().transpose() * Eigen::Vector3d::UnitX());
  EXPECT_NEAR(std::abs(forearm_dir.z()), 1.0, 1e-9);
}

TEST(MotionRetargeterTest, RejectsAClipWithoutTheRoot) {
  const SkinnedBody body = MakeProceduralBody();
  MotionClip clip = MakeTPoseClip();
  clip.joints[0].name = "Pelvis";
  EXPECT_THROW(MotionRetargeter(clip, body.skeleton), BvhError);
  clip.frames.clear();
  EXPECT_THROW(MotionRetargeter(clip, body.skeleton), BvhError);
}

#ifdef POLYFIT_SHARED_DATA_DIR
TEST(MotionRetargeterTest, CmuWalkOnMakeHumanKeepsFeetOnTheGround) {
  const std::filesystem::path data(POLYFIT_SHARED_DATA_DIR);
  const std::filesystem::path body_dir = data / "drape" / "body";
  const std::filesystem::path clip_path = data / "drape" / "motion" / "02_01.bvh";
  if (!std::filesystem::exists(body_dir) || !std::filesystem::exists(clip_path)) {
    GTEST_SKIP() << "needs " << body_dir << " and " << clip_path;
  }
  const SkinnedBody body = LoadMakeHumanBody(body_dir.string());
  const MotionClip clip = ReadBvh(clip_path.string(), 0.056444).Resampled(30.0);
  const MotionRetargeter retargeter(clip, body.skeleton);
  EXPECT_EQ(retargeter.num_matched_joints(), 31);
  const double rest_floor = body.mesh.vertices.row(1).minCoeff();
  const double rest_top = body.mesh.vertices.row(1).maxCoeff();
  for (int f = 0; f < retargeter.num_frames(); f += 5) {
    const Eigen::Matrix3Xd posed = SkinVertices(body, retargeter.Pose(f));
    ASSERT_TRUE(posed.allFinite());
    // One foot is on the floor (within 6 cm), the head stays up.
    EXPECT_NEAR(posed.row(1).minCoeff(), rest_floor, 0.06) << "frame " << f;
    EXPECT_GT(posed.row(1).maxCoeff(), rest_top - 0.12) << "frame " << f;
  }
  // Frame 0 faces as the rest pose does: the hips' left stays along +X.
  const std::vector<Eigen::Vector3d> heads = PosedHeads(body.skeleton, retargeter.Pose(0));
  const Eigen::Vector3d left = heads[body.skeleton.Find("LeftUpLeg")] - heads[body.skeleton.Find("RightUpLeg")];
  EXPECT_GT(left.normalized().x(), std::cos(20.0 * kPi / 180.0));
  // The walk moves about 1.26 m/s (the clip's mean root speed) on this body.
  double speed = 0.0;
  for (int f = 0; f < retargeter.num_frames(); ++f)
    speed += retargeter.RootVelocity(f).norm() / retargeter.num_frames();
  EXPECT_GT(speed, 0.8);
  EXPECT_LT(speed, 1.6);
}
#endif

}  // namespace
}  // namespace polyfit
