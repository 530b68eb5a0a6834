#include "drape/motion/limb_excursion.h"

#include <cmath>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"

namespace polyfit {
namespace {

std::vector<Eigen::Isometry3d> RestPose(const Skeleton& s) {
  return std::vector<Eigen::Isometry3d>(s.num_joints(), Eigen::Isometry3d::Identity());
}

// Where the rest position of joint `child`'s head goes under `pose`.
Eigen::Vector3d Head(const Skeleton& s, const std::vector<Eigen::Isometry3d>& pose, const char* child) {
  const int j = s.Find(child);
  return pose[s.parents[j]] * s.rest_heads.col(j);
}

TEST(LimbExcursionTest, DefaultRangesTurnLimbsTheWayTheirNamesSay) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& s = body.skeleton;
  // One excursion at a time, held at its largest angle.
  auto at_max = [&](int i) {
    JointExcursion e = DefaultLimbExcursions()[i];
    e.min_angle = e.max_angle;
    return LimbExcursion(s, {e}, 1.0, 3).Apply(RestPose(s), 0.5);
  };
  const std::vector<Eigen::Isometry3d> rest = RestPose(s);
  // 0: the left arm raised sideways: the elbow up and out.
  Eigen::Vector3d moved = Head(s, at_max(0), "LeftForeArm") - Head(s, rest, "LeftForeArm");
  EXPECT_GT(moved.y(), 0.2);
  EXPECT_GT(Head(s, at_max(0), "LeftForeArm").y(), s.rest_heads.col(s.Find("LeftArm")).y());
  // 1: the left arm raised forwards: the elbow to +Z.
  EXPECT_GT((Head(s, at_max(1), "LeftForeArm") - Head(s, rest, "LeftForeArm")).z(), 0.15);
  // 2: the right arm raised sideways: the elbow up and further to -X.
  moved = Head(s, at_max(2), "RightForeArm") - Head(s, rest, "RightForeArm");
  EXPECT_GT(moved.y(), 0.2);
  // 4: the left hip flexed: the knee forwards; 5: spread: the knee out.
  EXPECT_GT((Head(s, at_max(4), "LeftLeg") - Head(s, rest, "LeftLeg")).z(), 0.3);
  EXPECT_GT((Head(s, at_max(5), "LeftLeg") - Head(s, rest, "LeftLeg")).x(), 0.15);
  EXPECT_LT((Head(s, at_max(7), "RightLeg") - Head(s, rest, "RightLeg")).x(), -0.15);
  // 10: the spine bent forwards: the neck to +Z.
  EXPECT_GT((Head(s, at_max(10), "Neck") - Head(s, rest, "Neck")).z(), 0.1);
}

TEST(LimbExcursionTest, AnglesStayInRangeHitTheirKeysAndMoveSmoothly) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& s = body.skeleton;
  const std::vector<JointExcursion> ranges = DefaultLimbExcursions();
  const LimbExcursion excursion(s, ranges, 10.0, 11, 0.6, 1.6);
  ASSERT_EQ(excursion.num_excursions(), static_cast<int>(ranges.size()));
  for (int i = 0; i < excursion.num_excursions(); ++i) {
    const double range = ranges[i].max_angle - ranges[i].min_angle;
    double low = 1e9, high = -1e9;
    for (double t = 0.0; t <= 10.0; t += 0.01) {
      const double a = excursion.Angle(i, t);
      low = std::min(low, a);
      high = std::max(high, a);
      // |d theta / dt| <= 1.5 range / hold_min (the smoothstep's peak rate).
      const double rate = (excursion.Angle(i, t + 1e-5) - excursion.Angle(i, t - 1e-5)) / 2e-5;
      EXPECT_LE(std::abs(rate), 1.5 * range / 0.6 + 1e-6) << ranges[i].joint << " at " << t;
    }
    EXPECT_GE(low, ranges[i].min_angle - 1e-12);
    EXPECT_LE(high, ranges[i].max_angle + 1e-12);
    // Ten seconds of keys 0.6-1.6 s apart sweep most of the range.
    EXPECT_GT(high - low, 0.3 * range) << ranges[i].joint;
    // After the last key the angle holds.
    EXPECT_DOUBLE_EQ(excursion.Angle(i, 20.0), excursion.Angle(i, 30.0));
  }
  // The same seed gives the same angles; another seed other ones.
  const LimbExcursion same(s, ranges, 10.0, 11), other(s, ranges, 10.0, 12);
  EXPECT_DOUBLE_EQ(same.Angle(0, 3.3), excursion.Angle(0, 3.3));
  EXPECT_NE(other.Angle(0, 3.3), excursion.Angle(0, 3.3));
}

TEST(LimbExcursionTest, BonesStayConnectedAndOtherJointsKeepTheirRotation) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& s = body.skeleton;
  // A recorded-like pose: every joint turned a little about its head, the
  // root moved.
  std::vector<Eigen::Isometry3d> pose(s.num_joints());
  for (int j = 0; j < s.num_joints(); ++j) {
    Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
    local.linear() =
        Eigen::AngleAxisd(0.1 + 0.03 * j, Eigen::Vector3d(0.3, 1.0, -0.2 * j).normalized()).toRotationMatrix();
    local.translation() = s.rest_heads.col(j) - local.linear() * s.rest_heads.col(j);
    if (s.parents[j] < 0) local.translation() += Eigen::Vector3d(0.2, 0.0, -0.1);
    pose[j] = s.parents[j] < 0 ? local : pose[s.parents[j]] * local;
  }
  const std::vector<JointExcursion> ranges = DefaultLimbExcursions();
  const LimbExcursion excursion(s, ranges, 5.0, 5);
  const std::vector<Eigen::Isometry3d> out = excursion.Apply(pose, 2.2);
  EXPECT_LT((out[0].matrix() - pose[0].matrix()).norm(), 1e-12);
  bool turned[32] = {};
  for (const JointExcursion& e : ranges) turned[s.Find(e.joint)] = true;
  for (int j = 1; j < s.num_joints(); ++j) {
    const int p = s.parents[j];
    EXPECT_LT((out[j] * s.rest_heads.col(j) - out[p] * s.rest_heads.col(j)).norm(), 1e-12) << s.names[j];
    const Eigen::Matrix3d local = pose[p].linear().transpose() * pose[j].linear();
    const Eigen::Matrix3d now = out[p].linear().transpose() * out[j].linear();
    if (!turned[j]) {
      EXPECT_LT((now - local).norm(), 1e-12) << s.names[j];
    }
  }
  // The Spine's three excursions compose: its extra rotation is theirs.
  const int spine = s.Find("Spine");
  const Eigen::Matrix3d extra = (pose[0].linear().transpose() * pose[spine].linear()).transpose() *
                                (out[0].linear().transpose() * out[spine].linear());
  Eigen::Matrix3d expected = Eigen::Matrix3d::Identity();
  for (int i = 0; i < excursion.num_excursions(); ++i) {
    const JointExcursion& e = ranges[i];
    if (e.joint == "Spine") expected = expected * Eigen::AngleAxisd(excursion.Angle(i, 2.2), e.axis.normalized());
  }
  EXPECT_LT((extra - expected).norm(), 1e-12);
}

TEST(LimbExcursionTest, BadRangesAreRefusedByName) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& s = body.skeleton;
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  try {
    LimbExcursion(s, {{"Tail", z, 0.0, 1.0}}, 1.0, 1);
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'Tail'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(LimbExcursion(s, {{"LeftArm", Eigen::Vector3d::Zero(), 0.0, 1.0}}, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(LimbExcursion(s, {{"LeftArm", z, 1.0, 0.0}}, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(LimbExcursion(s, {{"LeftArm", z, 0.0, NAN}}, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(LimbExcursion(s, {{"Hips", z, 0.0, 1.0}}, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(LimbExcursion(s, {}, -1.0, 1), std::invalid_argument);
  EXPECT_THROW(LimbExcursion(s, {}, 1.0, 1, 0.0, 1.0), std::invalid_argument);
  EXPECT_THROW(LimbExcursion(s, {}, 1.0, 1, 1.0, 0.5), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
