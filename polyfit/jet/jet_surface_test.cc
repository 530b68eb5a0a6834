#include "polyfit/jet/jet_surface.h"

#include <cmath>
#include <random>

#include <ceres/jet.h>
#include <gtest/gtest.h>

namespace polyfit {
namespace {

std::vector<double> RandomCoefficients(int order, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> dist(-0.5, 0.5);
  std::vector<double> alpha(NumJetCoefficients(order));
  for (double& a : alpha) a = dist(rng);
  return alpha;
}

TEST(JetBasis, CoefficientLayout) {
  EXPECT_EQ(NumJetCoefficients(1), 3);
  EXPECT_EQ(NumJetCoefficients(4), 15);
  EXPECT_EQ(NumJetCoefficients(8), 45);
  EXPECT_EQ(JetCoefficientIndex(0, 0), 0);
  EXPECT_EQ(JetCoefficientIndex(1, 0), 1);
  EXPECT_EQ(JetCoefficientIndex(0, 1), 2);
  EXPECT_EQ(JetCoefficientIndex(2, 0), 3);
  EXPECT_EQ(JetCoefficientIndex(0, 4), 14);
  double m[kMaxJetCoefficients];
  JetMonomials(3, 2.0, 3.0, m);
  EXPECT_DOUBLE_EQ(m[JetCoefficientIndex(2, 1)], 12.0);
  EXPECT_DOUBLE_EQ(m[JetCoefficientIndex(0, 3)], 27.0);
  EXPECT_DOUBLE_EQ(m[JetCoefficientIndex(1, 2)], 18.0);
}

TEST(JetSurface, HeightMatchesExplicitPolynomial) {
  // z = 1 + 2u - v + 0.5 u^2 + 3 u v^2
  double alpha[10] = {};
  alpha[0] = 1.0;
  alpha[JetCoefficientIndex(1, 0)] = 2.0;
  alpha[JetCoefficientIndex(0, 1)] = -1.0;
  alpha[JetCoefficientIndex(2, 0)] = 0.5;
  alpha[JetCoefficientIndex(1, 2)] = 3.0;
  const double u = 0.3, v = -0.7;
  EXPECT_NEAR(EvaluateJetHeight(3, alpha, u, v), 1 + 2 * u - v + 0.5 * u * u + 3 * u * v * v, 1e-15);
}

// Horner's scheme (EvaluateJetHeight) against the sum of alpha times the
// monomials, at every order, far from the origin too.
TEST(JetSurface, HornersHeightIsTheMonomialSum) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coordinate(-2.0, 2.0);
  for (int order = 1; order <= kMaxJetOrder; ++order) {
    const std::vector<double> alpha = RandomCoefficients(order, 100 + order);
    for (int trial = 0; trial < 20; ++trial) {
      const double u = coordinate(rng), v = coordinate(rng);
      double m[kMaxJetCoefficients];
      JetMonomials(order, u, v, m);
      double sum = 0.0, scale = 0.0;
      for (int c = 0; c < NumJetCoefficients(order); ++c) {
        sum += alpha[c] * m[c];
        scale += std::abs(alpha[c] * m[c]);
      }
      EXPECT_NEAR(EvaluateJetHeight(order, alpha.data(), u, v), sum, 1e-14 * scale) << order;
      EXPECT_NEAR(EvaluateJetDerivatives(order, alpha.data(), u, v).z, sum, 1e-14 * scale) << order;
    }
  }
}

TEST(JetSurface, DerivativesMatchAutodiffAndFiniteDifferences) {
  for (int order = 1; order <= kMaxJetOrder; ++order) {
    const std::vector<double> alpha = RandomCoefficients(order, 17 + order);
    const double u = 0.37, v = -0.61;
    const JetHeightDerivatives<double> d = EvaluateJetDerivatives(order, alpha.data(), u, v);

    using J = ceres::Jet<double, 2>;
    std::vector<J> alpha_j(alpha.begin(), alpha.end());
    const J z = EvaluateJetHeight(order, alpha_j.data(), J(u, 0), J(v, 1));
    EXPECT_NEAR(d.z, z.a, 1e-14);
    EXPECT_NEAR(d.z_u, z.v[0], 1e-13) << "order " << order;
    EXPECT_NEAR(d.z_v, z.v[1], 1e-13) << "order " << order;

    // Second derivatives by central differences of the analytic gradient.
    const double h = 1e-6;
    const auto du_p = EvaluateJetDerivatives(order, alpha.data(), u + h, v);
    const auto du_m = EvaluateJetDerivatives(order, alpha.data(), u - h, v);
    const auto dv_p = EvaluateJetDerivatives(order, alpha.data(), u, v + h);
    const auto dv_m = EvaluateJetDerivatives(order, alpha.data(), u, v - h);
    EXPECT_NEAR(d.z_uu, (du_p.z_u - du_m.z_u) / (2 * h), 1e-7);
    EXPECT_NEAR(d.z_uv, (dv_p.z_u - dv_m.z_u) / (2 * h), 1e-7);
    EXPECT_NEAR(d.z_uv, (du_p.z_v - du_m.z_v) / (2 * h), 1e-7);
    EXPECT_NEAR(d.z_vv, (dv_p.z_v - dv_m.z_v) / (2 * h), 1e-7);
  }
}

TEST(JetSurface, NormalIsOrthogonalToTangents) {
  const std::vector<double> alpha = RandomCoefficients(4, 5);
  const auto d = EvaluateJetDerivatives(4, alpha.data(), 0.2, 0.9);
  double n[3];
  JetNormal(d, n);
  EXPECT_NEAR(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1.0, 1e-15);
  EXPECT_NEAR(n[0] * 1 + n[2] * d.z_u, 0.0, 1e-15);  // . (1, 0, z_u)
  EXPECT_NEAR(n[1] * 1 + n[2] * d.z_v, 0.0, 1e-15);  // . (0, 1, z_v)
  EXPECT_GT(n[2], 0.0);
}

TEST(JetSurface, FundamentalFormsOfKnownSurfaces) {
  // Paraboloid z = (u^2 + v^2) / 2: at the apex K = 1, H = 1.
  double alpha[6] = {0, 0, 0, 0.5, 0, 0.5};
  auto d = EvaluateJetDerivatives(2, alpha, 0.0, 0.0);
  double gaussian, mean;
  JetCurvatures(d, &gaussian, &mean);
  EXPECT_NEAR(gaussian, 1.0, 1e-15);
  EXPECT_NEAR(mean, 1.0, 1e-15);

  // Saddle z = u v: K = -1 / (1 + u^2 + v^2)^2 everywhere.
  double saddle[6] = {0, 0, 0, 0, 1, 0};
  const double u = 0.4, v = -0.3;
  d = EvaluateJetDerivatives(2, saddle, u, v);
  JetCurvatures(d, &gaussian, &mean);
  const double w = 1 + u * u + v * v;
  EXPECT_NEAR(gaussian, -1.0 / (w * w), 1e-14);
  const FundamentalForm<double> I = JetFirstFundamentalForm(d);
  EXPECT_NEAR(I.e, 1 + v * v, 1e-15);
  EXPECT_NEAR(I.f, u * v, 1e-15);
  EXPECT_NEAR(I.g, 1 + u * u, 1e-15);
}

}  // namespace
}  // namespace polyfit
