#include "sft/synthetic/cloth_simulation.h"

#include <cmath>

#include <gtest/gtest.h>

#include "sft/synthetic/cloth_motion.h"
#include "sft/synthetic/sheet_scene.h"

namespace polyfit {
namespace {

// The default sheet's grid, flat in the plane z = 0.4 (x right, y down).
TriangleMesh FlatSheet(const SheetSceneOptions& o) {
  Eigen::Matrix3Xd x(3, (o.grid_x + 1) * (o.grid_y + 1));
  for (int v = 0; v < x.cols(); ++v) x.col(v) << SheetGridPoint(o, v), 0.4;
  return MakeSheetMesh(o, x);
}

Eigen::Vector3d MassCentre(const TriangleMesh& rest, const Eigen::Matrix3Xd& x) {
  const Eigen::VectorXd area = VertexAreas(rest);
  return x * area / area.sum();
}

// Edge constraints, bending (its rows sum to zero) and self-collisions
// move vertices by their inverse masses, so the centre of mass falls as
// one particle under symplectic Euler: after n substeps of h,
// x_n = x_0 + h^2 g n (n + 1) / 2.
TEST(ClothSimulation, TheCentreOfMassFallsExactly) {
  const SheetSceneOptions o;
  const TriangleMesh rest = FlatSheet(o);
  ClothSimulationOptions physics;
  physics.air_density = 0.0;
  physics.damping = 0.0;
  physics.substeps = 20;
  physics.gravity = Eigen::Vector3d(0.5, 9.81, 2.0);
  Eigen::Matrix3Xd bowed = rest.vertices;  // not flat, so that bending and the edges act
  for (int v = 0; v < bowed.cols(); ++v) bowed(2, v) += 8.0 * bowed(0, v) * bowed(0, v);
  ClothSimulation cloth(rest, physics);
  cloth.SetPositions(bowed);
  const Eigen::Vector3d start = MassCentre(rest, bowed);
  for (int frame = 0; frame < 10; ++frame) cloth.Advance(1.0 / 30.0);
  const double h = 1.0 / 30.0 / physics.substeps;
  const int n = 10 * physics.substeps;
  const Eigen::Vector3d expected = start + 0.5 * h * h * n * (n + 1) * physics.gravity;
  EXPECT_LT((MassCentre(rest, cloth.positions()) - expected).norm(), 1e-12);
  EXPECT_GT(cloth.BendingEnergy(), 0.0);
}

// On a cylinder of curvature k the plate's energy is (B / 2) k^2 per area;
// the matrix leaves boundary rows out, so compare over the interior
// vertices' area: for the 24 by 17 grid, (22 x 15) / (24 x 16) of it.
TEST(ClothSimulation, BendingEnergyOfACylinderIsThePlates) {
  const SheetSceneOptions o;
  const TriangleMesh rest = FlatSheet(o);
  ClothSimulationOptions physics;
  physics.bending_stiffness = 2e-5;
  ClothSimulation cloth(rest, physics);
  EXPECT_NEAR(cloth.BendingEnergy(), 0.0, 1e-12);
  const double curvature = 1.0 / 0.1;
  Eigen::Matrix3Xd bent = rest.vertices;
  for (int v = 0; v < bent.cols(); ++v) {
    const double x = rest.vertices(0, v);
    bent(0, v) = std::sin(curvature * x) / curvature;
    bent(2, v) = 0.4 + (1.0 - std::cos(curvature * x)) / curvature;
  }
  cloth.SetPositions(bent);
  const double interior = o.sheet_width * o.sheet_height * (o.grid_x - 1.0) * (o.grid_y - 1.0) / (o.grid_x * o.grid_y);
  EXPECT_NEAR(cloth.BendingEnergy(), 0.5 * physics.bending_stiffness * curvature * curvature * interior,
              0.03 * cloth.BendingEnergy());
}

TEST(ClothSimulation, AClothHangingFromTwoCornersKeepsItsLengths) {
  const SheetSceneOptions o;
  const TriangleMesh rest = FlatSheet(o);
  ClothSimulation cloth(rest, ClothSimulationOptions());
  cloth.Pin(0);
  cloth.Pin(o.grid_x);
  cloth.SetWind(Eigen::Vector3d(0.0, 0.0, 2.0));
  for (int frame = 0; frame < 30; ++frame) cloth.Advance(1.0 / 30.0);
  EXPECT_LT(cloth.MaxEdgeStrain(), 0.02);
  EXPECT_EQ(cloth.positions().col(0), rest.vertices.col(0));
  // The wind blew it away from the camera.
  EXPECT_GT(cloth.positions()(2, cloth.positions().cols() - 1), 0.45);
  EXPECT_THROW(cloth.SetPinTarget(1, Eigen::Vector3d::Zero()), std::invalid_argument);
}

TEST(ClothSimulation, RejectsBadOptions) {
  ClothSimulationOptions physics;
  physics.substeps = 0;
  EXPECT_NE(physics.Validate(), "");
  const SheetSceneOptions o;
  EXPECT_THROW(ClothSimulation(FlatSheet(o), physics), std::invalid_argument);
}

// Every simulated motion, 45 frames: the cloth stays near-inextensible, out
// of the obstacle and out of itself; the run is deterministic.
TEST(ClothMotion, EveryMotionIsPhysical) {
  for (const char* name : {"hanging", "flag", "fall", "table"}) {
    SheetSceneOptions o;
    o.motion = ParseSheetMotion(name);
    o.frame_count = 45;
    ClothMotionReport report;
    const std::vector<Eigen::Matrix3Xd> frames = SheetSequence(o, &report);
    ASSERT_EQ(frames.size(), 45u);
    EXPECT_LT(report.max_edge_strain, 0.02) << name;
    EXPECT_GT(report.min_self_distance, 0.5 * report.thickness) << name;
    EXPECT_GE(report.min_obstacle_distance, 0.0) << name;
    // It moves: a vertex travels more than 2 cm at some frame.
    double travel = 0.0;
    for (const Eigen::Matrix3Xd& x : frames)
      travel = std::max(travel, (x - frames.front()).colwise().norm().maxCoeff());
    EXPECT_GT(travel, 0.02) << name;
    if (o.motion == SheetMotion::kFall) {
      EXPECT_EQ(SheetSequence(o).back(), frames.back());
      EXPECT_THROW(SheetVerticesAt(o, 0.5), std::invalid_argument);
    }
  }
}

}  // namespace
}  // namespace polyfit
