// Fits the 2-jet of z = 0.3 u^2 - 0.2 u v + 0.1 v in a fixed frame with
// PolyFit's JetHeightResidual in a user's own Ceres problem. Exit 0 when the
// coefficients come back.
#include <cmath>
#include <cstdio>

#include <ceres/ceres.h>

#include "cost_functions/jet_height_residual.h"

int main() {
  using polyfit::JetCoefficientIndex;
  double truth[6] = {};
  truth[JetCoefficientIndex(0, 1)] = 0.1;
  truth[JetCoefficientIndex(2, 0)] = 0.3;
  truth[JetCoefficientIndex(1, 1)] = -0.2;

  double alpha[6] = {};
  double rotation[4] = {1, 0, 0, 0};  // identity: the patch frame is the world
  double origin[3] = {0, 0, 0};
  ceres::Problem problem;
  for (int i = 0; i < 11; ++i) {
    for (int j = 0; j < 11; ++j) {
      const double u = -1 + 0.2 * i, v = -1 + 0.2 * j;
      const Eigen::Vector3d p(u, v, polyfit::EvaluateJetHeight(2, truth, u, v));
      problem.AddResidualBlock(polyfit::JetHeightResidual::Create(2, p, 1.0), nullptr, alpha, rotation, origin);
    }
  }
  problem.SetParameterBlockConstant(rotation);
  problem.SetParameterBlockConstant(origin);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);

  double max_error = 0;
  for (int k = 0; k < 6; ++k) max_error = std::max(max_error, std::abs(alpha[k] - truth[k]));
  std::printf("2-jet recovered with max coefficient error %.3g (%d iterations)\n", max_error,
              static_cast<int>(summary.iterations.size()));
  return max_error < 1e-8 ? 0 : 1;
}
