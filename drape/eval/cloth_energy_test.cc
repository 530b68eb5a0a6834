#include "drape/eval/cloth_energy.h"

#include <cmath>

#include <gtest/gtest.h>

#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

TEST(ClothEnergyTest, RestIsFree) {
  const TriangleMesh grid = MakeGrid(6, 6, 0.5);
  const ClothRest rest = PrepareClothRest(grid);
  const ClothMeasures m = MeasureCloth(rest, grid.vertices);
  EXPECT_NEAR(m.stretch_energy, 0.0, 1e-12);
  EXPECT_NEAR(m.bending_energy, 0.0, 1e-12);
  EXPECT_NEAR(m.edge_strain_percent, 0.0, 1e-12);
  double area = 0.0;
  for (double a : rest.vertex_area) area += a;
  EXPECT_NEAR(area, 0.25, 1e-12);
}

TEST(ClothEnergyTest, UniformStretchMatchesStVK) {
  const TriangleMesh grid = MakeGrid(6, 6, 0.5);
  const ClothRest rest = PrepareClothRest(grid);
  const double e = 0.05;
  // In-plane scaling by 1 + e, and a rigid motion, which changes nothing.
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Eigen::Matrix3Xd x = turn * ((1.0 + e) * grid.vertices);
  x.colwise() += Eigen::Vector3d(0.3, -0.2, 1.0);
  const ClothMaterial material;
  const ClothMeasures m = MeasureCloth(rest, x, material);
  // F = (1 + e) I, E = ((1 + e)^2 - 1) / 2 I: psi = 2 mu E^2 + 2 lambda E^2.
  const double strain = ((1.0 + e) * (1.0 + e) - 1.0) / 2.0;
  EXPECT_NEAR(m.stretch_energy, 0.25 * (2.0 * material.mu + 2.0 * material.lambda) * strain * strain, 1e-9);
  EXPECT_NEAR(m.edge_strain_percent, 100.0 * e, 1e-9);
  EXPECT_NEAR(m.area_change_percent, 100.0 * ((1.0 + e) * (1.0 + e) - 1.0), 1e-9);
  EXPECT_NEAR(m.bending_energy, 0.0, 1e-12);
}

TEST(ClothEnergyTest, FoldedHingeMatchesTheDiscreteShell) {
  // Two triangles on the edge (0,0,0)-(1,0,0), folded by theta.
  TriangleMesh hinge;
  hinge.vertices.resize(3, 4);
  hinge.vertices << 0, 1, 0.5, 0.5,  //
      0, 0, 1, -1,                   //
      0, 0, 0, 0;
  hinge.faces.resize(3, 2);
  hinge.faces.col(0) = Eigen::Vector3i(0, 1, 2);
  hinge.faces.col(1) = Eigen::Vector3i(1, 0, 3);
  const ClothRest rest = PrepareClothRest(hinge);
  ASSERT_EQ(rest.hinges.size(), 1u);
  const double theta = 0.4;
  Eigen::Matrix3Xd x = hinge.vertices;
  x.col(3) = Eigen::Vector3d(0.5, -std::cos(theta), std::sin(theta));
  const ClothMaterial material;
  const ClothMeasures m = MeasureCloth(rest, x, material);
  // 3 |e|^2 / (A_1 + A_2) = 3 / (0.5 + 0.5).
  EXPECT_NEAR(m.bending_energy, material.bending * 3.0 * theta * theta, 1e-12);
  EXPECT_NEAR(m.edge_strain_percent, 0.0, 1e-9);
}

TEST(ClothEnergyTest, RejectsDegenerateFaces) {
  TriangleMesh mesh = MakeGrid(2, 2, 1.0);
  mesh.vertices.col(mesh.faces(1, 0)) = mesh.vertices.col(mesh.faces(0, 0));
  EXPECT_THROW(PrepareClothRest(mesh), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
