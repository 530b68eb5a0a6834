#include "drape/motion/bvh_motion.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "polyfit/util/scoped_temp_dir.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

// A two-bone arm: root at (0, 1, 0), elbow 1 along x, hand 1 further.
constexpr char kArm[] = R"(HIERARCHY
ROOT Shoulder
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Elbow
  {
    OFFSET 1 0 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 1 0 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.5
0 1 0 0 0 0 0 0 0
0 1 0 90 0 0 0 0 0
2 1 0 90 0 0 90 0 0
)";

class BvhTest : public ::testing::Test {
 protected:
  std::string Write(const std::string& text) {
    const std::string path = dir_.File("clip.bvh");
    std::ofstream(path) << text;
    return path;
  }
  std::string Error(const std::string& text) {
    try {
      ReadBvh(Write(text));
    } catch (const BvhError& e) {
      return e.what();
    }
    return "(no error)";
  }
  ScopedTempDir dir_{"polyfit_bvh"};
};

TEST_F(BvhTest, ForwardKinematicsOfATwoBoneArm) {
  const MotionClip clip = ReadBvh(Write(kArm), 0.5);  // half-unit metres
  ASSERT_EQ(clip.num_joints(), 2);
  ASSERT_EQ(clip.num_frames(), 3);
  EXPECT_DOUBLE_EQ(clip.fps, 2.0);
  EXPECT_EQ(clip.FindJoint("Elbow"), 1);
  EXPECT_EQ(clip.joints[1].parent, 0);
  // Frame 0: elbow at (0.5, 0.5, 0). Frame 1: the shoulder turned 90 degrees
  // about z puts it at (0, 1, 0).
  EXPECT_LT((clip.GlobalTransforms(0)[1].translation() - Eigen::Vector3d(0.5, 0.5, 0)).norm(), 1e-12);
  EXPECT_LT((clip.GlobalTransforms(1)[1].translation() - Eigen::Vector3d(0, 1.0, 0)).norm(), 1e-12);
  // Frame 2: moved 1 m along x; the elbow's own z turn points the forearm
  // back along -x.
  const std::vector<Eigen::Isometry3d> g = clip.GlobalTransforms(2);
  EXPECT_LT((g[1].translation() - Eigen::Vector3d(1.0, 1.0, 0)).norm(), 1e-12);
  EXPECT_LT((g[1] * Eigen::Vector3d(0.5, 0, 0) - Eigen::Vector3d(0.5, 1.0, 0)).norm(), 1e-12);
  EXPECT_LT((clip.RootVelocity(2) - Eigen::Vector3d(2.0, 0, 0)).norm(), 1e-12);
}

TEST_F(BvhTest, ResamplingInterpolatesRotationsAndPositions) {
  const MotionClip clip = ReadBvh(Write(kArm));
  const MotionClip fine = clip.Resampled(4.0);  // twice the rate
  ASSERT_EQ(fine.num_frames(), 5);
  // Halfway between frames 0 and 1: the shoulder at 45 degrees.
  const Eigen::Vector3d elbow = fine.GlobalTransforms(1)[1].translation();
  EXPECT_LT((elbow - Eigen::Vector3d(std::sqrt(0.5), 1 + std::sqrt(0.5), 0)).norm(), 1e-12);
  // Coincident times reproduce the source.
  EXPECT_LT((fine.GlobalTransforms(4)[1].translation() - clip.GlobalTransforms(2)[1].translation()).norm(), 1e-12);
}

TEST_F(BvhTest, MalformedFilesAreNamed) {
  std::string text = kArm;
  EXPECT_NE(Error(text.replace(text.find("0 1 0 90 0 0 0 0 0"), 18, "0 1 0 90 0 0 0 0"))
                .find("line 20: frame 1 has 8 values, expected 9"),
            std::string::npos);
  text = kArm;
  EXPECT_NE(Error(text.replace(text.find("Xrotation\n  JOINT"), 9, "Wrotation")).find("unknown channel 'Wrotation'"),
            std::string::npos);
  text = kArm;
  EXPECT_NE(Error(text.replace(text.find("Frames: 3"), 9, "Frames: 4")).find("ends after 3 of 4 frames"),
            std::string::npos);
  EXPECT_NE(Error("HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 0\n").find("ends inside HIERARCHY"),
            std::string::npos);
  EXPECT_NE(Error("not a bvh").find("expected 'HIERARCHY'"), std::string::npos);
  text = kArm;
  EXPECT_NE(Error(text.replace(text.find("2 1 0 90"), 1, "nan")).find("bad value 'nan'"), std::string::npos);
  try {
    ReadBvh(dir_.File("absent.bvh"));
    FAIL();
  } catch (const BvhError& e) {
    EXPECT_NE(std::string(e.what()).find("absent.bvh"), std::string::npos);
  }
}

#ifdef POLYFIT_SHARED_DATA_DIR
TEST(BvhCmuTest, WalkClipAt30Fps) {
  const fs::path path = fs::path(POLYFIT_SHARED_DATA_DIR) / "drape/motion/02_01.bvh";
  if (!fs::exists(path)) GTEST_SKIP() << "shared data absent: " << path;
  const MotionClip clip = ReadBvh(path.string(), 0.056444);
  EXPECT_EQ(clip.num_joints(), 31);
  EXPECT_EQ(clip.num_frames(), 343);
  EXPECT_NEAR(clip.fps, 120.0, 0.01);
  const MotionClip at30 = clip.Resampled(30.0);
  EXPECT_EQ(at30.num_frames(), 86);  // 342 / 120 s * 30 + 1
  // A walk: the root moves about 1.3 m/s, the body is about 1.7 m tall.
  double speed = 0.0;
  for (int f = 0; f < at30.num_frames(); ++f) speed += at30.RootVelocity(f).norm() / at30.num_frames();
  EXPECT_GT(speed, 0.5);
  EXPECT_LT(speed, 2.5);
  const std::vector<Eigen::Isometry3d> g = at30.GlobalTransforms(0);
  const int head = at30.FindJoint("Head"), foot = at30.FindJoint("LeftFoot");
  ASSERT_GE(head, 0);
  ASSERT_GE(foot, 0);
  const double height = (g[head].translation() - g[foot].translation()).norm();
  EXPECT_GT(height, 1.2);
  EXPECT_LT(height, 1.9);
}
#endif

}  // namespace
}  // namespace polyfit
