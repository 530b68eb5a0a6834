#include "drape/body/makehuman_body.h"

#include <cctype>
#include <filesystem>

#include <gtest/gtest.h>

#include "drape/body/makehuman_test_body.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

const fs::path kBodyDir = fs::path(POLYFIT_SHARED_DATA_DIR) / "drape/body";

class MakeHumanBodyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    body_ = SharedMakeHumanBody(kBodyDir);
    if (body_ == nullptr) GTEST_SKIP() << "shared data absent: " << kBodyDir;
  }
  const SkinnedBody* body_ = nullptr;
};

TEST_F(MakeHumanBodyTest, MeshRigAndWeights) {
  const SkinnedBody& b = *body_;
  EXPECT_EQ(b.mesh.num_vertices(), 13380);
  EXPECT_EQ(b.mesh.num_faces(), 2 * 13378);
  EXPECT_TRUE(b.mesh.Validate().empty());
  const double height = b.mesh.vertices.row(1).maxCoeff() - b.mesh.vertices.row(1).minCoeff();
  EXPECT_GT(height, 1.5);
  EXPECT_LT(height, 2.0);
  ASSERT_EQ(b.skeleton.num_joints(), 31);
  EXPECT_EQ(b.skeleton.parents[0], -1);
  for (int j = 1; j < b.skeleton.num_joints(); ++j) EXPECT_LT(b.skeleton.parents[j], j);
  const int head = b.skeleton.Find("Head"), hips = b.skeleton.Find("Hips");
  ASSERT_GE(head, 0);
  EXPECT_GT(b.skeleton.rest_heads(1, head), b.skeleton.rest_heads(1, hips) + 0.4);
  for (int v = 0; v < b.mesh.num_vertices(); ++v) {
    double sum = 0.0;
    for (int k = b.weight_offsets[v]; k < b.weight_offsets[v + 1]; ++k) sum += b.weight_value[k];
    ASSERT_NEAR(sum, 1.0, 1e-9) << "vertex " << v;
  }
}

TEST_F(MakeHumanBodyTest, JointsAreMirrorSymmetric) {
  // The base mesh is symmetric about x = 0, so are its joint cubes. (The
  // rig file's default positions belong to MPFB's default shape, not to the
  // raw base mesh, and differ by up to 6 cm.)
  const Skeleton& s = body_->skeleton;
  int pairs = 0;
  for (int j = 0; j < s.num_joints(); ++j) {
    std::string mirror = s.names[j];
    if (mirror.rfind("Left", 0) == 0) {
      mirror.replace(0, 4, "Right");
    } else if (mirror.rfind("L", 0) == 0 && mirror.size() > 1 && std::isupper(mirror[1])) {
      mirror.replace(0, 1, "R");
    } else {
      continue;
    }
    const int k = s.Find(mirror);
    ASSERT_GE(k, 0) << mirror;
    const Eigen::Vector3d a = s.rest_heads.col(j), b = s.rest_heads.col(k);
    EXPECT_LT((a - Eigen::Vector3d(-b.x(), b.y(), b.z())).norm(), 1e-3) << s.names[j];
    ++pairs;
  }
  EXPECT_EQ(pairs, 12);
}

TEST_F(MakeHumanBodyTest, SkinningFollowsTheBones) {
  const SkinnedBody& b = *body_;
  std::vector<Eigen::Isometry3d> identity(b.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  EXPECT_LT((SkinVertices(b, identity) - b.mesh.vertices).cwiseAbs().maxCoeff(), 1e-12);
  // Turn the left forearm and everything below it 90 degrees about its head.
  const int forearm = b.skeleton.Find("LeftForeArm");
  ASSERT_GE(forearm, 0);
  const Eigen::Vector3d pivot = b.skeleton.rest_heads.col(forearm);
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.rotate(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  turn.pretranslate(pivot - turn.linear() * pivot);
  std::vector<Eigen::Isometry3d> pose = identity;
  std::vector<bool> below(b.skeleton.num_joints(), false);
  for (int j = 0; j < b.skeleton.num_joints(); ++j) {
    below[j] = j == forearm || (b.skeleton.parents[j] >= 0 && below[b.skeleton.parents[j]]);
    if (below[j]) pose[j] = turn;
  }
  const Eigen::Matrix3Xd posed = SkinVertices(b, pose);
  int moved = 0;
  for (int v = 0; v < b.mesh.num_vertices(); ++v) {
    bool all_below = true;
    for (int k = b.weight_offsets[v]; k < b.weight_offsets[v + 1]; ++k) all_below &= below[b.weight_joint[k]];
    if (!all_below) continue;
    EXPECT_LT((posed.col(v) - turn * Eigen::Vector3d(b.mesh.vertices.col(v))).norm(), 1e-12);
    ++moved;
  }
  EXPECT_GT(moved, 500);  // the hand and fingers
}

}  // namespace
}  // namespace polyfit
