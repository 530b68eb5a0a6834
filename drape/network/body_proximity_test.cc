#include "drape/network/body_proximity.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"
#include "polyfit/eval/kd_tree.h"
#include "polyfit/eval/mesh_metrics.h"

namespace polyfit {
namespace {

// One flat patch at the origin, turned by `rotation`, of frame scale `scale`.
PolyFitModel FlatPatch(const Eigen::Matrix3d& rotation, double scale) {
  PolyFitModel model;
  JetPatch patch;
  patch.order = 2;
  patch.frame.rotation = rotation;
  patch.frame.scale = scale;
  patch.frame.translation = Eigen::Vector3d(0.1, 0.2, 0.3);
  model.patches.push_back(patch);
  return model;
}

TEST(PatchProbesTest, SitOnTheRestJetAtHalfTheAreasRadiusWhateverTheFramesScale) {
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const double area = 0.01, reach = kProbeReach * std::sqrt(area / M_PI);
  for (const double scale : {0.5, 2.0}) {
    const PatchProbes probes = MakePatchProbes(FlatPatch(rotation, scale), {area}, Eigen::MatrixXd::Ones(1, 1));
    ASSERT_EQ(probes.rest_points.cols(), kProximityProbes);
    const Eigen::Vector3d centre = probes.rest_points.col(0);
    EXPECT_NEAR((centre - Eigen::Vector3d(0.1, 0.2, 0.3)).norm(), 0.0, 1e-15);
    for (int i = 1; i < kProximityProbes; ++i) {
      const Eigen::Vector3d offset = probes.rest_points.col(i) - centre;
      EXPECT_NEAR(offset.norm(), reach, 1e-12) << scale << " " << i;
      EXPECT_NEAR(offset.dot(rotation.col(2)), 0.0, 1e-12);  // in the patch's plane
    }
    // Opposite probes pair up along the frame's two axes.
    EXPECT_NEAR((probes.rest_points.col(1) - centre).dot(rotation.col(0)), reach, 1e-12);
    EXPECT_NEAR((probes.rest_points.col(4) - centre).dot(rotation.col(1)), -reach, 1e-12);
  }
  EXPECT_THROW(MakePatchProbes(FlatPatch(rotation, 1.0), {}, Eigen::MatrixXd::Ones(1, 1)), std::invalid_argument);
}

TEST(PatchProbesTest, TheRimLayoutAddsFourDiagonalProbesOnTheAreasRadius) {
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(-0.4, Eigen::Vector3d(3, 1, 2).normalized()).toRotationMatrix();
  const double area = 0.02, rho = std::sqrt(area / M_PI);
  const PolyFitModel patch = FlatPatch(rotation, 1.5);
  const PatchProbes five = MakePatchProbes(patch, {area}, Eigen::MatrixXd::Ones(1, 1));
  const PatchProbes nine = MakePatchProbes(patch, {area}, Eigen::MatrixXd::Ones(1, 1), kRimProximityProbes);
  ASSERT_EQ(nine.probes_per_patch, kRimProximityProbes);
  ASSERT_EQ(nine.rest_points.cols(), kRimProximityProbes);
  EXPECT_EQ(nine.rest_points.leftCols(kProximityProbes), five.rest_points);  // the default's first
  const Eigen::Vector3d centre = nine.rest_points.col(0);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int i = kProximityProbes; i < kRimProximityProbes; ++i) {
    const Eigen::Vector3d offset = nine.rest_points.col(i) - centre;
    EXPECT_NEAR(offset.norm(), rho, 1e-12) << i;
    EXPECT_NEAR(std::abs(offset.dot(rotation.col(0))), rho / std::sqrt(2.0), 1e-12) << i;  // diagonal
    EXPECT_NEAR(offset.dot(rotation.col(2)), 0.0, 1e-12);
    sum += offset;
  }
  EXPECT_NEAR(sum.norm(), 0.0, 1e-12);  // four corners, opposite in pairs
  for (const int count : {0, 4, 6, 13}) {
    EXPECT_THROW(MakePatchProbes(patch, {area}, Eigen::MatrixXd::Ones(1, 1), count), std::invalid_argument);
  }
  // The features: four values a probe.
  const SkinnedBody body = MakeProceduralBody();
  const PosedBodySamples samples(body, 0.05);
  Eigen::MatrixXd root_only = Eigen::MatrixXd::Zero(body.skeleton.num_joints(), 1);
  root_only(0, 0) = 1.0;
  const PatchProbes on_body = MakePatchProbes(patch, {area}, root_only, kRimProximityProbes);
  Eigen::MatrixXd features;
  BodyProximityFeatures(on_body, JointTransforms(body.skeleton.num_joints(), Eigen::Isometry3d::Identity()), samples,
                        &features);
  EXPECT_EQ(features.rows(), ProximitySize(kRimProximityProbes));
  EXPECT_EQ(features.cols(), 1);
  for (int i = 0; i < kRimProximityProbes; ++i) {
    EXPECT_NEAR(features(4 * i, 0),
                std::clamp(samples.Query(on_body.rest_points.col(i)).distance / kProximityScale, -kProximityClamp,
                           kProximityClamp),
                1e-12);
    EXPECT_NEAR(features.col(0).segment<3>(4 * i + 1).norm(), 1.0, 1e-12);  // a unit normal
  }
}

class BodyProximityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    body_ = MakeProceduralBody();
    const int joints = body_.skeleton.num_joints();
    // Two patches on the torso's joint (1), one blended with the root:
    // probes a little outside, inside and far from the body.
    Eigen::MatrixXd weights = Eigen::MatrixXd::Zero(joints, 2);
    weights(1, 0) = 1.0;
    weights(1, 1) = 0.6;
    weights(0, 1) = 0.4;
    probes_.SetJointWeights(weights);
    probes_.frames = {Eigen::Matrix3d::Identity(), Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()).toRotationMatrix()};
    probes_.rest_points.resize(3, 2 * kProximityProbes);
    const Eigen::Vector3d centre = body_.skeleton.rest_heads.col(1);
    for (int i = 0; i < 2 * kProximityProbes; ++i) {
      const double angle = 0.6 * i;
      const double radius = i == 3 ? 0.5 : 0.013 + 0.02 * i;  // one far off; none on the axis (a tie)
      probes_.rest_points.col(i) =
          centre + Eigen::Vector3d(radius * std::cos(angle), 0.05 + 0.01 * i, radius * std::sin(angle));
    }
  }

  SkinnedBody body_;
  PatchProbes probes_;
};

TEST_F(BodyProximityTest, DistancesAndNormalsAreTheNearestSamplesInThePatchesFrames) {
  const JointTransforms rest(body_.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  PosedBodySamples posed(body_);
  posed.Pose(rest);
  Eigen::MatrixXd features;
  BodyProximityFeatures(probes_, rest, posed, &features);
  ASSERT_EQ(features.rows(), kProximitySize);
  ASSERT_EQ(features.cols(), 2);
  int inside = 0, clamped = 0;
  for (int p = 0; p < 2; ++p) {
    for (int i = 0; i < kProximityProbes; ++i) {
      const SignedDistanceResult hit = posed.Query(probes_.rest_points.col(kProximityProbes * p + i));
      const double d = std::clamp(hit.distance / kProximityScale, -kProximityClamp, kProximityClamp);
      EXPECT_NEAR(features(4 * i, p), d, 1e-12);
      const Eigen::Vector3d normal = probes_.frames[p].transpose() * hit.normal;
      EXPECT_LT((features.col(p).segment<3>(4 * i + 1) - normal).norm(), 1e-12);
      inside += hit.distance < 0.0 ? 1 : 0;
      clamped += std::abs(d) == kProximityClamp ? 1 : 0;
    }
  }
  EXPECT_GT(inside, 0);  // the probes cover both sides and the clamp
  EXPECT_LT(inside, 2 * kProximityProbes);
  EXPECT_GT(clamped, 0);
}

// The samples are body vertices, posed as the body is, spread over all of
// it; near the body their tangent planes' distance is the exact one's to
// within the spacing's sag.
TEST_F(BodyProximityTest, TheSamplesCoverTheBodyAndApproximateItsDistance) {
  const double spacing = 0.05;  // the procedural body has few vertices
  PosedBodySamples samples(body_, spacing);
  EXPECT_GT(samples.num_samples(), 100);
  EXPECT_LT(samples.num_samples(), body_.mesh.num_vertices() / 2);
  JointTransforms pose(body_.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  const Eigen::Vector3d head = body_.skeleton.rest_heads.col(2);
  pose[2] = Eigen::Translation3d(head) * Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitZ()) * Eigen::Translation3d(-head);
  samples.Pose(pose);
  const Eigen::Matrix3Xd body = SkinVertices(body_, pose);
  const KdTree3 body_tree(body), sample_tree(samples.points());
  double d2 = 0.0;
  for (int s = 0; s < samples.num_samples(); ++s) {
    body_tree.Nearest(samples.points().col(s), &d2);
    EXPECT_LT(d2, 1e-20) << s;  // on a posed vertex
  }
  for (int v = 0; v < body.cols(); ++v) {
    sample_tree.Nearest(body.col(v), &d2);
    EXPECT_LT(std::sqrt(d2), 2.0 * spacing) << v;
  }
  BodySignedDistance exact(body_.mesh);
  exact.SetVertices(body);
  const Eigen::Matrix3Xd normals = VertexNormals(TriangleMesh{body, body_.mesh.faces, {}});
  int agree = 0, count = 0;
  double error = 0.0;
  for (int v = 0; v < body.cols(); v += 7) {
    for (const double offset : {-0.005, 0.005, 0.02}) {
      const Eigen::Vector3d p = body.col(v) + offset * normals.col(v);
      const double truth = exact.Query(p).distance, approx = samples.Query(p).distance;
      agree += (truth < 0.0) == (approx < 0.0) ? 1 : 0;
      error += std::abs(truth - approx);
      ++count;
    }
  }
  EXPECT_GT(agree, 0.85 * count);  // the plane misleads where capsules meet
  EXPECT_LT(error / count, 0.25 * spacing);
}

TEST_F(BodyProximityTest, ARigidMotionOfBodyAndGarmentTogetherChangesNothing) {
  const int joints = body_.skeleton.num_joints();
  JointTransforms pose(joints, Eigen::Isometry3d::Identity());
  const Eigen::Vector3d head = body_.skeleton.rest_heads.col(1);
  pose[1] = Eigen::Translation3d(head) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) * Eigen::Translation3d(-head);
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
  motion.linear() = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, 1.0, -0.2).normalized()).toRotationMatrix();
  motion.translation() = Eigen::Vector3d(0.4, -0.2, 1.5);
  JointTransforms moved = pose;
  for (auto& t : moved) t = motion * t;
  PosedBodySamples posed(body_);
  Eigen::MatrixXd a, b, still;
  posed.Pose(pose);
  BodyProximityFeatures(probes_, pose, posed, &a);
  posed.Pose(moved);
  BodyProximityFeatures(probes_, moved, posed, &b);
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9);
  // The torso bent under the garment does change them.
  const JointTransforms rest(joints, Eigen::Isometry3d::Identity());
  posed.Pose(rest);
  BodyProximityFeatures(probes_, rest, posed, &still);
  EXPECT_GT((a - still).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_TRUE(a.allFinite());
  EXPECT_THROW(BodyProximityFeatures(probes_, JointTransforms(1), posed, &a), std::invalid_argument);
  EXPECT_THROW(posed.Pose(JointTransforms(1)), std::invalid_argument);
}

// Hints carried from frame to frame (each probe's nearest sample) change
// no answer, through a motion and back (the procedural body's symmetric
// samples tie: either is an answer).
TEST_F(BodyProximityTest, HintsFromTheFrameBeforeGiveTheSameFeatures) {
  const int joints = body_.skeleton.num_joints();
  const Eigen::Vector3d head = body_.skeleton.rest_heads.col(1);
  PosedBodySamples posed(body_);
  std::vector<int> hints;
  for (const double angle : {0.0, 0.3, 0.6, 0.0}) {
    JointTransforms pose(joints, Eigen::Isometry3d::Identity());
    pose[1] =
        Eigen::Translation3d(head) * Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitX()) * Eigen::Translation3d(-head);
    posed.Pose(pose);
    Eigen::MatrixXd plain, hinted;
    BodyProximityFeatures(probes_, pose, posed, &plain);
    BodyProximityFeatures(probes_, pose, posed, &hinted, &hints);
    // Equal but for ties between samples at the same distance (an ulp).
    EXPECT_LT((plain - hinted).cwiseAbs().maxCoeff(), 1e-12) << "angle " << angle;
    ASSERT_EQ(hints.size(), static_cast<size_t>(probes_.rest_points.cols()));
    for (int h : hints) EXPECT_GE(h, 0);
  }
}

// The probes placed on patch parameters: on the rest parameters they are
// the rest probes; elsewhere they follow the jet, and the chain of the
// distances' derivatives back to alpha, s and T matches central
// differences (the nearest samples do not change over the steps).
TEST_F(BodyProximityTest, ProbesPlacedOnPatchParametersFollowThemAndChainTheDistances) {
  const int joints = body_.skeleton.num_joints();
  PolyFitModel model;
  for (int p = 0; p < 2; ++p) {
    JetPatch patch;
    patch.order = 2;
    patch.coefficients = {0.01, 0.02, -0.03, 0.2, -0.1, 0.15};
    patch.frame.rotation = Eigen::AngleAxisd(1.2 + p, Eigen::Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
    patch.frame.scale = 0.05 + 0.03 * p;
    patch.frame.translation = body_.skeleton.rest_heads.col(1) + Eigen::Vector3d(p == 0 ? 0.13 : -0.1, 0.05, 0.04);
    model.patches.push_back(patch);
  }
  Eigen::MatrixXd weights = Eigen::MatrixXd::Zero(joints, 2);
  weights(1, 0) = 1.0;
  weights(1, 1) = 0.7;
  weights(0, 1) = 0.3;
  const PatchProbes probes = MakePatchProbes(model, {0.01, 0.02}, weights);
  // DrapeSolver's layout with a warp of order 0 after T (ignored).
  const int k = 6, stride = k + 4 + 2;
  std::vector<double> rest(2 * stride, 0.0);
  for (int p = 0; p < 2; ++p) {
    const JetPatch& patch = model.patches[p];
    std::copy_n(patch.coefficients.begin(), k, rest.begin() + p * stride);
    rest[p * stride + k] = patch.frame.scale;
    for (int a = 0; a < 3; ++a) rest[p * stride + k + 1 + a] = patch.frame.translation[a];
    rest[p * stride + k + 4] = 0.3;  // a warp moves no probe
  }
  Eigen::Matrix3Xd points;
  PlaceProbes(probes, rest, 2, stride, &points);
  EXPECT_LT((points - probes.rest_points).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_THROW(PlaceProbes(probes, rest, 3, stride, &points), std::invalid_argument);  // 10 coefficients: too many

  // Moved parameters, a posed body.
  std::vector<double> moved = rest;
  for (size_t i = 0; i < moved.size(); ++i) moved[i] += 0.004 * std::sin(1.7 * i + 0.3);
  JointTransforms pose(joints, Eigen::Isometry3d::Identity());
  pose[1].linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  pose[1].translation() = Eigen::Vector3d(0.01, 0.0, -0.02);
  PosedBodySamples posed(body_);
  posed.Pose(pose);
  const auto features_at = [&](const std::vector<double>& parameters, Eigen::Matrix3Xd* gradients) {
    Eigen::Matrix3Xd at;
    PlaceProbes(probes, parameters, 2, stride, &at);
    Eigen::MatrixXd features;
    BodyProximityFeatures(probes, at, pose, posed, &features, gradients);
    return features;
  };
  Eigen::Matrix3Xd gradients;
  const Eigen::MatrixXd features = features_at(moved, &gradients);
  int unclamped = 0;
  for (int i = 0; i < 2 * kProximityProbes; ++i) unclamped += gradients.col(i).norm() > 0.0 ? 1 : 0;
  EXPECT_GE(unclamped, 4);
  // L = sum of c * features over the distances' rows.
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(kProximitySize, 2);
  for (int p = 0; p < 2; ++p) {
    for (int i = 0; i < kProximityProbes; ++i) c(4 * i, p) = std::cos(0.9 * i + p);
  }
  std::vector<double> gradient(moved.size(), 0.0);
  ChainProbesToPatchParameters(probes, moved, 2, stride, gradients, c, &gradient);
  const double h = 1e-7;
  for (size_t i = 0; i < moved.size(); ++i) {
    std::vector<double> plus = moved, minus = moved;
    plus[i] += h;
    minus[i] -= h;
    const double numeric = ((c.array() * features_at(plus, nullptr).array()).sum() -
                            (c.array() * features_at(minus, nullptr).array()).sum()) /
                           (2.0 * h);
    EXPECT_NEAR(gradient[i], numeric, 1e-5 * std::abs(numeric) + 1e-6) << i;
  }
}

}  // namespace
}  // namespace polyfit
