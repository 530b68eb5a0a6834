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

// A point of skinned_patch_costs.h by autodiff: the jet at the slid
// parameters, scaled, turned, translated, then skinned.
template <typename T>
void SlidPoint(int order, double u, double v, const Eigen::Matrix3d& rotation, const Eigen::Matrix3d& linear,
               const Eigen::Vector3d& translation, const T* alpha, const T* scale, const T* offset, const T* slide, T* x,
               bool skin = true) {
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

// The vertex terms by autodiff: collision, then inertia with gravity's
// linear energy folded into its target (owner), or collision alone.
struct VertexTermsAutodiff {
  int order;
  double u, v;
  Eigen::Matrix3d rotation, linear;
  Eigen::Vector3d translation;
  VertexTermsData data;
  bool motion;

  template <typename T>
  bool operator()(const T* alpha, const T* scale, const T* offset, const T* slide, T* r) const {
    T x[3];
    SlidPoint(order, u, v, rotation, linear, translation, alpha, scale, offset, slide, x);
    T depth = T(data.margin);
    for (int k = 0; k < 3; ++k) depth -= (x[k] - data.closest[k]) * data.normal[k];
    r[0] = depth > T(0.0) ? T(data.collision_weight) * depth : T(0.0);
    if (!motion) return true;
    const double w = data.inertia_weight;
    for (int k = 0; k < 3; ++k) {
      r[1 + k] = T(w) * (x[k] - data.target[k] + data.gravity_weight / (w * w) * data.up[k]);
    }
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
  double alpha[K], scale = 1.3, offset[3] = {0.05, -0.1, 0.2}, slide[2] = {0.04, -0.07};
  for (double& a : alpha) a = uniform(rng);
  const double* parameters[4] = {alpha, &scale, offset, slide};

  for (const bool motion : {true, false}) {
    f.motion = motion;
    const int rows = motion ? 4 : 1;
    SkinnedVertexCost analytic(SkinnedPatchPoint(order, f.u, f.v, f.rotation, &f.linear, &f.translation), &f.data,
                               motion);
    ASSERT_EQ(analytic.num_residuals(), rows);
    ceres::AutoDiffCostFunction<VertexTermsAutodiff, ceres::DYNAMIC, K, 1, 3, 2> automatic(new VertexTermsAutodiff(f),
                                                                                          rows);
    double ra[4], rb[4], ja[4][4 * K], jb[4][4 * K];
    double* jacobians_a[4] = {ja[0], ja[1], ja[2], ja[3]};
    double* jacobians_b[4] = {jb[0], jb[1], jb[2], jb[3]};
    ASSERT_TRUE(analytic.Evaluate(parameters, ra, jacobians_a));
    ASSERT_TRUE(automatic.Evaluate(parameters, rb, jacobians_b));
    for (int i = 0; i < rows; ++i) EXPECT_NEAR(ra[i], rb[i], 1e-12);
    const int sizes[4] = {K, 1, 3, 2};
    for (int b = 0; b < 4; ++b) {
      for (int i = 0; i < rows * sizes[b]; ++i) {
        EXPECT_NEAR(ja[b][i], jb[b][i], 1e-10) << "motion " << motion << " block " << b << " entry " << i;
      }
    }
  }
}

TEST(SkinnedPatchCostsTest, FoldedGravityHasTheLinearEnergysGradient) {
  // w_i^2 / 2 |x - x_hat + w_g / w_i^2 up|^2 - (w_i^2 / 2 |x - x_hat|^2 + w_g x . up) is constant in x.
  VertexTermsData data;
  data.gravity_weight = 0.3;
  data.inertia_weight = 1.7;
  data.target = Eigen::Vector3d(0.1, 0.5, -0.2);
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  const SkinnedPatchPoint point(2, 0.0, 0.0, identity, &identity, &zero);
  SkinnedVertexCost cost(point, &data);
  double alpha[6] = {0.0}, scale = 1.0, slide[2] = {0.0, 0.0};
  double difference[2];
  for (int i = 0; i < 2; ++i) {
    double offset[3] = {0.3 * i, -0.2 + 0.5 * i, 0.1};
    const double* parameters[4] = {alpha, &scale, offset, slide};
    double r[4];
    ASSERT_TRUE(cost.Evaluate(parameters, r, nullptr));
    const Eigen::Vector3d x(offset[0], offset[1], offset[2]);
    const double folded = 0.5 * (r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
    const double w = data.inertia_weight;
    difference[i] = folded - (0.5 * w * w * (x - data.target).squaredNorm() + data.gravity_weight * x.dot(data.up));
  }
  EXPECT_NEAR(difference[0], difference[1], 1e-12);
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
  double alpha[K], scale = 0.8, offset[3] = {0.05, -0.1, 0.2}, slide_i[2] = {0.02, 0.03}, slide_j[2] = {-0.05, 0.01};
  for (int k = 0; k < K; ++k) alpha[k] = 0.1 * std::sin(k + 1.0);
  const double* parameters[5] = {alpha, &scale, offset, slide_i, slide_j};
  SkinnedEdgeCost analytic(SkinnedPatchPoint(order, f.u[0], f.v[0], f.rotation, &f.linear[0], &f.translation[0]),
                           SkinnedPatchPoint(order, f.u[1], f.v[1], f.rotation, &f.linear[1], &f.translation[1]), f.rest,
                           f.weight);
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
  f.u[0] = 0.4, f.v[0] = -0.1, f.u[1] = -0.2, f.v[1] = 0.3;
  f.rotation[0] = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix();
  f.rotation[1] = Eigen::AngleAxisd(-0.7, Eigen::Vector3d(0.2, 1.0, 1.0).normalized()).toRotationMatrix();
  f.gap = Eigen::Vector3d(0.001, -0.002, 0.0005);
  f.weight = 5.0;
  // The skinning map is shared by both points, so the term ignores it.
  const Eigen::Matrix3d linear = 1.3 * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d translation(0.5, 0.0, 0.0);
  double alpha_a[K], alpha_b[K], scale_a = 0.9, scale_b = 1.1, offset_a[3] = {0.1, 0.0, 0.2}, offset_b[3] = {0.0, 0.1, 0.1},
                                slide_a[2] = {0.03, -0.01}, slide_b[2] = {0.02, 0.05};
  for (int k = 0; k < K; ++k) alpha_a[k] = 0.2 * std::cos(k + 0.5), alpha_b[k] = 0.1 * std::sin(2.0 * k);
  const double* parameters[8] = {alpha_a, &scale_a, offset_a, slide_a, alpha_b, &scale_b, offset_b, slide_b};
  SkinnedAgreementCost analytic(SkinnedPatchPoint(order, f.u[0], f.v[0], f.rotation[0], &linear, &translation),
                                SkinnedPatchPoint(order, f.u[1], f.v[1], f.rotation[1], &linear, &translation), f.gap,
                                f.weight);
  ceres::AutoDiffCostFunction<AgreementAutodiff, 3, K, 1, 3, 2, K, 1, 3, 2> automatic(new AgreementAutodiff(f));
  const int sizes[8] = {K, 1, 3, 2, K, 1, 3, 2};
  double ra[3], rb[3], ja[8][3 * K], jb[8][3 * K];
  double* jacobians_a[8];
  double* jacobians_b[8];
  for (int b = 0; b < 8; ++b) jacobians_a[b] = ja[b], jacobians_b[b] = jb[b];
  ASSERT_TRUE(analytic.Evaluate(parameters, ra, jacobians_a));
  ASSERT_TRUE(automatic.Evaluate(parameters, rb, jacobians_b));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(ra[i], rb[i], 1e-12);
  for (int b = 0; b < 8; ++b) {
    for (int i = 0; i < 3 * sizes[b]; ++i) EXPECT_NEAR(ja[b][i], jb[b][i], 1e-10) << "block " << b << " entry " << i;
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
  // Exact steps (sparse Cholesky) reproduce the dynamics to 1%; the
  // default inexact CG steps resolve the soft (rigid) modes less well:
  // 93% of the drop after five frames (measured).
  for (const bool cg : {false, true}) {
    DrapeSolverOptions options;
    options.parameter_prior = 0.0;
    options.max_iterations = 20;
    options.conjugate_gradients_min_vertices = cg ? 0 : garment.num_vertices() + 1;
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
    EXPECT_NEAR(y0 - solver.positions().row(1).mean(), expected, (cg ? 0.1 : 0.01) * expected) << "cg " << cg;
    const ClothMeasures m = MeasureCloth(cloth, solver.positions());
    EXPECT_LT(m.edge_strain_percent, 0.01) << "cg " << cg;
  }
}

TEST(DrapeSolverTest, SlidesUndoInPlaneSkinningDistortion) {
  // A flat sheet whose skinning stretches it in its own plane: vertices
  // weighted to a second joint by their x, that joint moved 5 cm along x.
  // Moving along the patch normals cannot undo that; slides can.
  const SkinnedBody body = MakeProceduralBody();
  TriangleMesh sheet = MakeGrid(12, 12, 0.3);
  sheet.vertices.row(1).array() += 2.5;  // no contact
  const double x_min = sheet.vertices.row(0).minCoeff(), x_max = sheet.vertices.row(0).maxCoeff();
  SkinWeights weights;
  for (int v = 0; v < sheet.num_vertices(); ++v) {
    const double t = (sheet.vertices(0, v) - x_min) / (x_max - x_min);
    weights.joint.insert(weights.joint.end(), {0, 1});
    weights.value.insert(weights.value.end(), {1.0 - t * t, t * t});
    weights.offsets.push_back(static_cast<int>(weights.joint.size()));
  }
  std::vector<Eigen::Isometry3d> pose(body.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  pose[1].translation() = Eigen::Vector3d(0.05, 0.0, 0.0);
  double strain[2];
  for (const bool slide : {false, true}) {
    DrapeSolverOptions options;
    options.slide = slide;
    options.weights.gravity = 0.0;
    options.max_iterations = 20;
    options.conjugate_gradients_min_vertices = sheet.num_vertices() + 1;
    DrapeSolver solver(body, sheet, weights, options);
    for (int step = 0; step < 3; ++step) ASSERT_TRUE(solver.Step(pose).finite);
    strain[slide] = MeasureCloth(PrepareClothRest(solver.rest_garment()), solver.positions()).edge_strain_percent;
  }
  // Measured: 7.2% mean strain without slides, under 1e-6 % with them.
  EXPECT_GT(strain[0], 5.0);
  EXPECT_LT(strain[1], 0.2 * strain[0]);
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
