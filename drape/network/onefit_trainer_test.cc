#include "drape/network/onefit_trainer.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"
#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

SkinWeights RigidWeights(int n, int joint) {
  SkinWeights weights;
  for (int v = 0; v < n; ++v) {
    weights.joint.push_back(joint);
    weights.value.push_back(1.0);
    weights.offsets.push_back(v + 1);
  }
  return weights;
}

// The procedural body bobbing up and down and turning a little: every
// joint moved alike.
OneFitTrainingClip Bob(const SkinnedBody& body, int frames) {
  OneFitTrainingClip clip;
  clip.name = "bob";
  for (int t = 0; t < frames; ++t) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0.0, 0.03 * std::sin(0.8 * t), 0.0);
    pose.linear() = Eigen::AngleAxisd(0.05 * std::sin(0.5 * t), Eigen::Vector3d::UnitY()).toRotationMatrix();
    clip.poses.emplace_back(body.skeleton.num_joints(), pose);
  }
  return clip;
}

class OneFitTrainerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    body_ = MakeProceduralBody();
    // A shirt just around the torso (radius 0.14 m): collisions matter.
    OneFitTrainingGarment shirt{"shirt", MakeTube(0.145, 0.1, 0.4, 20, 6), {}};
    shirt.weights = RigidWeights(shirt.mesh.num_vertices(), 1);
    options_.drape.patching.vertices_per_patch = 30;
    options_.network.patch_hidden = {16};
    options_.network.patch_embedding = 8;
    options_.network.body_hidden = {16};
    options_.network.body_embedding = 8;
    options_.network.decoder_hidden = {16, 16};
    options_.batch_size = 4;
    options_.iterations_per_batch = 5;
    options_.num_batches = 6;
    trainer_ = std::make_unique<OneFitTrainer>(body_, std::vector<OneFitTrainingGarment>{shirt},
                                               std::vector<OneFitTrainingClip>{Bob(body_, 8)}, options_);
  }

  SkinnedBody body_;
  OneFitTrainerOptions options_;
  std::unique_ptr<OneFitTrainer> trainer_;
};

TEST_F(OneFitTrainerTest, ANewNetworkPredictsAboutTheRestPatches) {
  std::vector<double> weights = trainer_->InitialWeights();
  const std::vector<double> predicted = trainer_->Predict(weights.data(), 0, 0, 3);
  std::fill(weights.begin(), weights.end(), 0.0);  // zero output: exactly the rest patches
  const std::vector<double> rest = trainer_->Predict(weights.data(), 0, 0, 3);
  ASSERT_EQ(predicted.size(), rest.size());
  double largest = 0.0;
  for (size_t i = 0; i < rest.size(); ++i) largest = std::max(largest, std::abs(predicted[i] - rest[i]));
  EXPECT_LT(largest, 0.05);
  EXPECT_GT(largest, 0.0);
}

TEST_F(OneFitTrainerTest, TheLossGradientMatchesCentralDifferences) {
  std::vector<double> weights = trainer_->InitialWeights();
  std::mt19937_64 rng(4);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (double& w : weights) w += normal(rng);  // away from the start's symmetries
  const std::vector<OneFitSample> samples = {{0, 0, 2}, {0, 0, 5}};
  std::vector<double> gradient(trainer_->num_parameters());
  const double loss = trainer_->Loss(weights.data(), samples, gradient.data());
  EXPECT_TRUE(std::isfinite(loss));
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<double> direction(weights.size()), plus = weights, minus = weights;
    double slope = 0.0;
    const double h = 1e-6;
    for (size_t i = 0; i < weights.size(); ++i) {
      direction[i] = normal(rng);
      plus[i] += h * direction[i];
      minus[i] -= h * direction[i];
      slope += gradient[i] * direction[i];
    }
    const double numeric =
        (trainer_->Loss(plus.data(), samples, nullptr) - trainer_->Loss(minus.data(), samples, nullptr)) / (2.0 * h);
    EXPECT_NEAR(numeric, slope, 1e-4 * std::abs(slope) + 1e-8) << "trial " << trial;
  }
}

TEST_F(OneFitTrainerTest, TrainingLowersTheLossDeterministically) {
  std::vector<double> weights = trainer_->InitialWeights();
  const std::vector<OneFitSample> all = {{0, 0, 0}, {0, 0, 1}, {0, 0, 2}, {0, 0, 3},
                                         {0, 0, 4}, {0, 0, 5}, {0, 0, 6}, {0, 0, 7}};
  const double before = trainer_->Loss(weights.data(), all, nullptr);
  const OneFitTrainingSummary summary = trainer_->Train(&weights);
  ASSERT_TRUE(summary.termination_type != TerminationType::kFailure) << summary.BriefReport();
  const double after = trainer_->Loss(weights.data(), all, nullptr);
  EXPECT_LT(after, 0.8 * before) << summary.BriefReport();
  // The same seed, the same weights.
  std::vector<double> again = trainer_->InitialWeights();
  trainer_->Train(&again);
  EXPECT_EQ(again, weights);
}

TEST(OneFitNetworkTest, OutputsMapToPatchParametersAndBack) {
  const int k = 3, patches = 2;
  const std::vector<double> rest = {0.1, 0.2, 0.3, 0.05, 1.0, 2.0, 3.0, -0.1, 0.0, 0.2, 0.08, -1.0, 0.5, 0.0};
  const std::vector<Eigen::Matrix3d> frames = {
      Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix(),
      Eigen::AngleAxisd(-0.7, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix()};
  Eigen::MatrixXd outputs = Eigen::MatrixXd::Zero(k + 4, patches);
  EXPECT_EQ(PatchParametersFromOutputs(rest, frames, outputs), rest);
  outputs.setRandom();
  outputs *= 0.1;
  // L = sum_i c_i params_i: its gradient in outputs against central differences.
  std::vector<double> c(rest.size());
  for (size_t i = 0; i < c.size(); ++i) c[i] = std::cos(1.0 + i);
  const Eigen::MatrixXd d = ChainPatchParameterGradient(rest, frames, outputs, c);
  const auto loss = [&](const Eigen::MatrixXd& y) {
    const std::vector<double> p = PatchParametersFromOutputs(rest, frames, y);
    double l = 0.0;
    for (size_t i = 0; i < p.size(); ++i) l += c[i] * p[i];
    return l;
  };
  for (Eigen::Index i = 0; i < outputs.size(); ++i) {
    Eigen::MatrixXd plus = outputs, minus = outputs;
    plus.data()[i] += 1e-6;
    minus.data()[i] -= 1e-6;
    EXPECT_NEAR(d.data()[i], (loss(plus) - loss(minus)) / 2e-6, 1e-8) << i;
  }
}

}  // namespace
}  // namespace polyfit
