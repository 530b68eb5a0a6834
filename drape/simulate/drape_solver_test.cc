#include "drape/simulate/drape_solver.h"

#include <cmath>
#include <random>

#include <ceres/autodiff_cost_function.h>
#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"
#include "drape/simulate/skinned_patch_costs.h"
#include "polyfit/jet/jet_surface.h"
#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

// The same vertex terms by autodiff, to check the analytic Jacobians.
struct VertexTermsAutodiff {
  int order;
  double u, v;
  Eigen::Matrix3d rotation, linear;
  Eigen::Vector3d translation;
  VertexTermsData data;

  template <typename T>
  bool operator()(const T* alpha, const T* scale, const T* offset, T* r) const {
    const T z = EvaluateJetHeight(order, alpha, T(u), T(v));
    T x[3];
    for (int i = 0; i < 3; ++i) {
      T canonical[3];
      for (int k = 0; k < 3; ++k) {
        canonical[k] = scale[0] * (rotation(k, 0) * u + rotation(k, 1) * v + rotation(k, 2) * z) + offset[k];
      }
      x[i] = T(translation[i]);
      for (int k = 0; k < 3; ++k) x[i] += linear(i, k) * canonical[k];
    }
    T depth = T(data.margin);
    T height = T(-data.floor);
    for (int k = 0; k < 3; ++k) {
      depth -= (x[k] - data.closest[k]) * data.normal[k];
      height += x[k] * data.up[k];
    }
    r[0] = depth > T(0.0) ? T(data.collision_weight) * depth : T(0.0);
    using std::sqrt;
    r[1] = sqrt(T(2.0 * data.gravity_weight) * height);
    for (int k = 0; k < 3; ++k) r[2 + k] = T(data.inertia_weight) * (x[k] - data.target[k]);
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
  f.data.collision = true;
  f.data.closest = Eigen::Vector3d(0.0, 0.0, 0.0);
  f.data.normal = Eigen::Vector3d(0.0, 0.0, 1.0);
  f.data.margin = 10.0;  // active
  f.data.collision_weight = 3.0;
  f.data.gravity_weight = 0.7;
  f.data.floor = -10.0;
  f.data.inertia_weight = 2.0;
  f.data.target = Eigen::Vector3d(0.2, 0.1, 0.0);
  double alpha[K], scale = 1.3, offset[3] = {0.05, -0.1, 0.2};
  for (double& a : alpha) a = uniform(rng);
  const double* parameters[3] = {alpha, &scale, offset};

  SkinnedVertexCost analytic(SkinnedPatchPoint(order, f.u, f.v, f.rotation, f.linear, f.translation), f.data);
  ceres::AutoDiffCostFunction<VertexTermsAutodiff, 5, K, 1, 3> automatic(new VertexTermsAutodiff(f));
  double ra[5], rb[5], ja[3][5 * K], jb[3][5 * K];
  double* jacobians_a[3] = {ja[0], ja[1], ja[2]};
  double* jacobians_b[3] = {jb[0], jb[1], jb[2]};
  ASSERT_TRUE(analytic.Evaluate(parameters, ra, jacobians_a));
  ASSERT_TRUE(automatic.Evaluate(parameters, rb, jacobians_b));
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(ra[i], rb[i], 1e-12);
  const int sizes[3] = {K, 1, 3};
  for (int b = 0; b < 3; ++b) {
    for (int i = 0; i < 5 * sizes[b]; ++i) EXPECT_NEAR(ja[b][i], jb[b][i], 1e-10) << "block " << b << " entry " << i;
  }
}

struct EdgeAutodiff {
  int order;
  double u[2], v[2];
  Eigen::Matrix3d rotation, linear[2];
  Eigen::Vector3d translation[2];
  double rest, weight;

  template <typename T>
  void Point(int i, const T* alpha, const T* scale, const T* offset, T* x) const {
    const T z = EvaluateJetHeight(order, alpha, T(u[i]), T(v[i]));
    T canonical[3];
    for (int k = 0; k < 3; ++k) {
      canonical[k] = scale[0] * (rotation(k, 0) * u[i] + rotation(k, 1) * v[i] + rotation(k, 2) * z) + offset[k];
    }
    for (int r = 0; r < 3; ++r) {
      x[r] = T(translation[i][r]);
      for (int k = 0; k < 3; ++k) x[r] += linear[i](r, k) * canonical[k];
    }
  }
  template <typename T>
  bool operator()(const T* alpha, const T* scale, const T* offset, T* r) const {
    T a[3], b[3];
    Point(0, alpha, scale, offset, a);
    Point(1, alpha, scale, offset, b);
    using std::sqrt;
    const T length = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
    r[0] = T(weight) * (length - T(rest)) / T(rest);
    return true;
  }
};

TEST(SkinnedPatchCostsTest, EdgeJacobiansMatchAutodiff) {
  const int order = 4, K = 15;
  EdgeAutodiff f;
  f.order = order;
  f.u[0] = 0.1, f.v[0] = 0.2, f.u[1] = -0.3, f.v[1] = 0.25;
  f.rotation = Eigen::Quaterniond(Eigen::Vector4d(0.3, -0.2, 0.9, 0.1).normalized()).toRotationMatrix();
  f.linear[0] = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  f.linear[1] = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()).toRotationMatrix();
  f.translation[0] = Eigen::Vector3d(0.1, 0.0, 0.0);
  f.translation[1] = Eigen::Vector3d(0.0, 0.2, 0.0);
  f.rest = 0.3;
  f.weight = 2.0;
  double alpha[K], scale = 0.8, offset[3] = {0.05, -0.1, 0.2};
  for (int k = 0; k < K; ++k) alpha[k] = 0.1 * std::sin(k + 1.0);
  const double* parameters[3] = {alpha, &scale, offset};
  SkinnedEdgeCost analytic(SkinnedPatchPoint(order, f.u[0], f.v[0], f.rotation, f.linear[0], f.translation[0]),
                           SkinnedPatchPoint(order, f.u[1], f.v[1], f.rotation, f.linear[1], f.translation[1]), f.rest,
                           f.weight);
  ceres::AutoDiffCostFunction<EdgeAutodiff, 1, K, 1, 3> automatic(new EdgeAutodiff(f));
  double ra, rb, ja[3][K], jb[3][K];
  double* jacobians_a[3] = {ja[0], ja[1], ja[2]};
  double* jacobians_b[3] = {jb[0], jb[1], jb[2]};
  ASSERT_TRUE(analytic.Evaluate(parameters, &ra, jacobians_a));
  ASSERT_TRUE(automatic.Evaluate(parameters, &rb, jacobians_b));
  EXPECT_NEAR(ra, rb, 1e-12);
  const int sizes[3] = {K, 1, 3};
  for (int b = 0; b < 3; ++b) {
    for (int i = 0; i < sizes[b]; ++i) EXPECT_NEAR(ja[b][i], jb[b][i], 1e-10) << "block " << b << " entry " << i;
  }
}

TEST(DrapeSolverTest, PatchesReproduceTheRestGarment) {
  const SkinnedBody body = MakeProceduralBody();
  TriangleMesh garment = MakeGrid(16, 16, 0.4);
  garment.vertices.row(1).array() += 1.9;  // above the head
  SkinWeights weights;
  for (int v = 0; v < garment.num_vertices(); ++v) {
    weights.joint.push_back(0);
    weights.value.push_back(1.0);
    weights.offsets.push_back(v + 1);
  }
  DrapeSolverOptions options;
  DrapeSolver solver(body, garment, weights, options);
  EXPECT_LT((solver.positions() - garment.vertices).cwiseAbs().maxCoeff(), 1e-6);
}

}  // namespace
}  // namespace polyfit

namespace polyfit {
namespace {

TEST(DrapeSolverTest, RestPoseStepKeepsAFreeSheetInextensible) {
  const SkinnedBody body = MakeProceduralBody();
  TriangleMesh garment = MakeGrid(16, 16, 0.4);
  garment.vertices.row(1).array() += 2.5;  // far above the head: no contact
  SkinWeights weights;
  for (int v = 0; v < garment.num_vertices(); ++v) {
    weights.joint.push_back(0);
    weights.value.push_back(1.0);
    weights.offsets.push_back(v + 1);
  }
  DrapeSolverOptions options;
  DrapeSolver solver(body, garment, weights, options);
  const std::vector<Eigen::Isometry3d> rest(body.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  const ClothRest cloth = PrepareClothRest(garment);
  for (int step = 0; step < 5; ++step) {
    const DrapeStepReport report = solver.Step(rest);
    const ClothMeasures m = MeasureCloth(cloth, solver.positions());
    std::printf("step %d: strain %.4f%% area %.4f%% cost %g -> %g iterations %d time %.1f ms\n", step,
                m.edge_strain_percent, m.area_change_percent, report.initial_cost, report.final_cost, report.iterations,
                1e3 * report.time_s);
    EXPECT_TRUE(report.finite);
    EXPECT_LT(m.edge_strain_percent, 1.0);
  }
}

}  // namespace
}  // namespace polyfit
