#include <cmath>

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "cost_functions/compressed_cost.h"
#include "cost_functions/edge_inextensibility.h"
#include "cost_functions/hinge_bending.h"
#include "cost_functions/temporal_consistency.h"

namespace polyfit {
namespace {

// Residuals and Jacobians of a two-block, 3 + 3 cost against central
// differences.
void ExpectJacobiansMatchFiniteDifferences(const ceres::CostFunction& cost, double* a, double* b) {
  const int m = cost.num_residuals();
  std::vector<double> residuals(m), plus(m), minus(m);
  std::vector<double> ja(3 * m), jb(3 * m);
  double* parameters[2] = {a, b};
  double* jacobians[2] = {ja.data(), jb.data()};
  ASSERT_TRUE(cost.Evaluate(parameters, residuals.data(), jacobians));
  const double h = 1e-6;
  for (int block = 0; block < 2; ++block) {
    for (int k = 0; k < 3; ++k) {
      double* x = parameters[block];
      const double saved = x[k];
      x[k] = saved + h;
      cost.Evaluate(parameters, plus.data(), nullptr);
      x[k] = saved - h;
      cost.Evaluate(parameters, minus.data(), nullptr);
      x[k] = saved;
      for (int r = 0; r < m; ++r) {
        EXPECT_NEAR(jacobians[block][r * 3 + k], (plus[r] - minus[r]) / (2 * h), 1e-6);
      }
    }
  }
}

TEST(EdgeInextensibilityResidualTest, ValueAndJacobian) {
  std::unique_ptr<ceres::CostFunction> cost(EdgeInextensibilityResidual::Create(2.0, 3.0));
  double a[3] = {1.0, 2.0, 2.0}, b[3] = {0.0, 0.0, 0.0};  // |a - b| = 3
  double residual;
  double* parameters[2] = {a, b};
  ASSERT_TRUE(cost->Evaluate(parameters, &residual, nullptr));
  EXPECT_NEAR(residual, 3.0 * (3.0 - 2.0) / 2.0, 1e-12);
  ExpectJacobiansMatchFiniteDifferences(*cost, a, b);
  // Coincident points: finite, no NaN.
  double c[3] = {0.0, 0.0, 0.0};
  double jc[3], jd[3];
  double* coincident[2] = {c, b};
  double* jacobians[2] = {jc, jd};
  ASSERT_TRUE(cost->Evaluate(coincident, &residual, jacobians));
  EXPECT_TRUE(std::isfinite(jc[0]) && std::isfinite(jd[2]));
  EXPECT_NEAR(residual, -3.0, 1e-12);
}

TEST(EdgeInextensibilityResidualTest, RobustAboveItsStrainAndItsJacobianIsRight) {
  const double rest = 2.0, weight = 3.0, b = 0.03;
  std::unique_ptr<ceres::CostFunction> robust(EdgeInextensibilityResidual::Create(rest, weight, b));
  std::unique_ptr<ceres::CostFunction> plain(EdgeInextensibilityResidual::Create(rest, weight));
  double origin[3] = {0.0, 0.0, 0.0};
  for (double strain : {-0.5, -0.05, -0.001, 0.0, 1e-4, 0.003, 0.03, 0.2, 2.0}) {
    double x[3] = {rest * (1.0 + strain) * 0.6, 0.0, rest * (1.0 + strain) * 0.8};
    double* parameters[2] = {x, origin};
    double r, r_plain;
    ASSERT_TRUE(robust->Evaluate(parameters, &r, nullptr));
    ASSERT_TRUE(plain->Evaluate(parameters, &r_plain, nullptr));
    EXPECT_NEAR(r_plain, weight * strain, 1e-12);
    // The pseudo-Huber penalty, with the residual's sign.
    const double penalty = weight * weight * 2.0 * b * b * (std::sqrt(1.0 + (strain / b) * (strain / b)) - 1.0);
    EXPECT_NEAR(r * r, penalty, 1e-12 * std::max(1.0, penalty)) << strain;
    EXPECT_TRUE(r * strain >= 0.0) << strain;
    // Quadratic well below b (the squared term), linear well above.
    if (std::abs(strain) <= 0.003) {
      EXPECT_NEAR(r, r_plain, 0.01 * std::abs(r_plain) + 1e-15) << strain;
    }
    if (std::abs(strain) >= 0.2) {
      EXPECT_NEAR(r * r, 2.0 * b * weight * weight * std::abs(strain), 0.2 * r * r);
    }
    ExpectJacobiansMatchFiniteDifferences(*robust, x, origin);
  }
  EXPECT_THROW(EdgeInextensibilityResidual::Create(rest, weight, -0.1), std::invalid_argument);
  EXPECT_THROW(EdgeInextensibilityResidual::Create(rest, weight, std::nan("")), std::invalid_argument);
}

// Two triangles on the edge (0,0,0) -> (1,0,0), the second turned about
// it by `fold` radians away from the first's normal (0, 0, 1).
void Hinge(double fold, double* x_i, double* x_j, double* x_k, double* x_l) {
  const double corners[4][3] = {
      {0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {0.3, 1.0, 0.0}, {0.6, -std::cos(fold), -std::sin(fold)}};
  double* out[4] = {x_i, x_j, x_k, x_l};
  for (int v = 0; v < 4; ++v) {
    for (int c = 0; c < 3; ++c) out[v][c] = corners[v][c];
  }
}

TEST(HingeBendingResidualTest, TheAngleIsTheFoldAndSignedAndItsJacobianIsRight) {
  double x[4][3];
  for (double fold : {0.0, 0.4, -0.4, 1.5, -2.5, 3.0}) {
    Hinge(fold, x[0], x[1], x[2], x[3]);
    EXPECT_NEAR(SignedDihedralAngle<double>(x[0], x[1], x[2], x[3]), fold, 1e-12) << fold;
  }
  // Swapping the two faces (and so the edge's direction) keeps the angle.
  Hinge(0.7, x[0], x[1], x[2], x[3]);
  EXPECT_NEAR(SignedDihedralAngle<double>(x[1], x[0], x[3], x[2]), 0.7, 1e-12);

  std::unique_ptr<ceres::CostFunction> cost(HingeBendingResidual::Create(0.2, 3.0));
  double* parameters[4] = {x[0], x[1], x[2], x[3]};
  double residual = 0.0;
  ASSERT_TRUE(cost->Evaluate(parameters, &residual, nullptr));
  EXPECT_NEAR(residual, 3.0 * (0.7 - 0.2), 1e-12);
  double jacobians[4][3];
  double* jacobian_blocks[4] = {jacobians[0], jacobians[1], jacobians[2], jacobians[3]};
  ASSERT_TRUE(cost->Evaluate(parameters, &residual, jacobian_blocks));
  const double h = 1e-6;
  for (int v = 0; v < 4; ++v) {
    for (int c = 0; c < 3; ++c) {
      const double saved = x[v][c];
      double plus = 0.0, minus = 0.0;
      x[v][c] = saved + h;
      cost->Evaluate(parameters, &plus, nullptr);
      x[v][c] = saved - h;
      cost->Evaluate(parameters, &minus, nullptr);
      x[v][c] = saved;
      EXPECT_NEAR(jacobians[v][c], (plus - minus) / (2 * h), 1e-7) << v << " " << c;
    }
  }
}

TEST(HingeBendingResidualTest, AFoldThroughPiIsNotAFullTurnAndACollapsedFaceIsFinite) {
  double x[4][3];
  // Rest folded to 3.0 rad, now to -3.0 (through pi): 0.28 rad, not 6.
  Hinge(-3.0, x[0], x[1], x[2], x[3]);
  std::unique_ptr<ceres::CostFunction> cost(HingeBendingResidual::Create(3.0, 1.0));
  double* parameters[4] = {x[0], x[1], x[2], x[3]};
  double residual = 0.0;
  ASSERT_TRUE(cost->Evaluate(parameters, &residual, nullptr));
  EXPECT_NEAR(residual, 2.0 * M_PI - 6.0, 1e-12);
  // The fourth vertex on the edge: no angle, and finite derivatives.
  x[3][0] = 0.5;
  x[3][1] = x[3][2] = 0.0;
  double jacobians[4][3];
  double* jacobian_blocks[4] = {jacobians[0], jacobians[1], jacobians[2], jacobians[3]};
  ASSERT_TRUE(cost->Evaluate(parameters, &residual, jacobian_blocks));
  EXPECT_NEAR(residual, -3.0, 1e-12);
  for (const auto& block : jacobians) {
    for (double d : block) EXPECT_TRUE(std::isfinite(d));
  }
  EXPECT_THROW(HingeBendingResidual::Create(std::nan(""), 1.0), std::invalid_argument);
  EXPECT_THROW(HingeBendingResidual::Create(0.0, -1.0), std::invalid_argument);
}

TEST(TemporalConsistencyResidualTest, ValueAndJacobian) {
  std::unique_ptr<ceres::CostFunction> cost(TemporalConsistencyResidual::Create(0.5, 2.0));
  double now[3] = {1.0, -1.0, 0.5}, before[3] = {0.5, -1.0, 1.0};
  double residuals[3];
  double* parameters[2] = {now, before};
  ASSERT_TRUE(cost->Evaluate(parameters, residuals, nullptr));
  EXPECT_NEAR(residuals[0], 2.0 * 0.5 / 0.5, 1e-12);
  EXPECT_NEAR(residuals[2], -2.0, 1e-12);
  ExpectJacobiansMatchFiniteDifferences(*cost, now, before);
}

// A tall least-squares problem: x in R^2, y in R^1, 50 residuals
// r_i = a_i x0^2 + b_i x1 + c_i y - d_i.
struct TallResidual {
  template <typename T>
  bool operator()(const T* x, const T* y, T* r) const {
    for (int i = 0; i < 50; ++i) {
      const double a = std::sin(i), b = std::cos(0.3 * i), c = 0.1 * i - 2.0, d = std::sin(0.7 * i) + 1.0;
      r[i] = a * x[0] * x[0] + b * x[1] + c * y[0] - d;
    }
    return true;
  }
};

TEST(CompressedCostTest, SameCostGradientAndGaussNewtonModel) {
  auto* inner = new ceres::AutoDiffCostFunction<TallResidual, 50, 2, 1>(new TallResidual);
  std::unique_ptr<ceres::CostFunction> reference(
      new ceres::AutoDiffCostFunction<TallResidual, 50, 2, 1>(new TallResidual));
  const CompressedCost compressed(inner);
  EXPECT_EQ(compressed.num_residuals(), 4);
  double x[2] = {0.7, -0.4}, y[1] = {1.3};
  double* parameters[2] = {x, y};
  double r_full[50], j_full_x[100], j_full_y[50];
  double* j_full[2] = {j_full_x, j_full_y};
  ASSERT_TRUE(reference->Evaluate(parameters, r_full, j_full));
  double r_small[4], j_small_x[8], j_small_y[4];
  double* j_small[2] = {j_small_x, j_small_y};
  ASSERT_TRUE(compressed.Evaluate(parameters, r_small, j_small));
  Eigen::Map<Eigen::Matrix<double, 50, 1>> rf(r_full);
  Eigen::Matrix<double, 50, 3> jf;
  for (int i = 0; i < 50; ++i) jf.row(i) << j_full_x[2 * i], j_full_x[2 * i + 1], j_full_y[i];
  Eigen::Map<Eigen::Matrix<double, 4, 1>> rs(r_small);
  Eigen::Matrix<double, 4, 3> js;
  for (int i = 0; i < 4; ++i) js.row(i) << j_small_x[2 * i], j_small_x[2 * i + 1], j_small_y[i];
  EXPECT_NEAR(rs.squaredNorm(), rf.squaredNorm(), 1e-9);
  EXPECT_LT((js.transpose() * rs - jf.transpose() * rf).norm(), 1e-9);
  EXPECT_LT((js.transpose() * js - jf.transpose() * jf).norm(), 1e-9);
  // Cost-only evaluation keeps the cost.
  ASSERT_TRUE(compressed.Evaluate(parameters, r_small, nullptr));
  EXPECT_NEAR(rs.squaredNorm(), rf.squaredNorm(), 1e-9);
}

// The pivoted factorisation keeps the same cost, gradient and Gauss-Newton
// model at an atlas's size too, also when J has a zero and a repeated
// column (rank-deficient pivots).
TEST(CompressedCostTest, LargeRankDeficientSystemsKeepTheModel) {
  const int m = 400, n = 100;
  std::srand(3);
  Eigen::MatrixXd j = Eigen::MatrixXd::Random(m, n);
  j.col(5).setZero();
  j.col(9) = j.col(7);
  const Eigen::VectorXd r = Eigen::VectorXd::Random(m);
  const Eigen::MatrixXd jtj = j.transpose() * j;
  const Eigen::VectorXd jtr = j.transpose() * r;
  std::vector<double> residuals(n + 1), jacobian(static_cast<size_t>(n + 1) * n);
  double* jacobians[1] = {jacobian.data()};
  WriteCompressedResiduals({n}, r.squaredNorm(), jtj, jtr, residuals.data(), jacobians);
  const Eigen::Map<const Eigen::VectorXd> rs(residuals.data(), n + 1);
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> js(jacobian.data(),
                                                                                                   n + 1, n);
  EXPECT_NEAR(rs.squaredNorm(), r.squaredNorm(), 1e-9 * r.squaredNorm());
  EXPECT_LT((js.transpose() * rs - jtr).norm(), 1e-9 * jtr.norm());
  EXPECT_LT((js.transpose() * js - jtj).norm(), 1e-9 * jtj.norm());
}

// Block-triangular: the same cost, gradient and Gauss-Newton model, with
// block row i zero left of block i, also when a block's columns are zero
// or repeated (rank-deficient pivots) and a block is all zero.
TEST(CompressedCostTest, BlockTriangularKeepsTheModelAndItsZeros) {
  const std::vector<int32_t> sizes = {5, 7, 3, 6};
  const int m = 60, n = 21;
  std::srand(5);
  Eigen::MatrixXd j = Eigen::MatrixXd::Random(m, n);
  j.col(2).setZero();
  j.col(8) = j.col(6);
  j.col(19) = 2.0 * j.col(3);
  j.middleCols(12, 3).setZero();
  const Eigen::VectorXd r = Eigen::VectorXd::Random(m);
  const Eigen::MatrixXd jtj = j.transpose() * j;
  const Eigen::VectorXd jtr = j.transpose() * r;
  Eigen::VectorXd residuals;
  Eigen::MatrixXd factor;
  CompressBlockTriangular(sizes, r.squaredNorm(), &jtj, &jtr, &residuals, &factor);
  ASSERT_EQ(residuals.size(), n + 1);
  ASSERT_EQ(factor.rows(), n);
  EXPECT_NEAR(residuals.squaredNorm(), r.squaredNorm(), 1e-9 * r.squaredNorm());
  EXPECT_LT((factor.transpose() * residuals.head(n) - jtr).norm(), 1e-9 * jtr.norm());
  EXPECT_LT((factor.transpose() * factor - jtj).norm(), 1e-9 * jtj.norm());
  for (int i = 0, c = 0; i < static_cast<int>(sizes.size()); c += sizes[i], ++i) {
    EXPECT_EQ(factor.block(c, 0, sizes[i], c).norm(), 0.0) << "block row " << i;
  }
  EXPECT_EQ(factor.middleRows(12, 3).norm(), 0.0);  // an all-zero block
  // Cost only.
  CompressBlockTriangular(sizes, r.squaredNorm(), nullptr, nullptr, &residuals, &factor);
  EXPECT_NEAR(residuals.squaredNorm(), r.squaredNorm(), 1e-12 * r.squaredNorm());
}

// The fill of eliminating blocks in order: 0's neighbours 2 and 3 become
// adjacent, then 2's (3 and 4) do.
TEST(CompressedCostTest, BlockFillJoinsEachBlocksLaterNeighbours) {
  const std::vector<std::vector<int>> adjacent = {{2, 3}, {4}, {0, 4}, {0}, {1, 2}};
  const std::vector<std::vector<int>> later = BlockFill(adjacent);
  const std::vector<std::vector<int>> expected = {{2, 3}, {4}, {3, 4}, {4}, {}};
  EXPECT_EQ(later, expected);
}

// Block-sparse: with rows of J over pairs of blocks only, R keeps that
// pattern and its fill (BlockFill) and still gives J^T J and J^T r, also
// with a repeated column and an all-zero block.
TEST(CompressedCostTest, BlockSparseKeepsTheModelWithinTheFill) {
  const std::vector<int32_t> sizes = {4, 3, 5, 2, 4};
  const std::vector<std::vector<int>> pairs = {{0, 2}, {0, 3}, {1, 4}, {2, 4}, {1, 1}};
  std::vector<Eigen::Index> offset = {0};
  for (const int32_t b : sizes) offset.push_back(offset.back() + b);
  const Eigen::Index n = offset.back();
  std::srand(11);
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(12 * static_cast<Eigen::Index>(pairs.size()), n);
  for (size_t p = 0; p < pairs.size(); ++p) {
    for (const int block : pairs[p]) {
      j.block(12 * p, offset[block], 12, sizes[block]) = Eigen::MatrixXd::Random(12, sizes[block]);
    }
  }
  j.col(offset[4] + 1) = j.col(offset[4]);  // rank-deficient pivot
  j.middleCols(offset[3], sizes[3]).setZero();  // block 3 all zero
  const Eigen::VectorXd r = Eigen::VectorXd::Random(j.rows());
  const Eigen::MatrixXd jtj = j.transpose() * j;
  const Eigen::VectorXd jtr = j.transpose() * r;
  std::vector<std::vector<int>> adjacent(sizes.size());
  for (const std::vector<int>& p : pairs) {
    adjacent[p[0]].push_back(p[1]);
    adjacent[p[1]].push_back(p[0]);
  }
  const std::vector<std::vector<int>> later = BlockFill(adjacent);
  // Only the pattern's upper blocks are read: the rest is garbage.
  Eigen::MatrixXd schur = Eigen::MatrixXd::Constant(n, n, 1e30);
  for (size_t i = 0; i < sizes.size(); ++i) {
    schur.block(offset[i], offset[i], sizes[i], sizes[i]) = jtj.block(offset[i], offset[i], sizes[i], sizes[i]);
    for (const int k : later[i]) {
      schur.block(offset[i], offset[k], sizes[i], sizes[k]) = jtj.block(offset[i], offset[k], sizes[i], sizes[k]);
    }
  }
  Eigen::VectorXd g = jtr, residuals;
  std::vector<Eigen::MatrixXd> rows;
  CompressBlockSparse(sizes, later, r.squaredNorm(), 1e-12 * jtj.diagonal().maxCoeff(), &schur, &g, &rows,
                      &residuals);
  ASSERT_EQ(residuals.size(), n + 1);
  Eigen::MatrixXd factor = Eigen::MatrixXd::Zero(n, n);
  for (size_t i = 0; i < sizes.size(); ++i) {
    Eigen::Index w = sizes[i];
    factor.block(offset[i], offset[i], sizes[i], sizes[i]) = rows[i].leftCols(sizes[i]);
    for (const int k : later[i]) {
      factor.block(offset[i], offset[k], sizes[i], sizes[k]) = rows[i].middleCols(w, sizes[k]);
      w += sizes[k];
    }
    EXPECT_EQ(w, rows[i].cols());
  }
  EXPECT_NEAR(residuals.squaredNorm(), r.squaredNorm(), 1e-9 * r.squaredNorm());
  EXPECT_LT((factor.transpose() * residuals.head(n) - jtr).norm(), 1e-9 * jtr.norm());
  EXPECT_LT((factor.transpose() * factor - jtj).norm(), 1e-9 * jtj.norm());
  EXPECT_EQ(factor.middleRows(offset[3], sizes[3]).norm(), 0.0);
  EXPECT_EQ(residuals.segment(offset[3], sizes[3]).norm(), 0.0);
}

}  // namespace
}  // namespace polyfit
