#include "drape/network/mlp.h"

#include <cmath>
#include <random>

#include <ceres/autodiff_first_order_function.h>
#include <ceres/gradient_problem.h>
#include <gtest/gtest.h>

namespace polyfit {
namespace {

// A scalar loss of the network's output: L = sum_(i,n) c_in y_in + 1/2 y_in^2.
struct LossFunctor {
  const Mlp* mlp;
  Eigen::MatrixXd x, c;

  template <typename T>
  bool operator()(const T* params, T* loss) const {
    using Matrix = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;
    const Matrix y = mlp->ForwardT<T>(params, x.cast<T>());
    *loss = T(0.0);
    for (Eigen::Index i = 0; i < y.size(); ++i) *loss += T(c.data()[i]) * y.data()[i] + 0.5 * y.data()[i] * y.data()[i];
    return true;
  }
};

// The hand-written pass: L and dL/dparams.
double LossAndGradient(const Mlp& mlp, const LossFunctor& f, const std::vector<double>& params,
                       std::vector<double>* gradient, Eigen::MatrixXd* dx = nullptr) {
  Eigen::MatrixXd y;
  MlpCache cache;
  mlp.Forward(params.data(), f.x, &y, &cache);
  const Eigen::MatrixXd dy = f.c + y;
  gradient->assign(mlp.num_parameters(), 0.0);
  mlp.Backward(params.data(), cache, dy, gradient->data(), dx);
  return (f.c.array() * y.array()).sum() + 0.5 * y.squaredNorm();
}

class MlpTest : public ::testing::TestWithParam<bool> {};

TEST_P(MlpTest, BackwardMatchesAutodiffOnATinyNet) {
  const bool residual = GetParam();
  const Mlp mlp({3, 4, 4, 2}, residual, 0.1);
  ASSERT_EQ(mlp.num_parameters(), 4 * 3 + 4 + 4 * 4 + 4 + 2 * 4 + 2);
  EXPECT_EQ(mlp.SkipsAt(1), residual);
  std::vector<double> params(mlp.num_parameters());
  mlp.Initialize(7, 1.0, params.data());
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal;
  for (double& p : params) p += 0.1 * normal(rng);  // non-zero biases too
  LossFunctor f{&mlp, Eigen::MatrixXd::Random(3, 5), Eigen::MatrixXd::Random(2, 5)};

  std::vector<double> gradient;
  const double loss = LossAndGradient(mlp, f, params, &gradient);
  constexpr int kParams = 4 * 3 + 4 + 4 * 4 + 4 + 2 * 4 + 2;
  ceres::AutoDiffFirstOrderFunction<LossFunctor, kParams> autodiff(new LossFunctor(f));
  std::vector<double> expected(kParams);
  double expected_loss = 0.0;
  ASSERT_TRUE(autodiff.Evaluate(params.data(), &expected_loss, expected.data()));
  EXPECT_NEAR(loss, expected_loss, 1e-12);
  for (int i = 0; i < kParams; ++i) EXPECT_NEAR(gradient[i], expected[i], 1e-12) << i;
}

TEST_P(MlpTest, BackwardMatchesCentralDifferencesOnAWiderNet) {
  const Mlp mlp({6, 16, 16, 16, 5}, GetParam());
  std::vector<double> params(mlp.num_parameters());
  mlp.Initialize(11, 0.5, params.data());
  LossFunctor f{&mlp, Eigen::MatrixXd::Random(6, 9), Eigen::MatrixXd::Random(5, 9)};
  std::vector<double> gradient, scratch;
  Eigen::MatrixXd dx;
  LossAndGradient(mlp, f, params, &gradient, &dx);
  const double h = 1e-6;
  double worst = 0.0;
  for (int i = 0; i < mlp.num_parameters(); i += 7) {
    std::vector<double> plus = params, minus = params;
    plus[i] += h;
    minus[i] -= h;
    const double numeric =
        (LossAndGradient(mlp, f, plus, &scratch) - LossAndGradient(mlp, f, minus, &scratch)) / (2 * h);
    worst = std::max(worst, std::abs(numeric - gradient[i]));
  }
  EXPECT_LT(worst, 1e-6);
  // dL/dx too.
  for (int i = 0; i < f.x.size(); i += 5) {
    LossFunctor fp = f, fm = f;
    fp.x.data()[i] += h;
    fm.x.data()[i] -= h;
    const double numeric =
        (LossAndGradient(mlp, fp, params, &scratch) - LossAndGradient(mlp, fm, params, &scratch)) / (2 * h);
    EXPECT_NEAR(dx.data()[i], numeric, 1e-6) << i;
  }
}

INSTANTIATE_TEST_SUITE_P(ResidualOrPlain, MlpTest, ::testing::Bool());

TEST(MlpLayoutTest, InitialisationIsSeededAndTheLastLayerScaled) {
  const Mlp mlp({8, 32, 4});
  std::vector<double> a(mlp.num_parameters()), b(mlp.num_parameters()), c(mlp.num_parameters());
  mlp.Initialize(5, 1.0, a.data());
  mlp.Initialize(5, 1.0, b.data());
  mlp.Initialize(5, 0.01, c.data());
  EXPECT_EQ(a, b);
  EXPECT_EQ(a[mlp.bias_offset(0)], 0.0);
  EXPECT_NEAR(c[mlp.weight_offset(1)], 0.01 * a[mlp.weight_offset(1)], 1e-15);
  EXPECT_EQ(c[mlp.weight_offset(0)], a[mlp.weight_offset(0)]);
  EXPECT_THROW(Mlp({4}), std::invalid_argument);
  EXPECT_THROW(Mlp({4, 0, 2}), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
