#include "cost_functions/jet_height_residual.h"

#include <memory>
#include <random>

#include <ceres/ceres.h>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "polyfit/patch/jet_fit.h"
#include "polyfit/synthetic/patch_families.h"

namespace polyfit {
namespace {

struct Blocks {
  std::vector<double> alpha;
  double rotation[4];  // world_from_patch, (w, x, y, z)
  double origin[3];
};

Blocks RandomBlocks(int order, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uni(-0.5, 0.5);
  Blocks b;
  b.alpha.resize(NumJetCoefficients(order));
  for (double& a : b.alpha) a = uni(rng);
  Eigen::Quaterniond q(1 + uni(rng), uni(rng), uni(rng), uni(rng));
  q.normalize();
  b.rotation[0] = q.w();
  b.rotation[1] = q.x();
  b.rotation[2] = q.y();
  b.rotation[3] = q.z();
  for (double& t : b.origin) t = 3 * uni(rng);
  return b;
}

TEST(JetHeightResidual, ResidualMatchesClosedForm) {
  std::mt19937_64 rng(1);
  const int order = 4;
  Blocks b = RandomBlocks(order, rng);
  const Eigen::Vector3d p(0.7, -0.2, 1.3);
  const double scale = 1.7, weight = 0.5;
  std::unique_ptr<ceres::CostFunction> cost(JetHeightResidual::Create(order, p, scale, weight));
  const double* params[3] = {b.alpha.data(), b.rotation, b.origin};
  double r;
  ASSERT_TRUE(cost->Evaluate(params, &r, nullptr));
  const Eigen::Matrix3d rot =
      Eigen::Quaterniond(b.rotation[0], b.rotation[1], b.rotation[2], b.rotation[3]).toRotationMatrix();
  const Eigen::Vector3d q = rot.transpose() * (p - Eigen::Map<Eigen::Vector3d>(b.origin)) / scale;
  const double expected = weight * scale * (q.z() - EvaluateJetHeight(order, b.alpha.data(), q.x(), q.y()));
  EXPECT_NEAR(r, expected, 1e-13);
}

TEST(JetHeightResidual, JacobianMatchesFiniteDifferences) {
  std::mt19937_64 rng(2);
  for (int order = 1; order <= kMaxJetOrder; ++order) {
    Blocks b = RandomBlocks(order, rng);
    const Eigen::Vector3d p(0.4, 0.9, -0.6);
    std::unique_ptr<ceres::CostFunction> cost(JetHeightResidual::Create(order, p, 1.3));
    const int k = NumJetCoefficients(order);
    double* blocks[3] = {b.alpha.data(), b.rotation, b.origin};
    const int sizes[3] = {k, 4, 3};
    std::vector<double> j0(k), j1(4), j2(3);
    double* jac[3] = {j0.data(), j1.data(), j2.data()};
    double r;
    ASSERT_TRUE(cost->Evaluate(blocks, &r, jac));
    const double h = 1e-7;
    for (int blk = 0; blk < 3; ++blk) {
      for (int i = 0; i < sizes[blk]; ++i) {
        const double saved = blocks[blk][i];
        double rp, rm;
        blocks[blk][i] = saved + h;
        cost->Evaluate(blocks, &rp, nullptr);
        blocks[blk][i] = saved - h;
        cost->Evaluate(blocks, &rm, nullptr);
        blocks[blk][i] = saved;
        EXPECT_NEAR(jac[blk][i], (rp - rm) / (2 * h), 1e-6) << "order " << order << " block " << blk;
      }
    }
  }
}

TEST(JetHeightResidual, CeresSolveReachesTheClosedFormFit) {
  SyntheticPatchOptions sopt;
  sopt.num_points = 100;
  sopt.noise_sigma = 0.01;
  std::mt19937_64 rng(3);
  const SyntheticPatch sp = GenerateSyntheticPatch(sopt, rng);
  JetFitter fitter(JetFitOptions{});
  const JetPatch fit = fitter.Fit(sp.points_in_world);

  const Eigen::Quaterniond q(fit.frame.rotation);
  double rotation[4] = {q.w(), q.x(), q.y(), q.z()};
  double origin[3] = {fit.frame.translation.x(), fit.frame.translation.y(), fit.frame.translation.z()};
  std::vector<double> alpha(15, 0.0);
  ceres::Problem problem;
  for (int i = 0; i < sp.points_in_world.cols(); ++i) {
    problem.AddResidualBlock(JetHeightResidual::Create(4, sp.points_in_world.col(i), fit.frame.scale), nullptr,
                             alpha.data(), rotation, origin);
  }
  problem.SetParameterBlockConstant(rotation);
  problem.SetParameterBlockConstant(origin);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.function_tolerance = 1e-15;
  options.gradient_tolerance = 1e-15;
  options.parameter_tolerance = 1e-15;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable());
  for (int k = 0; k < 15; ++k) EXPECT_NEAR(alpha[k], fit.coefficients[k], 1e-7) << k;
  EXPECT_NEAR(std::sqrt(2 * summary.final_cost / sp.points_in_world.cols()), fit.rms_residual, 1e-10);
}

TEST(JetHeightResidual, RejectsBadArguments) {
  EXPECT_THROW(JetHeightResidual::Create(0, Eigen::Vector3d::Zero(), 1.0), std::invalid_argument);
  EXPECT_THROW(JetHeightResidual::Create(9, Eigen::Vector3d::Zero(), 1.0), std::invalid_argument);
  EXPECT_THROW(JetHeightResidual::Create(4, Eigen::Vector3d::Zero(), 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
