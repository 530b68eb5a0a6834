#include "polyfit/patch/orientation_refinement.h"

#include <ceres/ceres.h>
#include <ceres/jet.h>

#include "polyfit/patch/local_jet_solver.h"

namespace polyfit {
namespace {

// Residuals r = (I - P(n)) sqrt(w) z(n), one per point; one parameter block,
// the unit normal n (3) of the tilted frame in the initial frame. The
// Jacobian is Kaufman's: (I - P) d(sqrt(w) (z - h(u, v)))/dn at fixed alpha.
class VarProTiltCost : public ceres::CostFunction {
 public:
  VarProTiltCost(int order, const Eigen::Matrix3Xd& local, int m, const double* sqrt_w)
      : order_(order), local_(local.leftCols(m)), sqrt_w_(sqrt_w), x_(3, m), dx_(m, 9) {
    set_num_residuals(m);
    mutable_parameter_block_sizes()->push_back(3);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    using J3 = ceres::Jet<double, 3>;
    const int m = static_cast<int>(local_.cols());
    const J3 n[3] = {J3(parameters[0][0], 0), J3(parameters[0][1], 1), J3(parameters[0][2], 2)};
    if (!(parameters[0][2] > -1.0 + 1e-9)) return false;
    const Eigen::Matrix<J3, 3, 3> rt = RotationFromZAxis(n).transpose();
    for (int i = 0; i < m; ++i) {
      for (int r = 0; r < 3; ++r) {
        const J3 xr = rt(r, 0) * local_(0, i) + rt(r, 1) * local_(1, i) + rt(r, 2) * local_(2, i);
        x_(r, i) = xr.a;
        for (int c = 0; c < 3; ++c) dx_(i, 3 * r + c) = xr.v[c];
      }
    }
    solver_.Solve(order_, x_, m, sqrt_w_);
    Eigen::Map<Eigen::VectorXd>(residuals, m) = solver_.residual();
    if (jacobians && jacobians[0]) {
      if (!solver_.well_conditioned()) return false;
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>> j(jacobians[0], m, 3);
      const Eigen::VectorXd& alpha = solver_.alpha();
      for (int i = 0; i < m; ++i) {
        const auto d = EvaluateJetDerivatives(order_, alpha.data(), x_(0, i), x_(1, i));
        const double w = sqrt_w_ ? sqrt_w_[i] : 1.0;
        for (int c = 0; c < 3; ++c) {
          j(i, c) = w * (dx_(i, 6 + c) - d.z_u * dx_(i, c) - d.z_v * dx_(i, 3 + c));
        }
      }
      solver_.ProjectOut(j);
    }
    return true;
  }

 private:
  const int order_;
  const Eigen::Matrix3Xd local_;
  const double* sqrt_w_;
  // Scratch: the tilted points and their derivatives (du/dn, dv/dn, dz/dn).
  mutable Eigen::Matrix3Xd x_;
  mutable Eigen::Matrix<double, Eigen::Dynamic, 9> dx_;
  mutable internal::LocalJetSolver<Eigen::Dynamic> solver_;
};

}  // namespace

int RefineOrientationWithCeres(const OrientationRefinementOptions& options, int order, const Eigen::Matrix3Xd& local,
                               int m, const double* sqrt_w, Eigen::Matrix3d* tilt) {
  double normal[3] = {0.0, 0.0, 1.0};
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  problem.AddResidualBlock(new VarProTiltCost(order, local, m, sqrt_w), nullptr, normal);
  problem.SetManifold(normal, new ceres::SphereManifold<3>());

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  solver_options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  *tilt = RotationFromZAxis(normal);
  return static_cast<int>(summary.iterations.size()) - 1;
}

}  // namespace polyfit
