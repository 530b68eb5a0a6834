#include "drape/losses/skinned_patch_costs.h"

#include <cmath>
#include <memory>
#include <random>

#include <ceres/autodiff_cost_function.h>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "polyfit/jet/jet_surface.h"

namespace polyfit {
namespace {

// A point of skinned_patch_costs.h by autodiff: the jet at the slid
// parameters, scaled, turned, translated, then skinned.
template <typename T>
void SlidPoint(int order, double u, double v, const Eigen::Matrix3d& rotation, const Eigen::Matrix3d& linear,
               const Eigen::Vector3d& translation, const T* alpha, const T* scale, const T* offset, const T* slide,
               T* x, bool skin = true) {
  const T us = T(u) + slide[0], vs = T(v) + slide[1];
  const T z = EvaluateJetHeight(order, alpha, us, vs);
  T canonical[3];
  for (int k = 0; k < 3; ++k) {
    canonical[k] = scale[0] * (rotation(k, 0) * us + rotation(k, 1) * vs + rotation(k, 2) * z) + offset[k];
  }
  for (int i = 0; i < 3; ++i) {
    if (!skin) {
      x[i] = canonical[i];
      continue;
    }
    x[i] = T(translation[i]);
    for (int k = 0; k < 3; ++k) x[i] += linear(i, k) * canonical[k];
  }
}

// The vertex terms by autodiff, written out: collision, then inertia with
// gravity's linear energy folded into its target (owner), or collision
// alone.
struct VertexTermsAutodiff {
  int order;
  double u, v;
  Eigen::Matrix3d rotation, linear;
  Eigen::Vector3d translation;
  Eigen::Vector3d closest, normal;
  double margin, collision_weight;
  double mass, dt, inertia_weight, gravity_weight, gravity;
  Eigen::Vector3d target;  // 2 x_{t-1} - x_{t-2}
  bool motion;

  template <typename T>
  bool operator()(const T* alpha, const T* scale, const T* offset, const T* slide, T* r) const {
    T x[3];
    SlidPoint(order, u, v, rotation, linear, translation, alpha, scale, offset, slide, x);
    T depth = T(margin);
    for (int k = 0; k < 3; ++k) depth -= (x[k] - closest[k]) * normal[k];
    r[0] = depth > T(0.0) ? T(collision_weight) * depth : T(0.0);
    if (!motion) return true;
    const double w = std::sqrt(inertia_weight * mass) / dt;
    const double shift = gravity_weight * gravity * dt * dt / inertia_weight;  // along up = y
    for (int k = 0; k < 3; ++k) r[1 + k] = T(w) * (x[k] - target[k] + (k == 1 ? shift : 0.0));
    return true;
  }
};

TEST(SkinnedPatchCostsTest, VertexJacobiansMatchAutodiff) {
  const int order = 4, K = 15;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-0.5, 0.5);
  VertexTermsAutodiff f;
  f.order = order;
  f.u = 0.3;
  f.v = -0.2;
  f.rotation = Eigen::Quaterniond(Eigen::Vector4d::Random().normalized()).toRotationMatrix();
  f.linear = Eigen::Matrix3d::Identity() + 0.2 * Eigen::Matrix3d::Random();
  f.translation = Eigen::Vector3d(0.1, 0.2, -0.3);
  f.closest = Eigen::Vector3d(0.0, 0.0, 0.0);
  f.normal = Eigen::Vector3d(0.0, 0.0, 1.0);
  f.margin = 10.0;  // active
  f.collision_weight = 3.0;
  f.mass = 0.02;
  f.dt = 1.0 / 30.0;
  f.inertia_weight = 0.5;
  f.gravity_weight = 0.7;
  f.gravity = 9.81;
  const Eigen::Vector3d previous(0.2, 0.1, 0.0), before(0.15, 0.12, 0.01);
  f.target = 2.0 * previous - before;
  VertexTermsData data;
  data.collision.emplace(f.closest, f.normal, f.margin, f.collision_weight, 2);
  data.inertia.emplace(previous, before, f.mass, f.dt, f.inertia_weight, f.gravity_weight, f.gravity,
                       Eigen::Vector3d::UnitY());
  double alpha[K], scale = 1.3, offset[3] = {0.05, -0.1, 0.2}, slide[2] = {0.04, -0.07};
  for (double& a : alpha) a = uniform(rng);
  const double* parameters[4] = {alpha, &scale, offset, slide};

  for (const bool motion : {true, false}) {
    f.motion = motion;
    const int rows = motion ? 4 : 1;
    SkinnedVertexCost analytic(SkinnedPatchPoint(order, f.u, f.v, f.rotation, &f.linear, &f.translation), &data,
                               motion ? VertexMotion::kInertia : VertexMotion::kNone);
    ASSERT_EQ(analytic.num_residuals(), rows);
    ceres::AutoDiffCostFunction<VertexTermsAutodiff, ceres::DYNAMIC, K, 1, 3, 2> automatic(new VertexTermsAutodiff(f),
                                                                                           rows);
    double ra[4], rb[4], ja[4][4 * K], jb[4][4 * K];
    double* jacobians_a[4] = {ja[0], ja[1], ja[2], ja[3]};
    double* jacobians_b[4] = {jb[0], jb[1], jb[2], jb[3]};
    ASSERT_TRUE(analytic.Evaluate(parameters, ra, jacobians_a));
    ASSERT_TRUE(automatic.Evaluate(parameters, rb, jacobians_b));
    for (int i = 0; i < rows; ++i) EXPECT_NEAR(ra[i], rb[i], 1e-10);
    const int sizes[4] = {K, 1, 3, 2};
    for (int b = 0; b < 4; ++b) {
      for (int i = 0; i < rows * sizes[b]; ++i) {
        EXPECT_NEAR(ja[b][i], jb[b][i], 1e-9) << "motion " << motion << " block " << b << " entry " << i;
      }
    }
  }
}

TEST(SkinnedPatchCostsTest, UnsetTermsGiveZeroAndGravityBelowTheFloorIsRejected) {
  VertexTermsData data;
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  const SkinnedPatchPoint point(2, 0.0, 0.0, identity, &identity, &zero);
  SkinnedVertexCost cost(point, &data, VertexMotion::kGravity);
  double alpha[6] = {0.0}, scale = 1.0, slide[2] = {0.0, 0.0}, offset[3] = {0.0, 0.5, 0.0};
  const double* parameters[4] = {alpha, &scale, offset, slide};
  double r[2] = {1.0, 1.0};
  ASSERT_TRUE(cost.Evaluate(parameters, r, nullptr));
  EXPECT_EQ(r[0], 0.0);
  EXPECT_EQ(r[1], 0.0);
  data.gravity.emplace(0.02, 9.81, Eigen::Vector3d::UnitY(), 0.0, 1.0);  // floor at y = 0
  ASSERT_TRUE(cost.Evaluate(parameters, r, nullptr));
  EXPECT_NEAR(0.5 * r[1] * r[1], 0.02 * 9.81 * 0.5, 1e-12);
  offset[1] = -0.1;
  EXPECT_FALSE(cost.Evaluate(parameters, r, nullptr));
}

struct EdgeAutodiff {
  int order;
  double u[2], v[2];
  Eigen::Matrix3d rotation, linear[2];
  Eigen::Vector3d translation[2];
  double rest, weight;

  template <typename T>
  bool operator()(const T* alpha, const T* scale, const T* offset, const T* slide_i, const T* slide_j, T* r) const {
    T a[3], b[3];
    SlidPoint(order, u[0], v[0], rotation, linear[0], translation[0], alpha, scale, offset, slide_i, a);
    SlidPoint(order, u[1], v[1], rotation, linear[1], translation[1], alpha, scale, offset, slide_j, b);
    using std::sqrt;
    const T length =
        sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
    r[0] = T(weight) * (length - T(rest)) / T(rest);
    return true;
  }
};

TEST(SkinnedPatchCostsTest, EdgeJacobiansMatchAutodiff) {
  const int order = 4, K = 15;
  EdgeAutodiff f;
  f.order = order;
  f.u[0] = 0.1;
  f.v[0] = 0.2;
  f.u[1] = -0.3;
  f.v[1] = 0.25;
  f.rotation = Eigen::Quaterniond(Eigen::Vector4d(0.3, -0.2, 0.9, 0.1).normalized()).toRotationMatrix();
  f.linear[0] = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  f.linear[1] = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()).toRotationMatrix();
  f.translation[0] = Eigen::Vector3d(0.1, 0.0, 0.0);
  f.translation[1] = Eigen::Vector3d(0.0, 0.2, 0.0);
  f.rest = 0.3;
  f.weight = 2.0;
  double alpha[K], scale = 0.8, offset[3] = {0.05, -0.1, 0.2}, slide_i[2] = {0.02, 0.03}, slide_j[2] = {-0.05, 0.01};
  for (int k = 0; k < K; ++k) alpha[k] = 0.1 * std::sin(k + 1.0);
  const double* parameters[5] = {alpha, &scale, offset, slide_i, slide_j};
  SkinnedEdgeCost analytic(SkinnedPatchPoint(order, f.u[0], f.v[0], f.rotation, &f.linear[0], &f.translation[0]),
                           SkinnedPatchPoint(order, f.u[1], f.v[1], f.rotation, &f.linear[1], &f.translation[1]),
                           f.rest, f.weight);
  ceres::AutoDiffCostFunction<EdgeAutodiff, 1, K, 1, 3, 2, 2> automatic(new EdgeAutodiff(f));
  double ra, rb, ja[5][K], jb[5][K];
  double* jacobians_a[5] = {ja[0], ja[1], ja[2], ja[3], ja[4]};
  double* jacobians_b[5] = {jb[0], jb[1], jb[2], jb[3], jb[4]};
  ASSERT_TRUE(analytic.Evaluate(parameters, &ra, jacobians_a));
  ASSERT_TRUE(automatic.Evaluate(parameters, &rb, jacobians_b));
  EXPECT_NEAR(ra, rb, 1e-12);
  const int sizes[5] = {K, 1, 3, 2, 2};
  for (int b = 0; b < 5; ++b) {
    for (int i = 0; i < sizes[b]; ++i) EXPECT_NEAR(ja[b][i], jb[b][i], 1e-10) << "block " << b << " entry " << i;
  }
}

struct AgreementAutodiff {
  int order;
  double u[2], v[2];
  Eigen::Matrix3d rotation[2];
  Eigen::Vector3d gap;
  double weight;

  template <typename T>
  bool operator()(const T* alpha_a, const T* scale_a, const T* offset_a, const T* slide_a, const T* alpha_b,
                  const T* scale_b, const T* offset_b, const T* slide_b, T* r) const {
    const Eigen::Matrix3d unused = Eigen::Matrix3d::Identity();
    const Eigen::Vector3d none = Eigen::Vector3d::Zero();
    T a[3], b[3];
    SlidPoint(order, u[0], v[0], rotation[0], unused, none, alpha_a, scale_a, offset_a, slide_a, a, false);
    SlidPoint(order, u[1], v[1], rotation[1], unused, none, alpha_b, scale_b, offset_b, slide_b, b, false);
    for (int k = 0; k < 3; ++k) r[k] = T(weight) * (a[k] - b[k] - gap[k]);
    return true;
  }
};

TEST(SkinnedPatchCostsTest, AgreementJacobiansMatchAutodiff) {
  const int order = 3, K = 10;
  AgreementAutodiff f;
  f.order = order;
  f.u[0] = 0.4;
  f.v[0] = -0.1;
  f.u[1] = -0.2;
  f.v[1] = 0.3;
  f.rotation[0] = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix();
  f.rotation[1] = Eigen::AngleAxisd(-0.7, Eigen::Vector3d(0.2, 1.0, 1.0).normalized()).toRotationMatrix();
  f.gap = Eigen::Vector3d(0.001, -0.002, 0.0005);
  f.weight = 5.0;
  // The skinning map is shared by both points, so the term ignores it.
  const Eigen::Matrix3d linear = 1.3 * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d translation(0.5, 0.0, 0.0);
  double alpha_a[K], alpha_b[K], scale_a = 0.9, scale_b = 1.1, offset_a[3] = {0.1, 0.0, 0.2},
                                 offset_b[3] = {0.0, 0.1, 0.1}, slide_a[2] = {0.03, -0.01}, slide_b[2] = {0.02, 0.05};
  for (int k = 0; k < K; ++k) {
    alpha_a[k] = 0.2 * std::cos(k + 0.5);
    alpha_b[k] = 0.1 * std::sin(2.0 * k);
  }
  const double* parameters[8] = {alpha_a, &scale_a, offset_a, slide_a, alpha_b, &scale_b, offset_b, slide_b};
  SkinnedAgreementCost analytic(SkinnedPatchPoint(order, f.u[0], f.v[0], f.rotation[0], &linear, &translation),
                                SkinnedPatchPoint(order, f.u[1], f.v[1], f.rotation[1], &linear, &translation), f.gap,
                                f.weight);
  ceres::AutoDiffCostFunction<AgreementAutodiff, 3, K, 1, 3, 2, K, 1, 3, 2> automatic(new AgreementAutodiff(f));
  const int sizes[8] = {K, 1, 3, 2, K, 1, 3, 2};
  double ra[3], rb[3], ja[8][3 * K], jb[8][3 * K];
  double* jacobians_a[8];
  double* jacobians_b[8];
  for (int b = 0; b < 8; ++b) {
    jacobians_a[b] = ja[b];
    jacobians_b[b] = jb[b];
  }
  ASSERT_TRUE(analytic.Evaluate(parameters, ra, jacobians_a));
  ASSERT_TRUE(automatic.Evaluate(parameters, rb, jacobians_b));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(ra[i], rb[i], 1e-12);
  for (int b = 0; b < 8; ++b) {
    for (int i = 0; i < 3 * sizes[b]; ++i) EXPECT_NEAR(ja[b][i], jb[b][i], 1e-10) << "block " << b << " entry " << i;
  }
}

TEST(SkinnedPatchCostsTest, FaceMetricJacobiansMatchAutodiff) {
  const int order = 4, K = 15;
  Eigen::Matrix<double, 2, 3> uv;
  uv << 0.1, 0.5, 0.2, -0.3, -0.1, 0.35;
  const Eigen::Vector3d rest(1.05, -0.02, 0.97);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.6, Eigen::Vector3d(0.3, 1.0, -0.4).normalized()).toRotationMatrix();
  const Eigen::Matrix3d skinning[3] = {Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()).toRotationMatrix(),
                                       1.02 * Eigen::AngleAxisd(0.25, Eigen::Vector3d::UnitY()).toRotationMatrix(),
                                       Eigen::Vector3d(0.98, 1.0, 1.03).asDiagonal() * Eigen::Matrix3d::Identity()};
  const double k_ext[3] = {1.0, 1.004, 1.01};
  const Eigen::Matrix3d* skinning_pointers[3] = {&skinning[0], &skinning[1], &skinning[2]};
  const double* k_pointers[3] = {&k_ext[0], &k_ext[1], &k_ext[2]};
  const double weight = 3.0;
  SkinnedFaceMetricCost analytic(order, uv, rest, rotation, skinning_pointers, k_pointers, weight);
  // The formula itself (cost_functions/), with the means the cost takes.
  const Eigen::Matrix3d mean_skinning = (skinning[0] + skinning[1] + skinning[2]) / 3.0;
  std::unique_ptr<ceres::CostFunction> automatic(WarpedMetricInextensibilityResidual::Create(
      order, uv, rest, rotation, mean_skinning, weight, (k_ext[0] + k_ext[1] + k_ext[2]) / 3.0));
  double alpha[K], scale = 0.9, slide_a[2] = {0.02, -0.01}, slide_b[2] = {-0.03, 0.015}, slide_c[2] = {0.01, 0.04};
  for (int k = 0; k < K; ++k) alpha[k] = 0.3 * std::cos(1.7 * k + 0.2);
  const double* parameters[5] = {alpha, &scale, slide_a, slide_b, slide_c};
  const int sizes[5] = {K, 1, 2, 2, 2};
  double ra[3], rb[3], ja[5][3 * K], jb[5][3 * K];
  double* jacobians_a[5];
  double* jacobians_b[5];
  for (int b = 0; b < 5; ++b) {
    jacobians_a[b] = ja[b];
    jacobians_b[b] = jb[b];
  }
  ASSERT_TRUE(analytic.Evaluate(parameters, ra, jacobians_a));
  ASSERT_TRUE(automatic->Evaluate(parameters, rb, jacobians_b));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(ra[i], rb[i], 1e-12);
  for (int b = 0; b < 5; ++b) {
    for (int i = 0; i < 3 * sizes[b]; ++i) EXPECT_NEAR(ja[b][i], jb[b][i], 1e-10) << "block " << b << " entry " << i;
  }
}

// DrapePhysicsOptions::stretch_factor: residuals (and their Jacobians) of
// stretch times the factor, of compression and shear unchanged.
TEST(SkinnedPatchCostsTest, OnlyStretchIsWeightedByTheStretchFactor) {
  const int order = 4, K = 15;
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.6, Eigen::Vector3d(0.3, 1.0, -0.4).normalized()).toRotationMatrix();
  const Eigen::Matrix3d linear = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Vector3d translation(0.1, 0.0, 0.0);
  double alpha[K], scale = 0.9, offset[3] = {0.05, -0.1, 0.2}, slide_a[2] = {0.02, -0.01}, slide_b[2] = {-0.03, 0.015},
                   slide_c[2] = {0.01, 0.04};
  for (int k = 0; k < K; ++k) alpha[k] = 0.3 * std::cos(1.7 * k + 0.2);
  const SkinnedPatchPoint a(order, 0.1, 0.2, rotation, &linear, &translation);
  const SkinnedPatchPoint b(order, -0.3, 0.25, rotation, &linear, &translation);
  const double* edge_parameters[5] = {alpha, &scale, offset, slide_a, slide_b};
  for (const double rest : {0.01, 10.0}) {  // stretched, compressed
    double r1, r3, j1[K], j3[K];
    double* jacobians1[5] = {j1, nullptr, nullptr, nullptr, nullptr};
    double* jacobians3[5] = {j3, nullptr, nullptr, nullptr, nullptr};
    ASSERT_TRUE(SkinnedEdgeCost(a, b, rest, 2.0).Evaluate(edge_parameters, &r1, jacobians1));
    ASSERT_TRUE(SkinnedEdgeCost(a, b, rest, 2.0, 3.0).Evaluate(edge_parameters, &r3, jacobians3));
    const double factor = rest < 1.0 ? 3.0 : 1.0;
    EXPECT_EQ(r1 > 0.0, rest < 1.0);
    EXPECT_NEAR(r3, factor * r1, 1e-12);
    for (int k = 0; k < K; ++k) EXPECT_NEAR(j3[k], factor * j1[k], 1e-12);
  }
  Eigen::Matrix<double, 2, 3> uv;
  uv << 0.1, 0.5, 0.2, -0.3, -0.1, 0.35;
  const Eigen::Matrix3d* skinning[3] = {&linear, &linear, &linear};
  const double k_ext = 1.0;
  const double* k[3] = {&k_ext, &k_ext, &k_ext};
  const double* face_parameters[5] = {alpha, &scale, slide_a, slide_b, slide_c};
  // Rest metrics below and above the posed one along u and v.
  for (const Eigen::Vector3d& rest : {Eigen::Vector3d(1e-3, 0.0, 10.0), Eigen::Vector3d(10.0, 0.0, 1e-3)}) {
    double r1[3], r3[3], j1[3], j3[3];
    double* jacobians1[5] = {nullptr, j1, nullptr, nullptr, nullptr};
    double* jacobians3[5] = {nullptr, j3, nullptr, nullptr, nullptr};
    ASSERT_TRUE(SkinnedFaceMetricCost(order, uv, rest, rotation, skinning, k, 3.0).Evaluate(face_parameters, r1,
                                                                                           jacobians1));
    ASSERT_TRUE(SkinnedFaceMetricCost(order, uv, rest, rotation, skinning, k, 3.0, 3.0)
                    .Evaluate(face_parameters, r3, jacobians3));
    for (int i = 0; i < 3; ++i) {
      const double factor = i != 1 && r1[i] > 0.0 ? 3.0 : 1.0;
      EXPECT_NEAR(r3[i], factor * r1[i], 1e-12) << "row " << i;
      EXPECT_NEAR(j3[i], factor * j1[i], 1e-12) << "row " << i;
    }
    EXPECT_NE(r1[0] > 0.0, r1[2] > 0.0);  // one stretched, one compressed
  }
}

}  // namespace
}  // namespace polyfit
