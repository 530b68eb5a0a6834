#include <cmath>

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "cost_functions/edge_inextensibility.h"
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

}  // namespace
}  // namespace polyfit
