#include "sft/synthetic/sheet_scene.h"

#include <cmath>

#include <gtest/gtest.h>

namespace polyfit {
namespace {

// The largest relative change of a grid edge's length between the flat
// sheet and the sheet at tau.
double MaxEdgeStrain(const SheetSceneOptions& o, double tau) {
  SheetSceneOptions flat = o;
  flat.motion = SheetMotion::kRigid;
  const Eigen::Matrix3Xd rest = SheetVerticesAt(flat, 0.0), now = SheetVerticesAt(o, tau);
  double worst = 0.0;
  const int nx = o.grid_x;
  for (int j = 0; j <= o.grid_y; ++j) {
    for (int i = 0; i <= nx; ++i) {
      const int v = j * (nx + 1) + i;
      for (int u : {i < nx ? v + 1 : -1, j < o.grid_y ? v + nx + 1 : -1}) {
        if (u < 0) continue;
        const double l0 = (rest.col(v) - rest.col(u)).norm(), l = (now.col(v) - now.col(u)).norm();
        worst = std::max(worst, std::abs(l - l0) / l0);
      }
    }
  }
  return worst;
}

// Every motion bends the sheet without stretching it (paper does not
// stretch). Edges are chords of the curved surface, shorter than its
// arcs: the wave packet has about 8 grid edges per period, and its chords
// are up to 0.5% short where it curves most.
TEST(SheetScene, EveryMotionIsAnIsometry) {
  for (const char* name : {"bend", "wave", "rigid", "mixed", "roll", "crease", "wave_packet"}) {
    SheetSceneOptions o;
    o.motion = ParseSheetMotion(name);
    const double tolerance = o.motion == SheetMotion::kWavePacket ? 6e-3 : 2e-3;
    for (double tau : {0.3, 0.7, 1.0}) EXPECT_LT(MaxEdgeStrain(o, tau), tolerance) << name << " at " << tau;
  }
}

TEST(SheetScene, TheCreaseClosesToSixtyDegrees) {
  SheetSceneOptions o;
  o.motion = SheetMotion::kCrease;
  const Eigen::Matrix3Xd v = SheetVerticesAt(o, 1.0);
  const int row = o.grid_y / 2 * (o.grid_x + 1);
  const Eigen::Vector3d crease = v.col(row + o.grid_x / 2);
  const Eigen::Vector3d left = (v.col(row) - crease).normalized(),
                        right = (v.col(row + o.grid_x) - crease).normalized();
  EXPECT_NEAR(std::acos(left.dot(right)) * 180.0 / M_PI, 60.0, 1e-6);
  EXPECT_LT(v.col(row).z(), crease.z());  // folded toward the camera
}

TEST(SheetScene, TheWavePacketHoldsAboutTwoPeriodsAcrossTheHeight) {
  SheetSceneOptions o;
  o.motion = SheetMotion::kWavePacket;
  o.yaw_amplitude = 0.0;  // no rigid motion: read the profile down the middle column
  o.sideways_amplitude = 0.0;
  const Eigen::Matrix3Xd v = SheetVerticesAt(o, 0.5);
  // Sign changes of the depth's slope down the middle column: crests and
  // troughs (two periods: about four).
  int turns = 0;
  double previous = 0.0;
  for (int j = 1; j <= o.grid_y; ++j) {
    const int a = (j - 1) * (o.grid_x + 1) + o.grid_x / 2, b = j * (o.grid_x + 1) + o.grid_x / 2;
    const double slope = v(2, b) - v(2, a);
    if (j > 1 && slope * previous < 0.0) ++turns;
    previous = slope;
  }
  EXPECT_GE(turns, 3);
  EXPECT_LE(turns, 5);
  EXPECT_EQ(ParseSheetMotion("wave_packet"), SheetMotion::kWavePacket);
  EXPECT_THROW(ParseSheetMotion("ripple"), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
