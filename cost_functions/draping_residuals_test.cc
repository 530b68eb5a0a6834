#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "cost_functions/collision_residual.h"
#include "cost_functions/gravity_inertia_residuals.h"
#include "cost_functions/metric_inextensibility_residual.h"
#include "cost_functions/patch_boundary_residual.h"

namespace polyfit {
namespace {

// Largest difference between a cost's Jacobians and central differences of
// its residuals at `blocks`.
double JacobianError(const ceres::CostFunction& cost, std::vector<std::vector<double>> blocks, double h = 1e-6) {
  const int m = cost.num_residuals();
  std::vector<double*> parameters;
  for (auto& b : blocks) parameters.push_back(b.data());
  std::vector<std::vector<double>> jacobians(blocks.size());
  std::vector<double*> jacobian_ptrs;
  for (size_t b = 0; b < blocks.size(); ++b) {
    jacobians[b].resize(m * blocks[b].size());
    jacobian_ptrs.push_back(jacobians[b].data());
  }
  std::vector<double> r(m), rp(m), rm(m);
  EXPECT_TRUE(cost.Evaluate(parameters.data(), r.data(), jacobian_ptrs.data()));
  double worst = 0.0;
  for (size_t b = 0; b < blocks.size(); ++b) {
    const int size = static_cast<int>(blocks[b].size());
    for (int c = 0; c < size; ++c) {
      const double saved = blocks[b][c];
      blocks[b][c] = saved + h;
      cost.Evaluate(parameters.data(), rp.data(), nullptr);
      blocks[b][c] = saved - h;
      cost.Evaluate(parameters.data(), rm.data(), nullptr);
      blocks[b][c] = saved;
      for (int i = 0; i < m; ++i) {
        worst = std::max(worst, std::abs((rp[i] - rm[i]) / (2 * h) - jacobians[b][i * size + c]));
      }
    }
  }
  return worst;
}

double Residual(const ceres::CostFunction& cost, std::vector<std::vector<double>> blocks, int index = 0) {
  std::vector<double*> parameters;
  for (auto& b : blocks) parameters.push_back(b.data());
  std::vector<double> r(cost.num_residuals());
  EXPECT_TRUE(cost.Evaluate(parameters.data(), r.data(), nullptr));
  return r[index];
}

TEST(CollisionResidualTest, PenaltyInsideTheMarginOnly) {
  const Eigen::Vector3d c(0, 0, 0), n(0, 0, 2);  // normalised inside
  std::unique_ptr<ceres::CostFunction> cubic(CollisionResidual::Create(c, n, 0.004, 3.0, 3));
  std::unique_ptr<ceres::CostFunction> square(CollisionResidual::Create(c, n, 0.004, 3.0, 2));
  // 1 cm inside: depth 0.014.
  EXPECT_NEAR(Residual(*cubic, {{0.2, 0.1, -0.01}}), 3.0 * std::pow(0.014, 1.5), 1e-15);
  EXPECT_NEAR(Residual(*square, {{0.2, 0.1, -0.01}}), 3.0 * 0.014, 1e-15);
  EXPECT_EQ(Residual(*cubic, {{0.2, 0.1, 0.005}}), 0.0);  // beyond the margin
  EXPECT_LT(JacobianError(*cubic, {{0.2, 0.1, -0.01}}, 1e-8), 1e-6);
  EXPECT_LT(JacobianError(*square, {{0.2, 0.1, -0.01}}, 1e-8), 1e-6);
}

TEST(GravityInertiaTest, GravityHasTheEnergysGradient) {
  const double mass = 0.02, g = 9.81, weight = 1.5;
  std::unique_ptr<ceres::CostFunction> gravity(
      GravityResidual::Create(mass, g, Eigen::Vector3d(0, 1, 0), -10.0, weight));
  const double r1 = Residual(*gravity, {{0.0, 0.3, 0.0}}), r2 = Residual(*gravity, {{0.0, 0.5, 0.0}});
  // r^2 / 2 changes by k_g m g dh.
  EXPECT_NEAR(0.5 * (r2 * r2 - r1 * r1), weight * mass * g * 0.2, 1e-12);
  EXPECT_LT(JacobianError(*gravity, {{0.1, 0.3, 0.2}}), 1e-6);
  double below[3] = {0, -11, 0}, r;
  double* p[1] = {below};
  EXPECT_FALSE(gravity->Evaluate(p, &r, nullptr));
}

TEST(GravityInertiaTest, InertiaPredictsConstantVelocity) {
  std::unique_ptr<ceres::CostFunction> inertia(
      InertiaResidual::Create(Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0.5, 0, 0), 0.04, 1.0 / 30, 0.5));
  EXPECT_NEAR(Residual(*inertia, {{1.5, 0, 0}}), 0.0, 1e-15);  // on the prediction
  EXPECT_NEAR(Residual(*inertia, {{1.6, 0, 0}}), std::sqrt(0.5 * 0.04) * 30 * 0.1, 1e-12);
  EXPECT_LT(JacobianError(*inertia, {{1.2, 0.3, -0.1}}), 1e-6);
}

TEST(GravityInertiaTest, FoldedGravityHasTheLinearEnergysGradient) {
  // k_i m / (2 dt^2) |x - x_pred + shift|^2 - (k_i m / (2 dt^2) |x - x_pred|^2 + k_g m g x . up) is constant in x.
  const double mass = 0.03, dt = 1.0 / 30, k_i = 0.5, k_g = 1.2, g = 9.81;
  const Eigen::Vector3d previous(0.1, 0.5, -0.2), before(0.05, 0.52, -0.2), up(0, 1, 0);
  std::unique_ptr<ceres::CostFunction> folded(InertiaResidual::Create(previous, before, mass, dt, k_i, k_g, g, up));
  std::unique_ptr<ceres::CostFunction> inertia(InertiaResidual::Create(previous, before, mass, dt, k_i));
  double difference[2];
  for (int i = 0; i < 2; ++i) {
    const std::vector<double> x = {0.3 * i, -0.2 + 0.5 * i, 0.1};
    double rf = 0.0, ri = 0.0;
    for (int k = 0; k < 3; ++k) {
      rf += std::pow(Residual(*folded, {x}, k), 2);
      ri += std::pow(Residual(*inertia, {x}, k), 2);
    }
    difference[i] = 0.5 * rf - (0.5 * ri + k_g * mass * g * x[1]);
  }
  EXPECT_NEAR(difference[0], difference[1], 1e-12);
  EXPECT_THROW(InertiaResidual::Create(previous, before, mass, dt, 0.0, k_g), std::invalid_argument);
}

TEST(MetricInextensibilityTest, FlatPatchAndParabola) {
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  std::unique_ptr<ceres::CostFunction> flat(
      MetricInextensibilityResidual::Create(2, 0.5, 0.0, Eigen::Vector3d(1, 0, 1), identity));
  std::vector<double> alpha(6, 0.0);
  EXPECT_NEAR(Residual(*flat, {alpha, {1.0}}), 0.0, 1e-15);
  // z = u^2 at u = 0.5: z_u = 1, so g11 = s^2 (1 + 1) = 2 with s = 1.
  alpha[3] = 1.0;  // coefficient of u^2
  EXPECT_NEAR(Residual(*flat, {alpha, {1.0}}, 0), 1.0, 1e-12);
  // A rigid frame changes nothing; a skinning stretch does.
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  std::unique_ptr<ceres::CostFunction> rotated(
      MetricInextensibilityResidual::Create(2, 0.5, 0.0, Eigen::Vector3d(1, 0, 1), rotation));
  EXPECT_NEAR(Residual(*rotated, {alpha, {1.0}}, 0), 1.0, 1e-12);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(-0.5, 0.5);
  std::vector<double> random(15);
  for (double& a : random) a = unit(rng);
  std::unique_ptr<ceres::CostFunction> quartic(MetricInextensibilityResidual::Create(
      4, 0.3, -0.2, Eigen::Vector3d(1.1, 0.05, 0.9), rotation, Eigen::Matrix3d::Identity() * 1.1));
  EXPECT_LT(JacobianError(*quartic, {random, {0.8}}), 1e-6);
}

TEST(MetricInextensibilityTest, KextScalesTheRestMetric) {
  // A flat patch keeps g = I; with k_ext = 1.5 the target is 1.5 I.
  std::unique_ptr<ceres::CostFunction> cost(MetricInextensibilityResidual::Create(
      2, 0.1, 0.2, Eigen::Vector3d(1, 0, 1), Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Identity(), 2.0, 1.5));
  const std::vector<double> alpha(6, 0.0);
  EXPECT_NEAR(Residual(*cost, {alpha, {1.0}}, 0), 2.0 * (1.0 - 1.5), 1e-14);
  EXPECT_NEAR(Residual(*cost, {alpha, {1.0}}, 1), 0.0, 1e-14);
  EXPECT_NEAR(Residual(*cost, {alpha, {1.0}}, 2), 2.0 * (1.0 - 1.5), 1e-14);
}

TEST(WarpedMetricInextensibilityTest, UnslidEqualsTheCentroidsMetric) {
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix();
  const Eigen::Matrix3d skinning = Eigen::Vector3d(1.05, 0.97, 1.0).asDiagonal();
  Eigen::Matrix<double, 2, 3> uv;
  uv << 0.1, 0.4, 0.2, -0.2, 0.0, 0.3;
  const Eigen::Vector3d rest(1.02, 0.03, 0.95);
  std::unique_ptr<ceres::CostFunction> warped(
      WarpedMetricInextensibilityResidual::Create(4, uv, rest, rotation, skinning, 0.7, 1.2));
  const Eigen::Vector2d centroid = uv.rowwise().mean();
  std::unique_ptr<ceres::CostFunction> plain(
      MetricInextensibilityResidual::Create(4, centroid.x(), centroid.y(), rest, rotation, skinning, 0.7, 1.2));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-0.3, 0.3);
  std::vector<double> alpha(15);
  for (double& a : alpha) a = unit(rng);
  const std::vector<double> zero(2, 0.0);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(Residual(*warped, {alpha, {0.9}, zero, zero, zero}, i), Residual(*plain, {alpha, {0.9}}, i), 1e-13);
  }
  EXPECT_LT(JacobianError(*warped, {alpha, {0.9}, {0.01, -0.02}, {0.03, 0.0}, {-0.01, 0.02}}), 1e-6);
}

TEST(WarpedMetricInextensibilityTest, SlidesStretchAFlatPatchAndATranslationDoesNot) {
  Eigen::Matrix<double, 2, 3> uv;
  uv << 0.0, 0.2, 0.0, 0.0, 0.0, 0.2;
  std::unique_ptr<ceres::CostFunction> cost(
      WarpedMetricInextensibilityResidual::Create(2, uv, Eigen::Vector3d(1, 0, 1), Eigen::Matrix3d::Identity()));
  const std::vector<double> flat(6, 0.0);
  // The whole triangle moved along the plane: no change of metric.
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(Residual(*cost, {flat, {1.0}, {0.05, -0.02}, {0.05, -0.02}, {0.05, -0.02}}, i), 0.0, 1e-14);
  }
  // Stretched 10% along u: g11 = 1.21, the rest unchanged.
  EXPECT_NEAR(Residual(*cost, {flat, {1.0}, {0.0, 0.0}, {0.02, 0.0}, {0.0, 0.0}}, 0), 0.21, 1e-12);
  EXPECT_NEAR(Residual(*cost, {flat, {1.0}, {0.0, 0.0}, {0.02, 0.0}, {0.0, 0.0}}, 2), 0.0, 1e-12);
  // Sheared: g12 = w01 = 0.1 (the sqrt(2) weight on the off-diagonal).
  EXPECT_NEAR(Residual(*cost, {flat, {1.0}, {0.0, 0.0}, {0.0, 0.0}, {0.02, 0.0}}, 1), std::sqrt(2.0) * 0.1, 1e-12);
  Eigen::Matrix<double, 2, 3> degenerate;
  degenerate << 0.0, 0.1, 0.2, 0.0, 0.1, 0.2;
  EXPECT_THROW(WarpedMetricInextensibilityResidual(2, degenerate, Eigen::Vector3d(1, 0, 1), Eigen::Matrix3d::Identity(),
                                                   Eigen::Matrix3d::Identity(), 1.0),
               std::invalid_argument);
}

TEST(PatchBoundaryTest, IdenticalPatchesAgreeAndJacobiansMatch) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::unique_ptr<ceres::CostFunction> cost(
      PatchBoundaryResidual::Create(3, Eigen::Vector2d(0.2, -0.4), r, Eigen::Vector2d(0.2, -0.4), r, 2.0, 0.5));
  std::vector<double> alpha = {0.1, -0.2, 0.3, 0.05, 0.1, -0.1, 0.02, 0.0, 0.01, -0.03};
  for (int i = 0; i < 6; ++i)
    EXPECT_NEAR(Residual(*cost, {alpha, {0.7}, {1, 2, 3}, alpha, {0.7}, {1, 2, 3}}, i), 0.0, 1e-15);
  // A shifted translation shows in the position residuals only.
  EXPECT_NEAR(Residual(*cost, {alpha, {0.7}, {1, 2, 3}, alpha, {0.7}, {1, 2, 3.5}}, 2), 2.0 * -0.5, 1e-12);
  EXPECT_NEAR(Residual(*cost, {alpha, {0.7}, {1, 2, 3}, alpha, {0.7}, {1, 2, 3.5}}, 5), 0.0, 1e-15);
  std::vector<double> other = alpha;
  other[4] += 0.2;
  EXPECT_LT(JacobianError(*cost, {alpha, {0.7}, {1, 2, 3}, other, {0.9}, {1, 2.1, 3}}), 1e-6);
}

// The hand-derived Jacobians against the autodiff functor's, at random
// jets, frames, scales and gaps, for every order.
TEST(PatchBoundaryTest, HandJacobiansMatchAutodiff) {
  std::mt19937 random(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int order = 1; order <= kMaxJetOrder; ++order) {
    const int k = NumJetCoefficients(order);
    const Eigen::Matrix3d ra = Eigen::AngleAxisd(unit(random) * 3.0, Eigen::Vector3d::Random().normalized()).matrix();
    const Eigen::Matrix3d rb = Eigen::AngleAxisd(unit(random) * 3.0, Eigen::Vector3d::Random().normalized()).matrix();
    const Eigen::Vector2d uv_a(unit(random), unit(random)), uv_b(unit(random), unit(random));
    const Eigen::Vector3d position_gap = Eigen::Vector3d::Random() * 0.01, normal_gap = Eigen::Vector3d::Random() * 0.1;
    std::unique_ptr<ceres::CostFunction> autodiff(
        PatchBoundaryResidual::Create(order, uv_a, ra, uv_b, rb, 3.0, 0.7, position_gap, normal_gap));
    std::unique_ptr<ceres::CostFunction> hand(
        PatchBoundaryCost::Create(order, uv_a, ra, uv_b, rb, 3.0, 0.7, position_gap, normal_gap));
    ASSERT_EQ(hand->parameter_block_sizes(), autodiff->parameter_block_sizes());
    std::vector<std::vector<double>> blocks = {std::vector<double>(k), {0.8 + 0.3 * unit(random)}, {1, -2, 3},
                                               std::vector<double>(k), {1.1 + 0.3 * unit(random)}, {0.5, 0.2, -1}};
    for (double& c : blocks[0]) c = 0.4 * unit(random);
    for (double& c : blocks[3]) c = 0.4 * unit(random);
    std::vector<double*> parameters;
    for (auto& b : blocks) parameters.push_back(b.data());
    std::vector<double> r_auto(6), r_hand(6);
    std::vector<std::vector<double>> j_auto(6), j_hand(6);
    std::vector<double*> p_auto, p_hand;
    for (int b = 0; b < 6; ++b) {
      j_auto[b].resize(6 * blocks[b].size());
      j_hand[b].assign(6 * blocks[b].size(), 1e9);  // every entry must be written
      p_auto.push_back(j_auto[b].data());
      p_hand.push_back(j_hand[b].data());
    }
    ASSERT_TRUE(autodiff->Evaluate(parameters.data(), r_auto.data(), p_auto.data()));
    ASSERT_TRUE(hand->Evaluate(parameters.data(), r_hand.data(), p_hand.data()));
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(r_hand[i], r_auto[i], 1e-13) << "order " << order;
    for (int b = 0; b < 6; ++b) {
      for (size_t i = 0; i < j_auto[b].size(); ++i) {
        EXPECT_NEAR(j_hand[b][i], j_auto[b][i], 1e-12) << "order " << order << " block " << b << " entry " << i;
      }
    }
    EXPECT_LT(JacobianError(*hand, blocks), 1e-6) << "order " << order;
    // Some blocks asked for, others not.
    std::vector<double*> some = {nullptr, p_hand[1], nullptr, p_hand[3], nullptr, nullptr};
    ASSERT_TRUE(hand->Evaluate(parameters.data(), r_hand.data(), some.data()));
    for (size_t i = 0; i < j_auto[3].size(); ++i) EXPECT_NEAR(j_hand[3][i], j_auto[3][i], 1e-12);
  }
  EXPECT_THROW(PatchBoundaryCost(0, Eigen::Vector2d::Zero(), Eigen::Matrix3d::Identity(), Eigen::Vector2d::Zero(),
                                 Eigen::Matrix3d::Identity(), 1.0, 1.0),
               std::invalid_argument);
  EXPECT_THROW(PatchBoundaryCost(kMaxJetOrder + 1, Eigen::Vector2d::Zero(), Eigen::Matrix3d::Identity(),
                                 Eigen::Vector2d::Zero(), Eigen::Matrix3d::Identity(), 1.0, 1.0),
               std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
