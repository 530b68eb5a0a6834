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

  SkinnedVertexCost analytic(SkinnedPatchPoint(order, f.u, f.v, f.rotation, &f.linear, &f.translation), &f.data);
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
  SkinnedEdgeCost analytic(SkinnedPatchPoint(order, f.u[0], f.v[0], f.rotation, &f.linear[0], &f.translation[0]),
                           SkinnedPatchPoint(order, f.u[1], f.v[1], f.rotation, &f.linear[1], &f.translation[1]), f.rest,
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

SkinWeights RigidWeights(int n, int joint) {
  SkinWeights weights;
  for (int v = 0; v < n; ++v) {
    weights.joint.push_back(joint);
    weights.value.push_back(1.0);
    weights.offsets.push_back(v + 1);
  }
  return weights;
}

TEST(DrapeSolverTest, PatchesReproduceTheRestGarment) {
  const SkinnedBody body = MakeProceduralBody();
  TriangleMesh garment = MakeGrid(16, 16, 0.4);
  garment.vertices.row(1).array() += 1.9;  // above the head
  DrapeSolverOptions options;
  DrapeSolver solver(body, garment, RigidWeights(garment.num_vertices(), 0), options);
  EXPECT_LT((solver.positions() - garment.vertices).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(DrapeSolverTest, AFreeSheetFallsWithTheWeightsAccelerationAndKeepsItsShape) {
  const SkinnedBody body = MakeProceduralBody();
  TriangleMesh garment = MakeGrid(16, 16, 0.4);
  garment.vertices.row(1).array() += 2.5;  // far above the head: no contact
  DrapeSolverOptions options;
  options.parameter_prior = 0.0;
  options.max_iterations = 20;
  DrapeSolver solver(body, garment, RigidWeights(garment.num_vertices(), 0), options);
  const std::vector<Eigen::Isometry3d> rest(body.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  const ClothRest cloth = PrepareClothRest(solver.rest_garment());
  const double y0 = solver.positions().row(1).mean();
  const int steps = 5;
  for (int step = 0; step < steps; ++step) {
    const DrapeStepReport report = solver.Step(rest);
    ASSERT_TRUE(report.finite);
  }
  // Implicit steps of eq. 7 + eq. 8 from rest: each frame's displacement
  // grows by a dt^2 with a = (k_g / k_i) g, so after N frames the drop is
  // a dt^2 N (N + 1) / 2.
  const double dt = 1.0 / options.fps;
  const double a = options.weights.gravity / options.weights.inertia * options.gravity;
  const double expected = a * dt * dt * steps * (steps + 1) / 2.0;
  EXPECT_NEAR(y0 - solver.positions().row(1).mean(), expected, 0.01 * expected);
  const ClothMeasures m = MeasureCloth(cloth, solver.positions());
  EXPECT_LT(m.edge_strain_percent, 0.01);
}

TEST(DrapeSolverTest, PushesAShirtStartingInsideTheBodyOut) {
  const SkinnedBody body = MakeProceduralBody();
  // Radius 0.13 m inside the torso's 0.14 m: every vertex starts inside.
  const TriangleMesh shirt = MakeTube(0.13, 0.1, 0.4, 32, 10);
  DrapeSolverOptions options;
  options.vertices_per_patch = 40;
  options.max_passes = 4;
  DrapeSolver solver(body, shirt, RigidWeights(shirt.num_vertices(), 1), options);
  EXPECT_EQ((solver.SignedDistances().array() < 0.0).count(), shirt.num_vertices());
  const std::vector<Eigen::Isometry3d> rest(body.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  for (int step = 0; step < 5; ++step) ASSERT_TRUE(solver.Step(rest).finite);
  const Eigen::VectorXd d = solver.SignedDistances();
  // Out, against the tube's inextensibility (it must stretch by 8%).
  EXPECT_LT((d.array() < 0.0).count(), shirt.num_vertices() / 10);
  EXPECT_GT(d.minCoeff(), -0.005);
}

TEST(DrapeSolverTest, StiffWeightRatiosStayFinite) {
  const SkinnedBody body = MakeProceduralBody();
  const TriangleMesh shirt = MakeTube(0.15, 0.1, 0.4, 32, 10);
  for (const double stiff : {1e6, 1e9}) {
    DrapeSolverOptions options;
    options.vertices_per_patch = 40;
    options.weights.inextensibility = stiff;  // against k_g = 1: ratio >= 1e6
    options.weights.boundary = stiff;
    options.collision_stiffness = 1e9;
    DrapeSolver solver(body, shirt, RigidWeights(shirt.num_vertices(), 1), options);
    // A quick turn of the torso's bone.
    std::vector<Eigen::Isometry3d> pose(body.skeleton.num_joints(), Eigen::Isometry3d::Identity());
    for (int step = 1; step <= 5; ++step) {
      pose[1].linear() = Eigen::AngleAxisd(0.3 * step, Eigen::Vector3d::UnitY()).toRotationMatrix();
      const DrapeStepReport report = solver.Step(pose);
      ASSERT_TRUE(report.finite) << stiff;
      ASSERT_TRUE(solver.positions().allFinite()) << stiff;
    }
    // It turned with the body (rigidly skinned); only the spin's inertia,
    // 9 rad/s, pulls at the seams (measured: 7.1% at 1e6, under 0.1% at 1e9).
    const ClothMeasures m = MeasureCloth(PrepareClothRest(solver.rest_garment()), solver.positions());
    EXPECT_LT(m.edge_strain_percent, 10.0) << stiff;
  }
}

TEST(DrapeSolverTest, RejectsBadOptionsAndGarments) {
  const SkinnedBody body = MakeProceduralBody();
  const TriangleMesh shirt = MakeTube(0.15, 0.1, 0.4, 16, 4);
  DrapeSolverOptions options;
  options.weights.collision = std::nan("");
  EXPECT_THROW(DrapeSolver(body, shirt, RigidWeights(shirt.num_vertices(), 1), options), std::invalid_argument);
  EXPECT_THROW(DrapeSolver(body, shirt, RigidWeights(3, 1), DrapeSolverOptions{}), std::invalid_argument);
  TriangleMesh broken = shirt;
  broken.vertices(0, 0) = std::nan("");
  EXPECT_THROW(DrapeSolver(body, broken, RigidWeights(shirt.num_vertices(), 1), DrapeSolverOptions{}),
               std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
