#include "polyfit/patch/jet_fit.h"

#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <gtest/gtest.h>

#include "polyfit/eval/metrics.h"
#include "polyfit/patch/local_jet_solver.h"
#include "polyfit/synthetic/patch_families.h"

namespace polyfit {
namespace {

bool AllFinite(const JetPatch& p) {
  for (double c : p.coefficients) {
    if (!std::isfinite(c)) return false;
  }
  return p.frame.rotation.allFinite() && p.frame.translation.allFinite() && std::isfinite(p.frame.scale) &&
         p.frame.scale > 0 && std::isfinite(p.rms_residual);
}

Eigen::Matrix3Xd RandomPlane(int m, const Eigen::Vector3d& offset, unsigned seed, Eigen::Vector3d* normal) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(-1, 1);
  const Eigen::Matrix3d r = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
  *normal = r.col(2);
  Eigen::Matrix3Xd points(3, m);
  for (int i = 0; i < m; ++i) points.col(i) = r * Eigen::Vector3d(uni(rng), uni(rng), 0) + offset;
  return points;
}

TEST(LocalJetSolver, RecoversExactPolynomialAtEveryOrder) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uni(-1, 1);
  for (int order = 1; order <= kMaxJetOrder; ++order) {
    const int k = NumJetCoefficients(order);
    std::vector<double> alpha(k);
    for (double& a : alpha) a = uni(rng);
    const int m = 3 * k;
    Eigen::Matrix3Xd local(3, m);
    for (int i = 0; i < m; ++i) {
      local(0, i) = uni(rng);
      local(1, i) = uni(rng);
      local(2, i) = EvaluateJetHeight(order, alpha.data(), local(0, i), local(1, i));
    }
    internal::LocalJetSolver<Eigen::Dynamic> solver;
    EXPECT_EQ(solver.Solve(order, local, m, nullptr), 0u) << "order " << order;
    for (int j = 0; j < k; ++j) EXPECT_NEAR(solver.alpha()[j], alpha[j], 1e-8) << "order " << order;
    EXPECT_LT(solver.ssr(), 1e-20);
  }
}

TEST(LocalJetSolver, WeightedFitMatchesDenseQr) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> uni(-1, 1);
  const int order = 4, k = 15, m = 64;
  Eigen::Matrix3Xd local = Eigen::Matrix3Xd::NullaryExpr(3, m, [&] { return uni(rng); });
  std::vector<double> sqrt_w(m);
  for (double& w : sqrt_w) w = 0.2 + std::abs(uni(rng));
  Eigen::MatrixXd a(m, k);
  Eigen::VectorXd b(m);
  double mono[kMaxJetCoefficients];
  for (int i = 0; i < m; ++i) {
    JetMonomials(order, local(0, i), local(1, i), mono);
    for (int j = 0; j < k; ++j) a(i, j) = sqrt_w[i] * mono[j];
    b[i] = sqrt_w[i] * local(2, i);
  }
  const Eigen::VectorXd expected = a.colPivHouseholderQr().solve(b);
  internal::LocalJetSolver<15> solver;
  solver.Solve(order, local, m, sqrt_w.data());
  for (int j = 0; j < k; ++j) EXPECT_NEAR(solver.alpha()[j], expected[j], 1e-10);
  EXPECT_NEAR(solver.ssr(), (b - a * expected).squaredNorm(), 1e-12);
}

TEST(JetFitter, PlaneFarFromOriginIsExact) {
  Eigen::Vector3d normal;
  const Eigen::Vector3d offset(1e6, -2e6, 3e6);
  const Eigen::Matrix3Xd points = RandomPlane(100, offset, 1, &normal);
  JetFitter fitter(JetFitOptions{});
  const JetPatch patch = fitter.Fit(points);
  EXPECT_EQ(patch.flags, 0u) << JetFitFlagsToString(patch.flags);
  EXPECT_TRUE(AllFinite(patch));
  EXPECT_LT(patch.rms_residual, 1e-9);
  EXPECT_NEAR(std::abs(patch.NormalInWorld(0.3, 0.2).dot(normal)), 1.0, 1e-12);
  for (int i = 0; i < points.cols(); ++i) {
    const Eigen::Vector3d q = patch.frame.PointToPatch(points.col(i));
    EXPECT_LT((patch.PointInWorld(q.x(), q.y()) - points.col(i)).norm(), 1e-8);
  }
}

TEST(JetFitter, LargeOffsetDoesNotChangeTheFit) {
  SyntheticPatchOptions options;
  options.num_points = 64;
  options.noise_sigma = 0.01;
  std::mt19937_64 rng(7);
  const SyntheticPatch sp = GenerateSyntheticPatch(options, rng);
  JetFitter fitter(JetFitOptions{});
  const JetPatch near = fitter.Fit(sp.points_in_world);
  const Eigen::Vector3d offset(1e6, 1e6, -1e6);
  const Eigen::Matrix3Xd far_points = sp.points_in_world.colwise() + offset;
  const JetPatch far = fitter.Fit(far_points);
  EXPECT_NEAR(far.rms_residual, near.rms_residual, 1e-8);
  const Eigen::Matrix3Xd far_surface = sp.surface_points_in_world.colwise() + offset;
  const double e_near =
      EvaluatePatchAgainstSurface(near, sp.surface_points_in_world, sp.surface_normals_in_world).height_rmse();
  const double e_far = EvaluatePatchAgainstSurface(far, far_surface, sp.surface_normals_in_world).height_rmse();
  EXPECT_NEAR(e_far, e_near, 1e-7);
}

TEST(JetFitter, FewerPointsThanCoefficientsFitsLowerOrder) {
  SyntheticPatchOptions options;
  options.num_points = 12;  // order 4 needs 15, order 3 needs 10
  std::mt19937_64 rng(8);
  const SyntheticPatch sp = GenerateSyntheticPatch(options, rng);
  JetFitter fitter(JetFitOptions{});
  const JetPatch patch = fitter.Fit(sp.points_in_world);
  EXPECT_TRUE(patch.flags & kJetFitReducedOrder);
  EXPECT_EQ(patch.order, 3);
  EXPECT_TRUE(AllFinite(patch));
  for (int k = NumJetCoefficients(3); k < kMaxJetCoefficients; ++k) EXPECT_EQ(patch.coefficients[k], 0.0);
}

TEST(JetFitter, CoincidentPointsGiveADegenerateFlatPatch) {
  const Eigen::Matrix3Xd points = Eigen::Vector3d(1, 2, 3).replicate(1, 20);
  JetFitter fitter(JetFitOptions{});
  const JetPatch patch = fitter.Fit(points);
  EXPECT_TRUE(patch.flags & kJetFitDegenerate);
  EXPECT_EQ(patch.order, 0);
  EXPECT_TRUE(AllFinite(patch));
  EXPECT_LT((patch.PointInWorld(0, 0) - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);

  const JetPatch empty = fitter.Fit(Eigen::Matrix3Xd(3, 0));
  EXPECT_TRUE(empty.flags & kJetFitDegenerate);
  EXPECT_TRUE(AllFinite(empty));
}

TEST(JetFitter, CollinearPointsAreRankDeficientButFinite) {
  Eigen::Matrix3Xd points(3, 30);
  for (int i = 0; i < 30; ++i) points.col(i) = Eigen::Vector3d(1, 2, 3) + (i - 15) * Eigen::Vector3d(0.3, -0.1, 0.2);
  for (int order : {1, 4, 8}) {
    JetFitOptions options;
    options.order = order;
    options.refine_orientation = true;
    JetFitter fitter(options);
    const JetPatch patch = fitter.Fit(points);
    EXPECT_TRUE(patch.flags & kJetFitRankDeficient) << JetFitFlagsToString(patch.flags);
    EXPECT_TRUE(AllFinite(patch));
    EXPECT_LT(patch.rms_residual, 1e-9);
    // The line itself is reproduced.
    const Eigen::Vector3d q = patch.frame.PointToPatch(points.col(4));
    EXPECT_LT((patch.PointInWorld(q.x(), q.y()) - points.col(4)).norm(), 1e-8);
  }
}

TEST(JetFitter, NonFinitePointsAreDroppedAndReported) {
  SyntheticPatchOptions options;
  options.num_points = 80;
  std::mt19937_64 rng(9);
  const SyntheticPatch sp = GenerateSyntheticPatch(options, rng);
  Eigen::Matrix3Xd points = sp.points_in_world;
  points(0, 3) = std::numeric_limits<double>::quiet_NaN();
  points(2, 40) = std::numeric_limits<double>::infinity();
  JetFitter fitter(JetFitOptions{});
  const JetPatch patch = fitter.Fit(points);
  EXPECT_TRUE(patch.flags & kJetFitDroppedNonFinite);
  EXPECT_EQ(patch.num_points, 78);
  EXPECT_TRUE(AllFinite(patch));

  Eigen::Matrix3Xd clean(3, 78);
  for (int i = 0, j = 0; i < 80; ++i) {
    if (i != 3 && i != 40) clean.col(j++) = sp.points_in_world.col(i);
  }
  const JetPatch expected = fitter.Fit(clean);
  EXPECT_NEAR(patch.rms_residual, expected.rms_residual, 1e-12);
  for (int k = 0; k < 15; ++k) EXPECT_NEAR(patch.coefficients[k], expected.coefficients[k], 1e-10);

  const Eigen::Matrix3Xd all_nan = Eigen::Matrix3Xd::Constant(3, 10, std::numeric_limits<double>::quiet_NaN());
  const JetPatch bad = fitter.Fit(all_nan);
  EXPECT_TRUE(bad.flags & kJetFitDegenerate);
  EXPECT_TRUE(AllFinite(bad));
}

TEST(JetFitter, FoldOverThePcaPlaneIsFlaggedAndRefinementRecoversIt) {
  // z = 3 u^2: taller than wide, so PCA puts the normal in the tangent plane.
  std::mt19937_64 rng(10);
  std::uniform_real_distribution<double> uni(-1, 1);
  const int m = 256;
  Eigen::Matrix3Xd points(3, m), normals(3, m);
  for (int i = 0; i < m; ++i) {
    const double u = uni(rng), v = uni(rng);
    points.col(i) = Eigen::Vector3d(u, v, 3 * u * u);
    normals.col(i) = Eigen::Vector3d(-6 * u, 0, 1).normalized();
  }
  JetFitter plain(JetFitOptions{});
  const JetPatch folded = plain.Fit(points);
  EXPECT_TRUE(folded.flags & kJetFitNotHeightField) << JetFitFlagsToString(folded.flags);
  EXPECT_TRUE(AllFinite(folded));

  JetFitOptions options;
  options.refine_orientation = true;
  options.refinement.max_iterations = 20;
  JetFitter refined_fitter(options);
  const JetPatch refined = refined_fitter.Fit(points);
  EXPECT_FALSE(refined.flags & kJetFitNotHeightField) << JetFitFlagsToString(refined.flags);
  EXPECT_LT(refined.rms_residual, 0.2 * folded.rms_residual);
  const double e_folded = EvaluatePatchAgainstSurface(folded, points, normals).normal_error_deg();
  const double e_refined = EvaluatePatchAgainstSurface(refined, points, normals).normal_error_deg();
  EXPECT_LT(e_refined, 0.5 * e_folded);
}

TEST(JetFitter, OrderEightOnSixtyFourPointsIsStable) {
  SyntheticPatchOptions sopt;
  sopt.num_points = 64;
  sopt.noise_sigma = 0.01;
  const SyntheticPatchSet set = GenerateSyntheticPatchSet(sopt, 200, 11);
  JetFitOptions options;
  std::vector<JetPatch> order4, patches;
  FitJetPatches(options, set.points_in_world, set.offsets, nullptr, &order4);
  options.order = 8;
  FitJetPatches(options, set.points_in_world, set.offsets, nullptr, &patches);
  for (size_t p = 0; p < patches.size(); ++p) {
    ASSERT_TRUE(AllFinite(patches[p])) << "patch " << p;
    EXPECT_EQ(patches[p].order, 8);
    EXPECT_FALSE(patches[p].flags & kJetFitRankDeficient);
    // More coefficients in the same (PCA) frame never fit worse.
    EXPECT_LE(patches[p].rms_residual, order4[p].rms_residual * (1 + 1e-9));
  }
}

TEST(JetFitter, ErrorFallsWithOrderOnASmoothSurface) {
  SyntheticPatchOptions sopt;
  sopt.num_points = 256;
  const SyntheticPatchSet set = GenerateSyntheticPatchSet(sopt, 50, 12);
  double previous = 1e9;
  for (int order : {1, 2, 4, 6, 8}) {
    JetFitOptions options;
    options.order = order;
    std::vector<JetPatch> patches;
    FitJetPatches(options, set.points_in_world, set.offsets, nullptr, &patches);
    const SurfaceErrorAccumulator acc = EvaluatePatchSet(set, patches);
    EXPECT_LT(acc.height_rmse(), previous) << "order " << order;
    previous = acc.height_rmse();
  }
}

TEST(FitJetPatches, MatchesSingleFitsOnAnyThreadCountWithWeights) {
  SyntheticPatchOptions sopt;
  sopt.num_points = 40;
  sopt.noise_sigma = 0.02;
  SyntheticPatchSet set = GenerateSyntheticPatchSet(sopt, 300, 13);
  std::vector<double> weights(set.points_in_world.cols());
  std::mt19937_64 rng(1);
  for (double& w : weights) w = std::uniform_real_distribution<double>(0.5, 2.0)(rng);
  JetFitOptions options;
  options.refine_orientation = true;
  std::vector<JetPatch> one, two;
  options.num_threads = 1;
  const JetFitSummary s1 = FitJetPatches(options, set.points_in_world, set.offsets, &weights, &one);
  options.num_threads = 2;
  const JetFitSummary s2 = FitJetPatches(options, set.points_in_world, set.offsets, &weights, &two);
  EXPECT_EQ(s1.num_patches, 300);
  EXPECT_EQ(s2.num_threads, 2);
  EXPECT_EQ(s1.num_points, 300 * 40);
  EXPECT_DOUBLE_EQ(s1.rms_residual, s2.rms_residual);
  JetFitter fitter(options);
  for (int p : {0, 17, 299}) {
    const JetPatch single = fitter.Fit(set.patches[p].points_in_world, weights.data() + set.offsets[p]);
    EXPECT_EQ(single.coefficients, one[p].coefficients);
    EXPECT_EQ(single.coefficients, two[p].coefficients);
  }
}

TEST(FitJetPatches, RejectsInvalidInput) {
  std::vector<JetPatch> patches;
  Eigen::Matrix3Xd points = Eigen::Matrix3Xd::Random(3, 10);
  JetFitOptions options;
  EXPECT_THROW(FitJetPatches(options, points, {0, 5, 9}, nullptr, &patches), std::invalid_argument);
  EXPECT_THROW(FitJetPatches(options, points, {0, 6, 5, 10}, nullptr, &patches), std::invalid_argument);
  std::vector<double> short_weights(3, 1.0);
  EXPECT_THROW(FitJetPatches(options, points, {0, 10}, &short_weights, &patches), std::invalid_argument);
  options.order = 9;
  EXPECT_THROW(FitJetPatches(options, points, {0, 10}, nullptr, &patches), std::invalid_argument);
  EXPECT_THROW(JetFitter{options}, std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
