#include "polyfit/mesh/cotangent_laplacian.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

TEST(CotangentLaplacianTest, IsSymmetricWithZeroRowSumsAndVanishesOnLinearFieldsInside) {
  const TriangleMesh grid = MakeGrid(8, 6, 2.0);
  const CotangentLaplacian laplacian = MakeCotangentLaplacian(grid);
  const Eigen::MatrixXd dense = laplacian.ToDense();
  EXPECT_LT((dense - dense.transpose()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((dense * Eigen::VectorXd::Ones(grid.num_vertices())).cwiseAbs().maxCoeff(), 1e-12);
  // A linear field's Laplacian is zero away from the boundary.
  const Eigen::VectorXd f = 0.3 * grid.vertices.row(0).transpose() - 1.7 * grid.vertices.row(1).transpose();
  const Eigen::VectorXd lf = dense * f;
  EXPECT_LT((laplacian.Apply(f) - lf).cwiseAbs().maxCoeff(), 1e-12);
  const Eigen::Vector3d lo = grid.vertices.rowwise().minCoeff(), hi = grid.vertices.rowwise().maxCoeff();
  int inside = 0;
  for (int v = 0; v < grid.num_vertices(); ++v) {
    const Eigen::Vector3d p = grid.vertices.col(v);
    if ((p - lo).head<2>().minCoeff() < 1e-9 || (hi - p).head<2>().minCoeff() < 1e-9) continue;
    EXPECT_NEAR(lf[v], 0.0, 1e-12) << v;
    ++inside;
  }
  EXPECT_GT(inside, 20);
  EXPECT_NEAR(VertexAreas(grid).sum(), (hi - lo)[0] * (hi - lo)[1], 1e-12);
}

TEST(CotangentLaplacianTest, HeightIsAnEigenfunctionOnTheSphere) {
  // On a sphere of radius r, Delta z = -2 z / r^2; L approximates -M Delta.
  const double r = 0.7;
  const TriangleMesh sphere = MakeIcosphere(4, r);
  const Eigen::VectorXd areas = VertexAreas(sphere);
  EXPECT_NEAR(areas.sum(), 4.0 * M_PI * r * r, 0.01 * 4.0 * M_PI * r * r);
  const Eigen::VectorXd z = sphere.vertices.row(2).transpose();
  const Eigen::VectorXd lz = MakeCotangentLaplacian(sphere).Apply(z);
  const Eigen::VectorXd expected = (2.0 / (r * r)) * areas.cwiseProduct(z);
  EXPECT_LT((lz - expected).norm(), 0.02 * expected.norm());
}

TEST(CotangentLaplacianTest, ClampsNegativeWeightsAndSkipsDegenerateFaces) {
  // Two very obtuse triangles on both sides of the edge (0, 1): its
  // cotangent weight is negative and is clamped to zero.
  TriangleMesh mesh;
  mesh.vertices.resize(3, 5);
  mesh.vertices << 0, 1, 0.5, 0.5, 2, 0, 0, 0.05, -0.05, 0, 0, 0, 0, 0, 0;
  mesh.faces.resize(3, 3);
  mesh.faces << 0, 1, 0, 1, 0, 1, 2, 3, 4;  // (0,1,2), (1,0,3), (0,1,4): the last is degenerate
  const Eigen::MatrixXd dense = MakeCotangentLaplacian(mesh).ToDense();
  EXPECT_EQ(dense(0, 1), 0.0);
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) {
      if (i != j) {
        EXPECT_LE(dense(i, j), 0.0) << i << " " << j;
      }
    }
  }
  EXPECT_LT((dense * Eigen::VectorXd::Ones(5)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_TRUE(dense.allFinite());
  EXPECT_EQ(dense.row(4).cwiseAbs().sum(), 0.0);
}

TEST(CotangentLaplacianTest, KeptNegativeWeightsVanishOnLinearFieldsOfAnyPlanarMesh) {
  // A grid with its inner vertices jittered (not enough to fold a triangle
  // over): some edges get negative weights. Unclamped, L is exact on linear
  // fields at every inner vertex of a planar mesh; clamped, it is not.
  TriangleMesh mesh = MakeGrid(8, 8, 1.0);
  const Eigen::Vector3d lo = mesh.vertices.rowwise().minCoeff(), hi = mesh.vertices.rowwise().maxCoeff();
  const double spacing = (hi - lo)[0] / 8.0;
  std::vector<bool> inner(mesh.num_vertices(), false);
  std::srand(7);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    const Eigen::Vector3d p = mesh.vertices.col(v);
    inner[v] = (p - lo).head<2>().minCoeff() > 1e-9 && (hi - p).head<2>().minCoeff() > 1e-9;
    if (inner[v]) mesh.vertices.col(v).head<2>() += 0.2 * spacing * Eigen::Vector2d::Random();
  }
  const CotangentLaplacian kept = MakeCotangentLaplacian(mesh, /*clamp_negative_weights=*/false);
  EXPECT_LT(*std::min_element(kept.weight.begin(), kept.weight.end()), 0.0);
  const Eigen::Matrix3Xd field = (Eigen::Matrix3d() << 0.3, -1.7, 0, 2, 0.5, 0, -1, 1, 0).finished() * mesh.vertices;
  Eigen::Matrix3Xd kept_field(3, mesh.num_vertices());
  kept.ApplyToColumns(field, &kept_field);
  EXPECT_LT((kept_field.transpose() - kept.Apply(field.transpose())).cwiseAbs().maxCoeff(), 1e-14);
  const Eigen::MatrixXd clamped_field = MakeCotangentLaplacian(mesh).Apply(field.transpose());
  double clamped_worst = 0.0;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (!inner[v]) continue;
    EXPECT_LT(kept_field.col(v).norm(), 1e-12) << v;
    clamped_worst = std::max(clamped_worst, clamped_field.row(v).norm());
  }
  EXPECT_GT(clamped_worst, 1e-3);
}

TEST(DiffuseHeatTest, MatchesTheExactDiffusionOfAStepAndConservesItsIntegral) {
  // A step in x on the square [-1, 1]^2 diffuses to (1 + erf(x / 2 sqrt(t))) / 2
  // while it is far from the (insulated) boundary; two meshings agree.
  const double t = 0.3 * 0.3 / 8.0;
  for (const int n : {20, 40}) {
    const TriangleMesh grid = MakeGrid(n, n, 2.0);
    Eigen::MatrixXd step(grid.num_vertices(), 2);
    for (int v = 0; v < grid.num_vertices(); ++v) {
      const double x = grid.vertices(0, v);
      step(v, 0) = x > 1e-9 ? 1.0 : (x < -1e-9 ? 0.0 : 0.5);
      step(v, 1) = 1.0 - step(v, 0);
    }
    const Eigen::MatrixXd diffused = DiffuseHeat(grid, step, t, {}, 16);
    const Eigen::VectorXd areas = VertexAreas(grid);
    EXPECT_NEAR(areas.dot(diffused.col(0)), areas.dot(step.col(0)), 1e-9);
    double worst = 0.0;
    for (int v = 0; v < grid.num_vertices(); ++v) {
      const double exact = 0.5 * (1.0 + std::erf(grid.vertices(0, v) / (2.0 * std::sqrt(t))));
      worst = std::max(worst, std::abs(diffused(v, 0) - exact));
      EXPECT_NEAR(diffused(v, 0) + diffused(v, 1), 1.0, 1e-9);
    }
    EXPECT_LT(worst, n == 20 ? 0.03 : 0.015) << n;
  }
}

TEST(DiffuseHeatTest, OneStepSolvesItsSystemAndColumnsStayApart) {
  // One implicit step is (M + t L) x = M b to rounding; fields given
  // together come out as each alone; a zero field stays zero; a vertex on
  // no face keeps its value.
  TriangleMesh grid = MakeGrid(12, 9, 1.0);
  grid.vertices.conservativeResize(3, grid.num_vertices() + 1);
  grid.vertices.col(grid.num_vertices() - 1) = Eigen::Vector3d(5, 5, 5);  // on no face
  const int n = grid.num_vertices();
  Eigen::MatrixXd fields(n, 3);
  fields.col(0) = grid.vertices.row(0).transpose().array().sin().matrix();
  fields.col(1).setZero();
  fields.col(2) = grid.vertices.row(1).transpose().array().square().matrix();
  const double t = 0.02;
  const Eigen::MatrixXd together = DiffuseHeat(grid, fields, t, {}, 1);
  const Eigen::MatrixXd dense = MakeCotangentLaplacian(grid).ToDense();
  const Eigen::VectorXd mass = VertexAreas(grid);
  for (const int c : {0, 2}) {
    const Eigen::VectorXd residual =
        (mass.asDiagonal() * together.col(c) + t * dense * together.col(c)) - mass.asDiagonal() * fields.col(c);
    EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-14) << c;
    const Eigen::MatrixXd alone = DiffuseHeat(grid, fields.col(c), t, {}, 1);
    EXPECT_LT((alone.col(0) - together.col(c)).cwiseAbs().maxCoeff(), 1e-14) << c;
  }
  EXPECT_EQ(together.col(1).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(together(n - 1, 0), fields(n - 1, 0));
  EXPECT_GT((together.col(0) - fields.col(0)).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(DiffuseHeatTest, HeldVerticesKeepTheirValuesAndBadInputThrows) {
  const TriangleMesh grid = MakeGrid(10, 10, 1.0);
  Eigen::MatrixXd field = grid.vertices.row(0).transpose().array().square().matrix();
  std::vector<double> rate(grid.num_vertices(), 1.0);
  rate[7] = 0.0;
  const Eigen::MatrixXd diffused = DiffuseHeat(grid, field, 0.01, rate);
  EXPECT_EQ(diffused(7, 0), field(7, 0));
  EXPECT_GT((diffused - field).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_TRUE(DiffuseHeat(grid, field, 0.0).isApprox(field));
  EXPECT_THROW(DiffuseHeat(grid, field.topRows(3), 0.01), std::invalid_argument);
  EXPECT_THROW(DiffuseHeat(grid, field, -1.0), std::invalid_argument);
  EXPECT_THROW(DiffuseHeat(grid, field, 0.01, std::vector<double>(3, 1.0)), std::invalid_argument);
  EXPECT_THROW(DiffuseHeat(grid, field, 0.01, {}, 0), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
