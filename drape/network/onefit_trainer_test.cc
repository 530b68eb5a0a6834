#include "drape/network/onefit_trainer.h"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <mutex>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"
#include "drape/network/onefit_draper.h"
#include "polyfit/jet/jet_surface.h"
#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

// A file's bytes.
std::string FileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
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

// A tube shirt (radius 0.145 m) skinned rigidly to joint 1, the torso.
OneFitTrainingGarment TubeShirt() {
  OneFitTrainingGarment shirt{"shirt", MakeTube(0.145, 0.1, 0.4, 20, 6), {}};
  shirt.weights = SingleJointWeights(shirt.mesh.num_vertices(), 1);
  return shirt;
}

class OneFitTrainerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    body_ = MakeProceduralBody();
    // A shirt just around the torso (radius 0.14 m): collisions matter.
    OneFitTrainingGarment shirt = TubeShirt();
    options_.drape.patching.patch_area = 0.09;
    options_.network.patch_hidden = {16};
    options_.network.patch_embedding = 8;
    options_.network.body_hidden = {16};
    options_.network.body_embedding = 8;
    options_.network.decoder_hidden = {24, 24};
    // A warp head, so that the gradient checks cover the slides too.
    options_.network.warp_order = 1;
    options_.drape.slide.warp_order = 1;
    options_.optimizer = OneFitOptimizer::kLbfgs;  // the Ceres path; Adam has its own test
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
  OneFitTrainingGarment shirt{"shirt", MakeTube(0.145, 0.1, 0.4, 20, 6), {}};
  DrapeSolver solver(body_, shirt.mesh, SingleJointWeights(shirt.mesh.num_vertices(), 1), options_.drape);
  EXPECT_EQ(rest, solver.RestPatchParameters());
  // Within a few millimetres of the rest garment, but not on it.
  const double moved = (solver.PositionsOf(predicted) - solver.PositionsOf(rest)).colwise().norm().maxCoeff();
  EXPECT_LT(moved, 0.008);
  EXPECT_GT(moved, 0.0);
}

// The trainer's loss gradient against central differences along random
// directions, at weights moved away from the start's symmetries. With
// hold_history, of the loss with the frames before predicted by the
// unmoved weights (LossWithHistory): the loss the gradient is exactly of.
void ExpectGradientMatchesCentralDifferences(OneFitTrainer* trainer, int trials, bool hold_history = false) {
  std::vector<double> weights = trainer->InitialWeights();
  std::mt19937_64 rng(4);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (double& w : weights) w += normal(rng);
  const std::vector<OneFitSample> samples = {{0, 0, 2}, {0, 0, 5}};
  std::vector<double> gradient(trainer->num_parameters());
  const double loss = trainer->Loss(weights.data(), samples, gradient.data());
  EXPECT_TRUE(std::isfinite(loss));
  for (int trial = 0; trial < trials; ++trial) {
    std::vector<double> direction(weights.size()), plus = weights, minus = weights;
    double slope = 0.0;
    const double h = 1e-6;
    for (size_t i = 0; i < weights.size(); ++i) {
      direction[i] = normal(rng);
      plus[i] += h * direction[i];
      minus[i] -= h * direction[i];
      slope += gradient[i] * direction[i];
    }
    const double* history_plus = hold_history ? weights.data() : plus.data();
    const double* history_minus = hold_history ? weights.data() : minus.data();
    const double numeric = (trainer->LossWithHistory(plus.data(), history_plus, samples, nullptr) -
                            trainer->LossWithHistory(minus.data(), history_minus, samples, nullptr)) /
                           (2.0 * h);
    EXPECT_NEAR(numeric, slope, (hold_history ? 1e-5 : 1e-4) * std::abs(slope) + 1e-8) << "trial " << trial;
  }
  EXPECT_NEAR(trainer->LossWithHistory(weights.data(), weights.data(), samples, nullptr), loss, 1e-12 * loss);
}

// The gradient holds the frames before as data: it is the derivative of
// the loss with their weights fixed.
TEST_F(OneFitTrainerTest, TheGradientIsTheLossWithItsHistoryHeld) {
  ExpectGradientMatchesCentralDifferences(trainer_.get(), 2, true);
}

TEST_F(OneFitTrainerTest, TheLossGradientMatchesCentralDifferences) {
  ExpectGradientMatchesCentralDifferences(trainer_.get(), 3);
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

// Two body shapes: a second, thicker torso (the shirt's rest drape
// collides more with it) whose clips carry its shape values.
// The polish's blocks against their definition: per sample, (dp/dTheta)^T
// (J_p^T J_p) (dp/dTheta) with J_p^T J_p from a drape posed as the trainer
// poses it and dp/dTheta by central differences of the network's
// prediction; the gradient is the loss gradient's output-layer part.
TEST_F(OneFitTrainerTest, TheOutputLayersGaussNewtonBlocksChainTheDrapes) {
  std::vector<double> weights = trainer_->InitialWeights();
  std::mt19937_64 rng(6);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (double& w : weights) w += normal(rng);
  const std::vector<OneFitSample> samples = {{0, 0, 2}, {0, 0, 5}};
  Eigen::MatrixXd blocks;
  Eigen::VectorXd gradient;
  const double loss = trainer_->OutputLayerGaussNewton(weights.data(), samples, &blocks, &gradient);
  std::vector<double> full(trainer_->num_parameters());
  EXPECT_NEAR(trainer_->Loss(weights.data(), samples, full.data()), loss, 1e-12 * loss);
  const int offset = trainer_->output_layer_offset(), t = trainer_->num_output_layer_parameters();
  EXPECT_EQ(t, trainer_->network().decoder().num_parameters() - trainer_->network().decoder().weight_offset(2));
  ASSERT_EQ(blocks.rows(), t);
  for (int i = 0; i < t; ++i) EXPECT_NEAR(gradient[i], full[offset + i], 1e-9 * (1.0 + std::abs(full[offset + i])));

  const OneFitTrainingClip clip = Bob(body_, 8);
  const TriangleMesh mesh = MakeTube(0.145, 0.1, 0.4, 20, 6);
  DrapeSolverOptions drape = options_.drape;
  drape.num_threads = 1;
  DrapeSolver solver(body_, mesh, SingleJointWeights(mesh.num_vertices(), 1), drape);
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(t, t);
  for (const OneFitSample& sample : samples) {
    Eigen::Matrix3Xd history[2];
    for (int back = 1; back <= 2; ++back) {
      const int f = std::max(sample.frame - back, 0);
      history[back - 1] = solver.PositionsAt(trainer_->Predict(weights.data(), 0, 0, f), clip.poses[f]);
    }
    solver.SetHistory(history[0], history[1]);
    solver.Pose(clip.poses[sample.frame]);
    const std::vector<double> params = trainer_->Predict(weights.data(), 0, 0, sample.frame);
    Eigen::MatrixXd h_p;
    std::vector<double> unused;
    solver.EvaluateGaussNewton(params, &unused, &h_p);
    Eigen::MatrixXd dp(params.size(), t);
    const double h = 1e-6;
    for (int i = 0; i < t; ++i) {
      std::vector<double> plus = weights, minus = weights;
      plus[offset + i] += h;
      minus[offset + i] -= h;
      const std::vector<double> p_plus = trainer_->Predict(plus.data(), 0, 0, sample.frame);
      const std::vector<double> p_minus = trainer_->Predict(minus.data(), 0, 0, sample.frame);
      for (size_t r = 0; r < params.size(); ++r) dp(r, i) = (p_plus[r] - p_minus[r]) / (2.0 * h);
    }
    expected += dp.transpose() * h_p * dp / static_cast<double>(samples.size());
  }
  EXPECT_LT((blocks - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
}

TEST_F(OneFitTrainerTest, ThePolishLowersTheLossChangingOnlyTheOutputLayer) {
  OneFitTrainerOptions options = options_;
  options.polish.iterations = 4;
  options.polish.samples = 6;
  options.validation_frames = 4;
  OneFitTrainer trainer(body_, {{"shirt", MakeTube(0.145, 0.1, 0.4, 20, 6), SingleJointWeights(20 * 7, 1)}},
                        {Bob(body_, 8)}, options);
  std::vector<double> weights = trainer.InitialWeights();
  trainer.Train(&weights);
  const std::vector<double> trained = weights;
  const OneFitPolishSummary summary = trainer.PolishOutputLayer(&weights);
  ASSERT_EQ(summary.steps.size(), 4u);
  EXPECT_LT(summary.final_loss, 0.9 * summary.initial_loss) << summary.BriefReport();
  EXPECT_TRUE(std::any_of(summary.steps.begin(), summary.steps.end(),
                          [](const OneFitPolishStep& step) { return step.accepted; }));
  EXPECT_TRUE(std::isfinite(summary.final_loss));
  const int offset = trainer.output_layer_offset(), t = trainer.num_output_layer_parameters();
  EXPECT_EQ(offset + t, trainer.num_parameters());  // the last layer is the weights' tail
  for (int i = 0; i < offset; ++i) ASSERT_EQ(weights[i], trained[i]) << i;
  EXPECT_NE(weights, trained);
  EXPECT_TRUE(std::isfinite(summary.validation_loss_after));
  // Deterministic.
  std::vector<double> again = trained;
  trainer.PolishOutputLayer(&again);
  EXPECT_EQ(again, weights);
}

TEST_F(OneFitTrainerTest, SeveralBodiesPairTheirOwnGarmentsAndClipsAndTheShapeIsRead) {
  OneFitTrainingGarment shirt = TubeShirt();
  std::vector<OneFitTrainingBody> bodies(2);
  bodies[0] = {body_, {shirt}, {Bob(body_, 8)}};
  bodies[1] = bodies[0];
  bodies[1].body.mesh.vertices.row(0) *= 1.04;  // about the spine (x = z = 0)
  bodies[1].body.mesh.vertices.row(2) *= 1.04;
  for (OneFitTrainingClip& clip : bodies[1].clips) clip.shape.weight = 0.8;
  OneFitTrainer trainer(bodies, options_);
  std::vector<double> weights(trainer.num_parameters(), 0.0);  // the rest patches, skinned
  EXPECT_THROW(trainer.Predict(weights.data(), 0, 1, 2), std::invalid_argument);
  EXPECT_EQ(trainer.Predict(weights.data(), 1, 1, 2), trainer.Predict(weights.data(), 0, 0, 2));
  // Each garment's drape is its own body's: the same shirt costs more
  // around the thicker torso.
  const double thin = trainer.Loss(weights.data(), {{0, 0, 3}}, nullptr);
  const double thick = trainer.Loss(weights.data(), {{1, 1, 3}}, nullptr);
  EXPECT_GT(thick, 1.5 * thin);
  EXPECT_NEAR(thin, trainer_->Loss(weights.data(), {{0, 0, 3}}, nullptr), 1e-9 * thin);
  // The shape's weight value varies over training, so the network reads
  // it; the values that stay put are ignored.
  const Eigen::VectorXd& inv_std = trainer.MakeModel(weights).body_normalizer.inv_std;
  const Eigen::Index shape = inv_std.size() - 5;
  EXPECT_EQ(inv_std[shape], 0.0);                     // gender
  EXPECT_NEAR(inv_std[shape + 2], 1.0 / 0.15, 1e-9);  // weight: 0.5 and 0.8, spread 0.15
  EXPECT_EQ(trainer_->MakeModel(weights).body_normalizer.inv_std[shape + 2], 0.0);
  // Training draws pairs of one body only (Predict would throw otherwise).
  weights = trainer.InitialWeights();
  const OneFitTrainingSummary summary = trainer.Train(&weights);
  EXPECT_NE(summary.termination_type, TerminationType::kFailure) << summary.BriefReport();
  // Bodies of another rig are refused.
  bodies[1].body.skeleton = Skeleton{};
  EXPECT_THROW(OneFitTrainer(bodies, options_), std::invalid_argument);
}

TEST(ValidationFrameTest, SpreadsTheFramesEvenlyThroughTheClip) {
  EXPECT_EQ(ValidationFrame(0, 3, 90), 15);
  EXPECT_EQ(ValidationFrame(1, 3, 90), 45);
  EXPECT_EQ(ValidationFrame(2, 3, 90), 75);
  for (int i = 0; i < 30; ++i) EXPECT_EQ(ValidationFrame(i, 30, 30), i);  // every frame once
  EXPECT_EQ(ValidationFrame(0, 1, 7), 3);
}

TEST_F(OneFitTrainerTest, TheValidationDrapeMeasuresTheNetworksGarment) {
  std::vector<double> weights(trainer_->num_parameters(), 0.0);  // the rest garment, skinned
  double inside = -1.0, strain = -1.0;
  trainer_->ValidationDrape(weights.data(), 0, 0, 4, &inside, &strain);
  // The shirt (radius 0.145) around the torso (0.14), moved rigidly with it.
  EXPECT_GE(inside, 0.0);
  EXPECT_LT(inside, 50.0);
  EXPECT_NEAR(strain, 0.0, 1e-6);  // rigid skinning stretches nothing
}

// The collision curriculum: k_c held, ramped and held again over the
// batches; the loss is affine in k_c, validation weighs collisions at the
// loss's own whatever the batch's, and training ends at the loss's own.
TEST_F(OneFitTrainerTest, ACollisionCurriculumRaisesTheWeightAndValidatesAtTheLossesOwn) {
  OneFitTrainerOptions options = options_;
  const double final_weight = options.drape.physics.weights.collision;
  options.collision_start = 0.25 * final_weight;
  options.collision_ramp = {0.25, 0.75};
  options.num_batches = 8;
  options.validation_every = 0;
  OneFitTrainer trainer(body_, {TubeShirt()}, {Bob(body_, 8)}, options);
  EXPECT_DOUBLE_EQ(trainer.CollisionWeightAt(0), 0.25 * final_weight);
  EXPECT_DOUBLE_EQ(trainer.CollisionWeightAt(2), 0.25 * final_weight);  // the ramp starts at a quarter
  EXPECT_DOUBLE_EQ(trainer.CollisionWeightAt(4), 0.625 * final_weight);
  EXPECT_DOUBLE_EQ(trainer.CollisionWeightAt(6), final_weight);
  EXPECT_DOUBLE_EQ(trainer.CollisionWeightAt(7), final_weight);
  EXPECT_DOUBLE_EQ(trainer_->CollisionWeightAt(0), final_weight);  // no curriculum

  std::vector<double> weights = trainer.InitialWeights();
  const std::vector<OneFitSample> samples = {{0, 0, 2}, {0, 0, 5}};
  const auto loss_at = [&](double k_c) {
    trainer.SetCollisionWeight(k_c);
    return trainer.Loss(weights.data(), samples, nullptr);
  };
  const double gentle = loss_at(0.25 * final_weight), stiff = loss_at(final_weight),
               between = loss_at(0.625 * final_weight);
  ASSERT_GT(stiff, gentle);  // the shirt touches the torso: collisions count
  EXPECT_NEAR(between, 0.5 * (gentle + stiff), 1e-9 * stiff);

  double inside = 0.0, strain = 0.0, validated_gentle = 0.0, validated_stiff = 0.0;
  trainer.SetCollisionWeight(final_weight);
  trainer.ValidationDrape(weights.data(), 0, 0, 4, &inside, &strain, &validated_stiff);
  trainer.SetCollisionWeight(0.25 * final_weight);
  trainer.ValidationDrape(weights.data(), 0, 0, 4, &inside, &strain, &validated_gentle);
  EXPECT_DOUBLE_EQ(validated_gentle, validated_stiff);
  EXPECT_DOUBLE_EQ(trainer.Loss(weights.data(), samples, nullptr), gentle);  // the batch's weight is back

  const OneFitTrainingSummary summary = trainer.Train(&weights);
  ASSERT_TRUE(summary.termination_type != TerminationType::kFailure) << summary.BriefReport();
  OneFitTrainer plain(body_, {TubeShirt()}, {Bob(body_, 8)}, options_);
  EXPECT_NEAR(trainer.Loss(weights.data(), samples, nullptr), plain.Loss(weights.data(), samples, nullptr),
              1e-12 * stiff);
}

TEST_F(OneFitTrainerTest, AdamLowersTheLossToo) {
  OneFitTrainingGarment shirt = TubeShirt();
  OneFitTrainerOptions options = options_;
  options.optimizer = OneFitOptimizer::kAdam;
  options.learning_rate = 1e-4;
  OneFitTrainer adam(body_, {shirt}, {Bob(body_, 8)}, options);
  std::vector<double> weights = adam.InitialWeights();
  const std::vector<OneFitSample> all = {{0, 0, 0}, {0, 0, 1}, {0, 0, 2}, {0, 0, 3},
                                         {0, 0, 4}, {0, 0, 5}, {0, 0, 6}, {0, 0, 7}};
  const double before = adam.Loss(weights.data(), all, nullptr);
  const OneFitTrainingSummary summary = adam.Train(&weights);
  ASSERT_NE(summary.termination_type, TerminationType::kFailure) << summary.BriefReport();
  EXPECT_LT(adam.Loss(weights.data(), all, nullptr), 0.9 * before) << summary.BriefReport();

  // A warm-up over 4 batches of one step: Adam's first step (m / sqrt(v)
  // is +-1 per weight) moves each weight by the rate over 4.
  options.iterations_per_batch = 1;
  options.num_batches = 1;
  options.warmup_batches = 4;
  OneFitTrainer warm(body_, {shirt}, {Bob(body_, 8)}, options);
  const std::vector<double> start = warm.InitialWeights();
  std::vector<double> stepped = start;
  warm.Train(&stepped);
  double largest = 0.0;
  for (size_t i = 0; i < start.size(); ++i) largest = std::max(largest, std::abs(stepped[i] - start[i]));
  EXPECT_NEAR(largest, options.learning_rate / 4.0, 1e-3 * options.learning_rate);
}

// AdamW's decay: one step with it lands where the step without it lands
// less rate * lambda * w on the layers' matrices, and on the biases alike.
TEST_F(OneFitTrainerTest, WeightDecayShrinksTheMatricesButNotTheBiases) {
  OneFitTrainerOptions options = options_;
  options.optimizer = OneFitOptimizer::kAdam;
  options.learning_rate = 1e-5;  // a step too small to be undone as a spike
  options.final_rate_fraction = 1.0;
  options.iterations_per_batch = 1;
  options.num_batches = 1;
  OneFitTrainingGarment shirt = TubeShirt();
  OneFitTrainer plain(body_, {shirt}, {Bob(body_, 8)}, options);
  options.weight_decay = 10.0;
  OneFitTrainer decaying(body_, {shirt}, {Bob(body_, 8)}, options);
  const std::vector<double> start = plain.InitialWeights();
  std::vector<double> a = start, b = start;
  ASSERT_EQ(plain.Train(&a).undone_batches, 0);
  ASSERT_EQ(decaying.Train(&b).undone_batches, 0);
  ASSERT_NE(a, start);

  std::vector<char> in_matrix(start.size(), 0);
  const auto ranges = plain.network().WeightMatrixRanges();
  for (const auto& [offset, size] : ranges) std::fill(in_matrix.begin() + offset, in_matrix.begin() + offset + size, 1);
  const int num_matrix = static_cast<int>(std::count(in_matrix.begin(), in_matrix.end(), 1));
  EXPECT_GT(num_matrix, 0);
  EXPECT_LT(num_matrix, static_cast<int>(start.size()));  // the biases are left out
  double worst = 0.0;
  for (size_t i = 0; i < start.size(); ++i) {
    const double expected = in_matrix[i] ? a[i] - options.learning_rate * options.weight_decay * start[i] : a[i];
    worst = std::max(worst, std::abs(b[i] - expected));
  }
  EXPECT_LT(worst, 1e-12);

  options.optimizer = OneFitOptimizer::kLbfgs;
  EXPECT_NE(options.Validate().find("weight_decay"), std::string::npos);
  options.optimizer = OneFitOptimizer::kAdam;
  options.weight_decay = -1.0;
  EXPECT_NE(options.Validate().find("weight_decay"), std::string::npos);
}

// A batch whose loss grows over kSpikeRatio-fold is undone: the weights
// after it are those before it, and Adam's moments too (the batch after it
// steps as if it had not happened).
TEST_F(OneFitTrainerTest, ABatchWhoseLossExplodesIsUndone) {
  OneFitTrainingGarment shirt = TubeShirt();
  OneFitTrainerOptions options = options_;
  options.optimizer = OneFitOptimizer::kAdam;
  options.learning_rate = 1.0;  // every output thrown to its bound within a batch
  options.final_rate_fraction = 1.0;
  options.num_batches = 4;
  OneFitTrainer trainer(body_, {shirt}, {Bob(body_, 8)}, options);
  std::vector<double> weights = trainer.InitialWeights();
  std::vector<std::vector<double>> after;  // the weights after each batch
  OneFitAdamState adam;
  const OneFitTrainingSummary summary = trainer.Train(
      &weights, 0,
      [&](const OneFitBatchSummary&, const std::vector<double>& w, const std::vector<double>&) { after.push_back(w); },
      &adam);
  ASSERT_EQ(summary.batches.size(), 4u);
  ASSERT_GT(summary.undone_batches, 0) << summary.BriefReport();
  const std::vector<double> initial = trainer.InitialWeights();
  int undone = 0;
  for (size_t b = 0; b < summary.batches.size(); ++b) {
    const OneFitBatchSummary& record = summary.batches[b];
    EXPECT_EQ(record.undone, record.final_loss > kSpikeRatio * record.initial_loss) << "batch " << b;
    if (!record.undone) continue;
    ++undone;
    EXPECT_EQ(after[b], b == 0 ? initial : after[b - 1]) << "batch " << b;
  }
  EXPECT_EQ(undone, summary.undone_batches);
  EXPECT_NE(summary.BriefReport().find("undone"), std::string::npos);
  // Adam's step count covers only the batches kept.
  EXPECT_EQ(adam.steps, options.iterations_per_batch * (4 - undone));

  // Warp heads above order 2 diverge in training: refused, with the reason.
  options.network.warp_order = options.drape.slide.warp_order = kMaxTrainedWarpOrder + 1;
  EXPECT_NE(options.Validate().find("does not train"), std::string::npos) << options.Validate();
  // With a bound on the slides themselves they train (at most order 4).
  options.warp_slide_bound = 1.0;
  EXPECT_EQ(options.Validate(), "");
  options.warp_slide_bound = 1.5;
  EXPECT_NE(options.Validate().find("warp_slide_bound"), std::string::npos);
}

// The step size's schedule: linear warm-up, then constant or a cosine down
// to the final fraction at the last batch's last step.
TEST(AdamStepSizeTest, WarmsUpThenDecaysAlongACosine) {
  OneFitTrainerOptions options;
  options.learning_rate = 2e-4;
  options.final_rate_fraction = 1.0;  // constant
  options.warmup_batches = 2;
  options.iterations_per_batch = 5;
  options.num_batches = 10;  // 50 steps, 10 of them warm-up
  EXPECT_DOUBLE_EQ(AdamStepSize(options, 5), 1e-4);
  EXPECT_DOUBLE_EQ(AdamStepSize(options, 10), 2e-4);
  EXPECT_DOUBLE_EQ(AdamStepSize(options, 50), 2e-4);
  options.final_rate_fraction = 0.1;
  EXPECT_TRUE(options.Validate().empty()) << options.Validate();
  EXPECT_DOUBLE_EQ(AdamStepSize(options, 5), 1e-4);
  EXPECT_DOUBLE_EQ(AdamStepSize(options, 10), 2e-4);
  EXPECT_NEAR(AdamStepSize(options, 30), 2e-4 * (0.1 + 0.9 * 0.5), 1e-18);
  EXPECT_NEAR(AdamStepSize(options, 50), 2e-5, 1e-18);
  EXPECT_NEAR(AdamStepSize(options, 80), 2e-5, 1e-18);  // a run extended past its budget
  options.final_rate_fraction = 0.0;
  EXPECT_FALSE(options.Validate().empty());
}

// Processes simulated by threads: MPI_Allreduce's sum, met at a barrier.
class InMemoryAllReduce {
 public:
  explicit InMemoryAllReduce(int participants) : participants_(participants) {}

  void operator()(double* values, int count) {
    std::unique_lock<std::mutex> lock(mutex_);
    const long long round = round_;
    if (arrived_ == 0) {
      sum_.assign(values, values + count);
    } else {
      for (int i = 0; i < count; ++i) sum_[i] += values[i];
    }
    if (++arrived_ == participants_) {
      arrived_ = 0;
      result_ = sum_;
      ++round_;
      done_.notify_all();
    } else {
      done_.wait(lock, [&] { return round_ != round; });
    }
    std::copy(result_.begin(), result_.end(), values);
  }

 private:
  int participants_;
  std::mutex mutex_;
  std::condition_variable done_;
  int arrived_ = 0;
  long long round_ = 0;
  std::vector<double> sum_, result_;
};

TEST_F(OneFitTrainerTest, TwoProcessesSharingEachBatchTakeTheSameSteps) {
  OneFitTrainingGarment shirt = TubeShirt();
  OneFitTrainerOptions options = options_;
  options.optimizer = OneFitOptimizer::kAdam;
  options.num_batches = 3;
  options.validation_every = 2;
  OneFitTrainer alone(body_, {shirt}, {Bob(body_, 8)}, options);
  const std::vector<double> start = alone.InitialWeights();
  const std::vector<OneFitSample> samples = {{0, 0, 1}, {0, 0, 4}, {0, 0, 6}};  // odd: uneven shares
  std::vector<double> gradient(start.size());
  const double loss = alone.Loss(start.data(), samples, gradient.data());
  std::vector<double> trained = start;
  const OneFitTrainingSummary summary = alone.Train(&trained);

  InMemoryAllReduce reduce(2);
  std::vector<double> shared_gradient[2], shared_trained[2];
  double shared_loss[2];
  OneFitTrainingSummary shared_summary[2];
  std::vector<std::thread> processes;
  for (int p = 0; p < 2; ++p) {
    processes.emplace_back([&, p] {
      OneFitTrainerOptions o = options;
      o.distribution = {p, 2, [&reduce](double* values, int count) { reduce(values, count); }};
      OneFitTrainer trainer(body_, {shirt}, {Bob(body_, 8)}, o);
      shared_gradient[p].resize(start.size());
      shared_loss[p] = trainer.Loss(start.data(), samples, shared_gradient[p].data());
      shared_trained[p] = start;
      shared_summary[p] = trainer.Train(&shared_trained[p]);
    });
  }
  for (std::thread& t : processes) t.join();
  for (int p = 0; p < 2; ++p) {
    EXPECT_NEAR(shared_loss[p], loss, 1e-12 * loss);
    double largest = 0.0, scale = 0.0;
    for (size_t i = 0; i < start.size(); ++i) {
      largest = std::max(largest, std::abs(shared_gradient[p][i] - gradient[i]));
      scale = std::max(scale, std::abs(gradient[i]));
    }
    EXPECT_LT(largest, 1e-12 * scale);
    // The same steps: every process ends with the weights of one process.
    largest = 0.0;
    for (size_t i = 0; i < start.size(); ++i) largest = std::max(largest, std::abs(shared_trained[p][i] - trained[i]));
    EXPECT_LT(largest, 1e-10);
    EXPECT_NEAR(shared_summary[p].batches.back().final_loss, summary.batches.back().final_loss,
                1e-10 * summary.batches.back().final_loss);
  }
  EXPECT_EQ(shared_trained[0], shared_trained[1]);  // bit for bit: the same reduced numbers
  // The validation drape runs on process 0 only.
  EXPECT_TRUE(std::isfinite(shared_summary[0].batches[1].validation_inside_percent));
  EXPECT_TRUE(std::isnan(shared_summary[1].batches[1].validation_inside_percent));
}

TEST_F(OneFitTrainerTest, AResumedRunEndsWhereAStraightRunEnds) {
  std::vector<double> straight = trainer_->InitialWeights(), checkpoint;
  trainer_->Train(&straight, 0,
                  [&](const OneFitBatchSummary& b, const std::vector<double>& w, const std::vector<double>&) {
                    if (b.batch == 2) checkpoint = w;  // killed after batch 2
                  });
  ASSERT_FALSE(checkpoint.empty());
  std::vector<double> resumed = checkpoint;
  const OneFitTrainingSummary summary = trainer_->Train(&resumed, 3);
  ASSERT_EQ(summary.batches.size(), static_cast<size_t>(options_.num_batches - 3));
  EXPECT_EQ(summary.batches.front().batch, 3);
  EXPECT_EQ(resumed, straight);
}

TEST_F(OneFitTrainerTest, AFineTuneStartsFromTheModelsNetworkAndNormalizers) {
  std::vector<double> weights = trainer_->InitialWeights();
  std::mt19937_64 rng(4);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (double& w : weights) w += normal(rng);
  const OneFitModel model = trainer_->MakeModel(weights);
  // Another garment (its own normalisers if trained from scratch), and a
  // network of another width: the model's replace both.
  OneFitTrainingGarment wide{"wide", MakeTube(0.17, 0.12, 0.3, 16, 5), {}};
  wide.weights = SingleJointWeights(wide.mesh.num_vertices(), 1);
  OneFitTrainerOptions options = options_;
  options.network.decoder_hidden = {12};
  OneFitTrainer tune(body_, {wide}, {Bob(body_, 8)}, options);
  ASSERT_NE(tune.num_parameters(), trainer_->num_parameters());
  tune.StartFrom(model);
  ASSERT_EQ(tune.num_parameters(), trainer_->num_parameters());
  const OneFitModel again = tune.MakeModel(weights);
  EXPECT_EQ(again.patch_normalizer.mean, model.patch_normalizer.mean);
  EXPECT_EQ(again.body_normalizer.inv_std, model.body_normalizer.inv_std);
  EXPECT_EQ(again.network.decoder().sizes(), model.network.decoder().sizes());
  // The same body features normalise the same way: frame 3's prediction of
  // the shared clip matches a draper of the model on that garment.
  DrapeSolver solver(body_, wide.mesh, wide.weights, options_.drape);
  const OneFitDraper draper(model, solver, wide.weights, body_.skeleton, nullptr, InferencePrecision::kDouble);
  const OneFitTrainingClip clip = Bob(body_, 8);
  const std::vector<double> a = draper.Predict(clip.poses[1], clip.poses[2], clip.poses[3], clip.fps, clip.shape);
  const std::vector<double> b = tune.Predict(weights.data(), 0, 0, 3);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-12) << i;
  OneFitModel other = model;
  other.jet_order = 3;
  EXPECT_THROW(tune.StartFrom(other), std::invalid_argument);
}

TEST_F(OneFitTrainerTest, AResumedAdamRunWithItsMomentsEndsWhereAStraightRunEnds) {
  OneFitTrainerOptions options = options_;
  options.optimizer = OneFitOptimizer::kAdam;
  OneFitTrainingGarment shirt = TubeShirt();
  OneFitTrainer adam(body_, {shirt}, {Bob(body_, 8)}, options);
  std::vector<double> straight = adam.InitialWeights(), checkpoint;
  OneFitAdamState state, saved;
  adam.Train(
      &straight, 0,
      [&](const OneFitBatchSummary& b, const std::vector<double>& w, const std::vector<double>&) {
        if (b.batch == 2) checkpoint = w, saved = state;
      },
      &state);
  ASSERT_FALSE(checkpoint.empty());
  EXPECT_EQ(saved.steps, 3 * options.iterations_per_batch);
  // The moments through their file, as a resumed `onefit train` reads them.
  const std::string path = ::testing::TempDir() + "/onefit_test.adam";
  SaveOneFitAdamState(path, saved);
  OneFitAdamState loaded = LoadOneFitAdamState(path, checkpoint.size());
  EXPECT_EQ(loaded.m, saved.m);
  EXPECT_THROW(LoadOneFitAdamState(path, checkpoint.size() + 1), OneFitModelError);
  std::vector<double> resumed = checkpoint;
  adam.Train(&resumed, 3, nullptr, &loaded);
  EXPECT_EQ(resumed, straight);
}

// Polyak averaging: the weights validated and returned are the exponential
// average of each batch's, Adam's own steps are those of a run without it,
// and a run resumed from a checkpoint (the average through its file) ends
// where a straight run ends.
TEST_F(OneFitTrainerTest, AveragedWeightsAreTheBatchesMeanAndResumeWithIt) {
  OneFitTrainerOptions options = options_;
  options.optimizer = OneFitOptimizer::kAdam;
  OneFitTrainingGarment shirt = TubeShirt();
  OneFitTrainer plain(body_, {shirt}, {Bob(body_, 8)}, options);
  std::vector<std::vector<double>> raw;  // each batch's weights, no averaging
  std::vector<double> weights = plain.InitialWeights();
  plain.Train(&weights, 0, [&](const OneFitBatchSummary&, const std::vector<double>& w, const std::vector<double>& v) {
    raw.push_back(w);
    EXPECT_EQ(v, w);  // without averaging the weights themselves are validated
  });
  ASSERT_EQ(raw.size(), static_cast<size_t>(options.num_batches));

  options.average_batches = 3;
  OneFitTrainer averaging(body_, {shirt}, {Bob(body_, 8)}, options);
  std::vector<double> expected = averaging.InitialWeights(), straight = expected, checkpoint;
  OneFitAdamState state, saved;
  int batch = 0;
  averaging.Train(
      &straight, 0,
      [&](const OneFitBatchSummary& b, const std::vector<double>& w, const std::vector<double>& v) {
        ASSERT_EQ(w, raw[batch]) << "batch " << batch;
        for (size_t i = 0; i < w.size(); ++i) expected[i] += (w[i] - expected[i]) / 3.0;
        for (size_t i = 0; i < w.size(); ++i) ASSERT_NEAR(v[i], expected[i], 1e-15) << "batch " << batch;
        if (b.batch == 2) checkpoint = w, saved = state;
        ++batch;
      },
      &state);
  EXPECT_EQ(straight, state.average);
  EXPECT_NE(straight, raw.back());
  ASSERT_EQ(saved.average.size(), checkpoint.size());

  const std::string path = ::testing::TempDir() + "/onefit_average.adam";
  SaveOneFitAdamState(path, saved);
  OneFitAdamState loaded = LoadOneFitAdamState(path, checkpoint.size());
  EXPECT_EQ(loaded.average, saved.average);
  std::vector<double> resumed = checkpoint;
  averaging.Train(&resumed, 3, nullptr, &loaded);
  EXPECT_EQ(resumed, straight);
  // A state written without averaging has no average.
  SaveOneFitAdamState(path, OneFitAdamState{saved.m, saved.v, saved.steps, {}, {}});
  EXPECT_TRUE(LoadOneFitAdamState(path, checkpoint.size()).average.empty());

  options.optimizer = OneFitOptimizer::kLbfgs;
  EXPECT_NE(options.Validate().find("average_batches needs the Adam optimiser"), std::string::npos);
}

// The draper (garment half precomputed, as inference runs) predicts what
// training sees, at frame 3 of `clip`.
void ExpectDraperPredictsAsTraining(const SkinnedBody& body, const OneFitTrainerOptions& options,
                                    const OneFitTrainingClip& clip, const OneFitModel& model, OneFitTrainer& trainer,
                                    const std::vector<double>& weights) {
  OneFitTrainingGarment shirt = TubeShirt();
  DrapeSolver solver(body, shirt.mesh, shirt.weights, options.drape);
  const OneFitDraper draper(model, solver, shirt.weights, body.skeleton, &body, InferencePrecision::kDouble);
  const std::vector<double> a = draper.Predict(clip.poses[1], clip.poses[2], clip.poses[3], clip.fps, clip.shape);
  const std::vector<double> b = trainer.Predict(weights.data(), 0, 0, 3);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-12) << i;
  // Single precision (the default) agrees to float's rounding through a
  // few layers, and is not double's answer by accident.
  const OneFitDraper single(model, solver, shirt.weights, body.skeleton, &body);
  const std::vector<double> c = single.Predict(clip.poses[1], clip.poses[2], clip.poses[3], clip.fps, clip.shape);
  double largest = 0.0;
  for (size_t i = 0; i < c.size(); ++i) {
    EXPECT_NEAR(c[i], b[i], 1e-5 * (1.0 + std::abs(b[i]))) << i;
    largest = std::max(largest, std::abs(c[i] - b[i]));
  }
  EXPECT_GT(largest, 0.0);
}

// Bob, with joint 1 (the shirt's) also swaying about its head: its local
// rotation changes, so that the local pose carries something.
OneFitTrainingClip Sway(const SkinnedBody& body, int frames) {
  OneFitTrainingClip clip = Bob(body, frames);
  const Eigen::Vector3d head = body.skeleton.rest_heads.col(1);
  for (int t = 0; t < frames; ++t) {
    const Eigen::Isometry3d turn = Eigen::Translation3d(head) *
                                   Eigen::AngleAxisd(0.1 * std::sin(0.9 * t), Eigen::Vector3d::UnitX()) *
                                   Eigen::Translation3d(-head);
    clip.poses[t][1] = clip.poses[t][0] * turn;
  }
  return clip;
}

// The trainer's new weights moved at random (seeded), so that every input
// reaches the outputs.
std::vector<double> JitteredWeights(const OneFitTrainer& trainer, std::uint64_t seed) {
  std::vector<double> weights = trainer.InitialWeights();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (double& w : weights) w += normal(rng);
  return weights;
}

// The largest difference between the patch parameters predicted for the
// first garment on clips 0 and 1 at these frames.
double ClipPredictionDifference(OneFitTrainer& trainer, const std::vector<double>& weights,
                                std::initializer_list<int> frames) {
  double difference = 0.0;
  for (const int frame : frames) {
    const std::vector<double> a = trainer.Predict(weights.data(), 0, 0, frame);
    const std::vector<double> b = trainer.Predict(weights.data(), 0, 1, frame);
    for (size_t i = 0; i < a.size(); ++i) difference = std::max(difference, std::abs(a[i] - b[i]));
  }
  return difference;
}

// The same motion facing elsewhere: the heading-free network drapes it
// alike (patch parameters are in the body's rest frame); one reading the
// root's rotation in the world does not.
TEST_F(OneFitTrainerTest, AHeadingFreeNetworkDrapesAMotionTurnedAboutTheVerticalAlike) {
  OneFitTrainingGarment shirt = TubeShirt();
  const OneFitTrainingClip sway = Sway(body_, 8);
  OneFitTrainingClip turned = sway;
  const Eigen::Isometry3d turn(Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitY()));
  for (auto& pose : turned.poses) {
    for (auto& joint : pose) joint = turn * joint;
  }
  for (const RootRotation root : {RootRotation::kHeadingFree, RootRotation::kAbsolute}) {
    options_.root_rotation = root;
    OneFitTrainer trainer(body_, {shirt}, {sway, turned}, options_);
    const std::vector<double> weights = JitteredWeights(trainer, 5);
    const double difference = ClipPredictionDifference(trainer, weights, {0, 3, 6});
    if (root == RootRotation::kHeadingFree) {
      EXPECT_LT(difference, 1e-12);
    } else {
      EXPECT_GT(difference, 1e-6);
    }
    EXPECT_EQ(trainer.MakeModel(weights).root_rotation, root);
  }
}

// A tube shirt on joint 1 swaying for 8 frames, trained under `options`.
OneFitTrainer ShirtTrainer(const SkinnedBody& body, const OneFitTrainerOptions& options) {
  OneFitTrainingGarment shirt = TubeShirt();
  return OneFitTrainer(body, {shirt}, {Sway(body, 8)}, options);
}

// The trainer's initial weights, each moved by N(0, 0.05) under `seed`.
std::vector<double> JiggledWeights(const OneFitTrainer& trainer, std::uint64_t seed) {
  std::vector<double> weights = trainer.InitialWeights();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (double& w : weights) w += normal(rng);
  return weights;
}

// The trainer's model at these weights written to TempDir()/name and read
// back; *path (if given) is where.
OneFitModel RoundTrip(const OneFitTrainer& trainer, const std::vector<double>& weights, const std::string& name,
                      std::string* path = nullptr) {
  const std::string file = ::testing::TempDir() + "/" + name;
  SaveOneFitModel(file, trainer.MakeModel(weights));
  if (path != nullptr) *path = file;
  return LoadOneFitModel(file);
}

TEST_F(OneFitTrainerTest, TheLocalPoseHasTheRightGradientRoundTripsAndDrapesAsTraining) {
  options_.network.local_pose = true;
  OneFitTrainer trainer = ShirtTrainer(body_, options_);
  // With the history held: the loss the gradient is exactly of (the
  // history's own share varies with the features, here about 1e-3).
  ExpectGradientMatchesCentralDifferences(&trainer, 2, true);
  const std::vector<double> weights = JiggledWeights(trainer, 3);
  const OneFitModel loaded = RoundTrip(trainer, weights, "onefit_local_pose.pfonefit");
  EXPECT_TRUE(loaded.network.local_pose());
  EXPECT_EQ(loaded.network.decoder().input_size(), 8 + 8 + kLocalPoseSize);
  ExpectDraperPredictsAsTraining(body_, options_, Sway(body_, 8), loaded, trainer, weights);
  // The local pose moves the prediction: joint 1's sway is in x_k.
  const std::vector<double> a = trainer.Predict(weights.data(), 0, 0, 2), b = trainer.Predict(weights.data(), 0, 0, 4);
  double change = 0.0;
  for (size_t i = 0; i < a.size(); ++i) change = std::max(change, std::abs(a[i] - b[i]));
  EXPECT_GT(change, 1e-6);
}

// The body proximity: the gradient with it (an input: nothing flows into
// it), a round trip (version 11), and a draper that poses the body itself
// predicting what training sees; the proximity moves the prediction where
// only the body's place under the shirt changes.
TEST_F(OneFitTrainerTest, TheBodyProximityHasTheRightGradientRoundTripsAndDrapesAsTraining) {
  options_.network.body_proximity = true;
  OneFitTrainer trainer = ShirtTrainer(body_, options_);
  ExpectGradientMatchesCentralDifferences(&trainer, 2, true);
  const std::vector<double> weights = JiggledWeights(trainer, 5);
  const OneFitModel loaded = RoundTrip(trainer, weights, "onefit_proximity.pfonefit");
  EXPECT_TRUE(loaded.network.body_proximity());
  EXPECT_EQ(loaded.network.decoder().input_size(), 8 + 8 + kProximitySize);
  ExpectDraperPredictsAsTraining(body_, options_, Sway(body_, 8), loaded, trainer, weights);

  // Without the body the draper cannot read it: refused, not guessed.
  OneFitTrainingGarment shirt = TubeShirt();
  DrapeSolver solver(body_, shirt.mesh, shirt.weights, options_.drape);
  EXPECT_THROW(OneFitDraper(loaded, solver, shirt.weights, body_.skeleton), OneFitModelError);

  // The shirt on the root, which is held, and every other joint moved
  // aside together: every local rotation is the identity and the root is
  // still in both clips, so their body features agree, and only the
  // proximity sees the torso move under the shirt.
  shirt.weights = SingleJointWeights(shirt.mesh.num_vertices(), 0);
  OneFitTrainingClip still = Bob(body_, 8), moved = still;
  for (auto& pose : still.poses) pose.assign(pose.size(), Eigen::Isometry3d::Identity());
  for (auto& pose : moved.poses) {
    pose.assign(pose.size(), Eigen::Isometry3d(Eigen::Translation3d(0.03, 0.0, 0.0)));
    pose[0] = Eigen::Isometry3d::Identity();
  }
  OneFitTrainer sighted(body_, {shirt}, {still, moved}, options_);
  EXPECT_GT(ClipPredictionDifference(sighted, JiggledWeights(sighted, 6), {0, 3}), 1e-6);
  options_.network.body_proximity = false;
  OneFitTrainer blind(body_, {shirt}, {still, moved}, options_);
  EXPECT_LT(ClipPredictionDifference(blind, JiggledWeights(blind, 6), {0, 3}), 1e-12);
}

// The rim layout of nine probes: a round trip (version 12) and a draper
// predicting what training sees; a version-11 file, which has no count,
// reads the five-probe layout, and a count the decoder has no room for is
// refused.
TEST_F(OneFitTrainerTest, NineProximityProbesRoundTripAndDrapeAsTraining) {
  options_.network.body_proximity = true;
  options_.network.proximity_probes = kRimProximityProbes;
  OneFitTrainer trainer = ShirtTrainer(body_, options_);
  const std::vector<double> weights = JiggledWeights(trainer, 5);
  std::string path;
  const OneFitModel loaded = RoundTrip(trainer, weights, "onefit_rim_probes.pfonefit", &path);
  EXPECT_EQ(loaded.network.proximity_probes(), kRimProximityProbes);
  EXPECT_EQ(loaded.network.decoder().input_size(), 8 + 8 + ProximitySize(kRimProximityProbes));
  ExpectDraperPredictsAsTraining(body_, options_, Sway(body_, 8), loaded, trainer, weights);
  // A five-probe network cannot resume or fine-tune it.
  options_.network.proximity_probes = kProximityProbes;
  OneFitTrainer five = ShirtTrainer(body_, options_);
  EXPECT_THROW(five.StartFrom(loaded), std::invalid_argument);

  std::string bytes = FileBytes(path);
  ASSERT_EQ(bytes[8], 15);
  ASSERT_EQ(bytes[80], kRimProximityProbes);  // the probes' count
  const std::string damaged = ::testing::TempDir() + "/onefit_rim_probes_damaged.pfonefit";
  for (const char count : {'\x00', '\x05', '\x07'}) {
    std::string b = bytes;
    b[80] = count;
    std::ofstream(damaged, std::ios::binary) << b;
    EXPECT_THROW(LoadOneFitModel(damaged), OneFitModelError) << int{count};
  }
  // Version 11 without the count: five probes, for which this decoder has
  // no room.
  std::string v11 = bytes;
  v11[8] = 11;
  v11.erase(80, 84);  // the count, version 13's feedback flag, 14's skinning and 15's loss collision
  std::ofstream(damaged, std::ios::binary) << v11;
  EXPECT_THROW(LoadOneFitModel(damaged), OneFitModelError);
  SaveOneFitModel(path, five.MakeModel(JiggledWeights(five, 5)));
  v11 = FileBytes(path);
  v11[8] = 11;
  v11.erase(80, 84);
  std::ofstream(damaged, std::ios::binary) << v11;
  EXPECT_EQ(LoadOneFitModel(damaged).network.proximity_probes(), kProximityProbes);
}

// The feedback decoder: a new one leaves the decoder's prediction nearly
// as it is; the gradient through it and through the proximity at the
// decoder's patches is right; a round trip (version 13) and a draper that
// predicts what training sees; it needs the proximity, and the polish
// (which fits the decoder's output layer) is refused with it.
TEST_F(OneFitTrainerTest, TheFeedbackDecoderHasTheRightGradientRoundTripsAndDrapesAsTraining) {
  options_.network.body_proximity = true;
  const OneFitTrainer plain = ShirtTrainer(body_, options_);
  options_.network.feedback = true;
  options_.network.feedback_hidden = {12, 12};
  OneFitTrainer trainer = ShirtTrainer(body_, options_);
  EXPECT_EQ(
      trainer.num_parameters(),
      plain.num_parameters() + trainer.MakeModel(trainer.InitialWeights()).network.feedback_decoder().num_parameters());
  {
    // F's last layer starts scaled as D's: it moves the patches by
    // millimetres, as a new D moves the rest patches.
    std::vector<double> weights = trainer.InitialWeights();
    const std::vector<double> refined = trainer.Predict(weights.data(), 0, 0, 3);
    std::fill(weights.begin() + plain.num_parameters(), weights.end(), 0.0);  // F's weights zero: D's outputs
    const std::vector<double> decoded = trainer.Predict(weights.data(), 0, 0, 3);
    OneFitTrainingGarment shirt = TubeShirt();
    DrapeSolverOptions drape = options_.drape;
    drape.slide.warp_order = options_.network.warp_order;
    DrapeSolver solver(body_, shirt.mesh, shirt.weights, drape);
    const double moved = (solver.PositionsOf(refined) - solver.PositionsOf(decoded)).colwise().norm().maxCoeff();
    EXPECT_GT(moved, 0.0);
    EXPECT_LT(moved, 0.008);
  }
  ExpectGradientMatchesCentralDifferences(&trainer, 3, true);
  const std::vector<double> weights = JiggledWeights(trainer, 7);
  std::string path;
  const OneFitModel loaded = RoundTrip(trainer, weights, "onefit_feedback.pfonefit", &path);
  ASSERT_TRUE(loaded.network.feedback());
  EXPECT_EQ(loaded.network.feedback_decoder().sizes(),
            (std::vector<int>{8 + 8 + kProximitySize + loaded.network.num_outputs() + kProximitySize, 12, 12,
                              loaded.network.num_outputs()}));
  ExpectDraperPredictsAsTraining(body_, options_, Sway(body_, 8), loaded, trainer, weights);
  std::string bytes = FileBytes(path);
  ASSERT_EQ(bytes[8], 15);
  ASSERT_EQ(bytes[84], 1);  // the feedback flag
  const std::string damaged = ::testing::TempDir() + "/onefit_feedback_damaged.pfonefit";
  for (const char flag : {'\x00', '\x05', '\xff'}) {
    std::string b = bytes;
    b[84] = flag;
    std::ofstream(damaged, std::ios::binary) << b;
    EXPECT_THROW(LoadOneFitModel(damaged), OneFitModelError) << int{flag};
  }
  // A network without it cannot resume it, and the polish is refused.
  options_.network.feedback = false;
  OneFitTrainer without = ShirtTrainer(body_, options_);
  EXPECT_THROW(without.StartFrom(loaded), std::invalid_argument);
  std::vector<double> polished = weights;
  EXPECT_THROW(trainer.PolishOutputLayer(&polished), std::invalid_argument);
  options_.network.feedback = true;
  options_.polish.iterations = 2;
  EXPECT_NE(options_.Validate(), "");
  options_.polish.iterations = 0;
  options_.network.body_proximity = false;
  EXPECT_NE(options_.network.Validate(), "");
}

// Two passes of the feedback decoder: the gradient through both (and
// the proximity each read), a round trip (the passes in the header) and a
// draper that predicts what training sees; a count past the bound is
// refused.
TEST_F(OneFitTrainerTest, TwoFeedbackPassesHaveTheRightGradientAndDrapeAsTraining) {
  options_.network.body_proximity = true;
  options_.network.feedback = true;
  options_.network.feedback_hidden = {12, 12};
  options_.network.feedback_passes = 2;
  OneFitTrainer trainer = ShirtTrainer(body_, options_);
  ExpectGradientMatchesCentralDifferences(&trainer, 3, true);
  const std::vector<double> weights = JiggledWeights(trainer, 9);
  std::string path;
  const OneFitModel loaded = RoundTrip(trainer, weights, "onefit_feedback_twice.pfonefit", &path);
  EXPECT_EQ(loaded.network.feedback_passes(), 2);
  ExpectDraperPredictsAsTraining(body_, options_, Sway(body_, 8), loaded, trainer, weights);
  // The second pass moves the prediction.
  options_.network.feedback_passes = 1;
  OneFitTrainer once = ShirtTrainer(body_, options_);
  const std::vector<double> a = trainer.Predict(weights.data(), 0, 0, 3), b = once.Predict(weights.data(), 0, 0, 3);
  double change = 0.0;
  for (size_t i = 0; i < a.size(); ++i) change = std::max(change, std::abs(a[i] - b[i]));
  EXPECT_GT(change, 1e-9);
  EXPECT_THROW(once.StartFrom(loaded), std::invalid_argument);
  std::string bytes = FileBytes(path);
  ASSERT_EQ(bytes[84], 2);
  bytes[84] = kMaxFeedbackPasses + 1;
  const std::string damaged = ::testing::TempDir() + "/onefit_feedback_twice_damaged.pfonefit";
  std::ofstream(damaged, std::ios::binary) << bytes;
  EXPECT_THROW(LoadOneFitModel(damaged), OneFitModelError);
  options_.network.feedback_passes = 0;
  EXPECT_NE(options_.network.Validate(), "");
}

// A warp head of order 3 under a slide bound: the gradient through the
// bound's coupling of its coefficients is right, and a drape from the
// saved model (version 10) predicts as training does.
TEST_F(OneFitTrainerTest, AWarpUnderASlideBoundHasTheRightGradientAndDrapesAsTraining) {
  options_.network.warp_order = options_.drape.slide.warp_order = 3;
  options_.warp_slide_bound = 0.5;
  ASSERT_EQ(options_.Validate(), "");
  OneFitTrainer trainer = ShirtTrainer(body_, options_);
  ExpectGradientMatchesCentralDifferences(&trainer, 2, true);
  const std::vector<double> weights = JiggledWeights(trainer, 4);
  const OneFitModel loaded = RoundTrip(trainer, weights, "onefit_slide_bound.pfonefit");
  EXPECT_EQ(loaded.warp_slide_bound, 0.5);
  EXPECT_EQ(loaded.network.warp_order(), 3);
  ExpectDraperPredictsAsTraining(body_, options_, Sway(body_, 8), loaded, trainer, weights);
}

// The warm start from the reference drape: its distance's gradient
// against central differences (through the body proximity and the
// feedback decoder), and its batches bring the network's drape to the
// reference drape's positions, the same under the same seed.
// The warp target: through training, the warps the network predicts come
// nearer those its own jets ask for (DrapeSolver::SolveWarps) than the
// loss alone brings them; and the option is checked.
TEST_F(OneFitTrainerTest, TheWarpTargetPullsTheWarpHeadToTheWarpsItsJetsAskFor) {
  options_.optimizer = OneFitOptimizer::kAdam;
  options_.learning_rate = 1e-4;
  options_.validation_every = 0;
  options_.num_batches = 6;
  const std::vector<OneFitSample> samples = {{0, 0, 2}, {0, 0, 4}, {0, 0, 6}};
  const auto trained_distance = [&](double weight) {
    OneFitTrainerOptions o = options_;
    o.warp_target_weight = weight;
    OneFitTrainer t = ShirtTrainer(body_, o);
    std::vector<double> w = t.InitialWeights();
    const OneFitTrainingSummary trained = t.Train(&w);
    EXPECT_NE(trained.termination_type, TerminationType::kFailure) << trained.BriefReport();
    return t.WarpTargetDistance(w.data(), samples);
  };
  const double alone = trained_distance(0.0), pulled = trained_distance(1e10);
  EXPECT_GT(alone, 0.0);
  EXPECT_LT(pulled, 0.5 * alone);
  OneFitTrainerOptions bad = options_;
  bad.warp_target_weight = 1.0;
  bad.optimizer = OneFitOptimizer::kLbfgs;
  EXPECT_NE(bad.Validate().find("warp_target_weight needs the Adam optimiser"), std::string::npos);
  bad = options_;
  bad.warp_target_weight = 1.0;
  bad.network.warp_order = -1;
  bad.drape.slide.warp_order = -1;
  OneFitTrainer no_warps = ShirtTrainer(body_, bad);
  std::vector<double> w = no_warps.InitialWeights();
  EXPECT_THROW(no_warps.Train(&w), std::invalid_argument);
  bad = options_;
  bad.warp_target_sweeps = 0;
  EXPECT_NE(bad.Validate().find("warp_target_sweeps"), std::string::npos);
}

TEST_F(OneFitTrainerTest, TheTeacherFitsTheNetworkToTheReferenceDrape) {
  options_.network.body_proximity = true;
  options_.network.feedback = true;
  options_.network.feedback_hidden = {12};
  options_.optimizer = OneFitOptimizer::kAdam;
  options_.learning_rate = 1e-3;
  options_.teacher.clips = 1;
  options_.teacher.max_frames = 6;
  options_.teacher.lead_in = 3;
  options_.teacher.batches = 40;
  options_.validation_every = 0;
  // Not Ceres' sparse Cholesky in this binary: the linker keeps this test's
  // out-of-line copy of Eigen's aligned_malloc (64-byte aligned by hand
  // under -march=native), which Ceres' inlined free cannot release
  // ("double free or corruption" in its Eigen sparse Cholesky).
  options_.drape.solve.linear_solver = DrapeLinearSolver::kConjugateGradients;
  OneFitTrainer trainer = ShirtTrainer(body_, options_);
  std::vector<double> weights = trainer.InitialWeights();
  const OneFitTeacherSummary summary = trainer.Teach(&weights);
  ASSERT_EQ(summary.frames, 6) << summary.BriefReport();
  ASSERT_EQ(summary.drapes.size(), 1u);
  EXPECT_EQ(summary.drapes[0].dropped, 0);
  EXPECT_GT(summary.drapes[0].from_skinning_mm, 0.0);
  ASSERT_EQ(trainer.num_teacher_frames(), 6);
  ASSERT_EQ(summary.batches.size(), 40u);
  const std::vector<int> all = {0, 1, 2, 3, 4, 5};
  const double start = trainer.TeacherLoss(trainer.InitialWeights().data(), all, nullptr);
  const double end = trainer.TeacherLoss(weights.data(), all, nullptr);
  EXPECT_GT(start, 0.0);
  EXPECT_LT(end, 0.25 * start) << summary.BriefReport();
  EXPECT_LT(summary.batches.back().final_rms_mm, 0.5 * summary.batches.front().initial_rms_mm);

  std::vector<double> gradient(trainer.num_parameters());
  const std::vector<double> jiggled = JiggledWeights(trainer, 3);
  const std::vector<int> two = {1, 4};
  trainer.TeacherLoss(jiggled.data(), two, gradient.data());
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<double> plus = jiggled, minus = jiggled;
    double slope = 0.0;
    const double h = 1e-6;
    for (size_t i = 0; i < jiggled.size(); ++i) {
      const double d = normal(rng);
      plus[i] += h * d;
      minus[i] -= h * d;
      slope += gradient[i] * d;
    }
    const double numeric =
        (trainer.TeacherLoss(plus.data(), two, nullptr) - trainer.TeacherLoss(minus.data(), two, nullptr)) / (2.0 * h);
    EXPECT_NEAR(numeric, slope, 1e-5 * std::abs(slope) + 1e-12) << "trial " << trial;
  }

  OneFitTrainer again = ShirtTrainer(body_, options_);
  std::vector<double> weights_again = again.InitialWeights();
  again.Teach(&weights_again);
  EXPECT_EQ(weights_again, weights);

  // Through training, the teacher's term pulls the drape nearer the
  // reference drape than the loss alone does (from a warm start of one
  // batch, so that there is a distance to close).
  {
    options_.num_batches = 6;
    options_.batch_size = 4;
    const auto trained_distance = [&](double weight) {
      OneFitTrainerOptions o = options_;
      o.teacher.batches = 1;
      o.teacher.weight = weight;
      OneFitTrainer t = ShirtTrainer(body_, o);
      std::vector<double> w = t.InitialWeights();
      t.Teach(&w);
      const OneFitTrainingSummary trained = t.Train(&w);
      EXPECT_NE(trained.termination_type, TerminationType::kFailure) << trained.BriefReport();
      return t.TeacherLoss(w.data(), all, nullptr);
    };
    const double alone = trained_distance(0.0), pulled = trained_distance(1e9);
    EXPECT_LT(pulled, 0.5 * alone);
  }

  // A frame where the reference drape stretches more than the bound is no
  // target: with a zero bound none is, and the weights stay.
  options_.teacher.max_edge_strain_percent = 0.0;
  OneFitTrainer strict = ShirtTrainer(body_, options_);
  std::vector<double> untouched = strict.InitialWeights();
  const OneFitTeacherSummary none = strict.Teach(&untouched);
  EXPECT_EQ(none.frames, 0);
  ASSERT_EQ(none.drapes.size(), 1u);
  EXPECT_EQ(none.drapes[0].dropped, 6);
  EXPECT_TRUE(none.batches.empty());
  EXPECT_EQ(untouched, strict.InitialWeights());

  OneFitTrainerOptions bad = options_;
  bad.teacher.batches = 0;
  EXPECT_NE(bad.Validate().find("teacher"), std::string::npos);
}

TEST_F(OneFitTrainerTest, AValidationClipIsValidatedButNeverTrainedOn) {
  options_.validation_every = 2;
  options_.validation_frames = 3;
  options_.num_batches = 4;
  OneFitTrainingGarment shirt = TubeShirt();
  OneFitTrainer plain(body_, {shirt}, {Bob(body_, 8)}, options_);
  OneFitTrainer held_out(body_, {shirt}, {Bob(body_, 8)}, options_);
  held_out.SetValidationClip(Sway(body_, 6));
  std::vector<double> a = plain.InitialWeights(), b = held_out.InitialWeights();
  const OneFitTrainingSummary sa = plain.Train(&a), sb = held_out.Train(&b);
  // The same batches and steps: the validation clip is never drawn.
  EXPECT_EQ(a, b);
  ASSERT_EQ(sb.batches.size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(sa.batches[i].final_loss, sb.batches[i].final_loss);
  // What is validated is the held-out clip (index 1), with its loss.
  const OneFitBatchSummary& last = sb.batches.back();
  double inside = 0.0, strain = 0.0, loss = 0.0;
  held_out.ValidationDrape(b.data(), 0, 1, 3, &inside, &strain, &loss);
  EXPECT_EQ(last.validation_inside_percent, inside);
  EXPECT_EQ(last.validation_edge_strain_percent, strain);
  EXPECT_EQ(last.validation_loss, loss);
  EXPECT_GT(loss, 0.0);
  EXPECT_TRUE(std::isnan(sb.batches[0].validation_loss));  // not a validation batch
  // The swaying clip is validated, not the training one.
  double bob_inside = 0.0, bob_strain = 0.0, bob_loss = 0.0;
  held_out.ValidationDrape(b.data(), 0, 0, 3, &bob_inside, &bob_strain, &bob_loss);
  EXPECT_NE(bob_loss, loss);
}

// A pose of the procedural body: the root tilted and placed, every other
// joint turned about its own axis, all varying with t.
JointTransforms TiltedPose(const Skeleton& skeleton, double t) {
  JointTransforms pose(skeleton.num_joints());
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
    local.linear() = (Eigen::AngleAxisd(0.3 * std::sin(t + j), Eigen::Vector3d(1.0, 0.5, -0.2).normalized()) *
                      Eigen::AngleAxisd(0.2 * t, Eigen::Vector3d::UnitX()))
                         .toRotationMatrix();
    const int p = skeleton.parents[j];
    if (p < 0) {
      local.translation() = Eigen::Vector3d(0.4 * t, 0.02 * t * t, -0.1 * t);
      pose[j] = local;
    } else {
      const Eigen::Vector3d head = skeleton.rest_heads.col(j);
      local.translation() = head - local.linear() * head;  // turns about its head
      pose[j] = pose[p] * local;
    }
  }
  return pose;
}

// Turned about the vertical through the origin.
JointTransforms Turned(const JointTransforms& pose, double angle) {
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
  JointTransforms out = pose;
  for (auto& p : out) p = turn * p;
  return out;
}

TEST(BodyFeaturesTest, HeadingFreeFeaturesIgnoreWhichWayTheMotionFaces) {
  const SkinnedBody body = MakeProceduralBody();
  const Skeleton& skeleton = body.skeleton;
  const BodyShape shape;
  const JointTransforms a = TiltedPose(skeleton, 0.0), b = TiltedPose(skeleton, 0.1), c = TiltedPose(skeleton, 0.25);
  for (const double angle : {0.7, 2.5, -3.0}) {
    const JointTransforms ta = Turned(a, angle), tb = Turned(b, angle), tc = Turned(c, angle);
    const Eigen::VectorXd free = BodyFeatures(skeleton, a, b, c, 30.0, shape, RootRotation::kHeadingFree);
    const Eigen::VectorXd free_turned = BodyFeatures(skeleton, ta, tb, tc, 30.0, shape, RootRotation::kHeadingFree);
    EXPECT_LT((free - free_turned).cwiseAbs().maxCoeff(), 1e-12) << angle;
    // The world rotation does change: the root's first block.
    const Eigen::VectorXd absolute = BodyFeatures(skeleton, a, b, c, 30.0, shape, RootRotation::kAbsolute);
    const Eigen::VectorXd absolute_turned = BodyFeatures(skeleton, ta, tb, tc, 30.0, shape, RootRotation::kAbsolute);
    EXPECT_GT((absolute - absolute_turned).head<6>().cwiseAbs().maxCoeff(), 0.1) << angle;
    // Every other joint's blocks, gravity and velocity are the same in both.
    const int n = skeleton.num_joints();
    for (int b6 = 0; b6 < 3; ++b6) {
      EXPECT_EQ(free.segment(6 * (b6 * n + 1), 6 * (n - 1)), absolute.segment(6 * (b6 * n + 1), 6 * (n - 1)));
    }
    EXPECT_EQ(free.tail(17), absolute.tail(17));
  }
  // The root's turns are its own frame's: R_b^T R_c - I in 6D.
  const Eigen::Matrix3d turn = b[0].linear().transpose() * c[0].linear();
  const Eigen::VectorXd free = BodyFeatures(skeleton, a, b, c, 30.0, shape, RootRotation::kHeadingFree);
  const int n = skeleton.num_joints();
  EXPECT_NEAR(free[6 * n + 0], turn(0, 0) - 1.0, 1e-12);
  EXPECT_NEAR(free[6 * n + 1], turn(1, 0), 1e-12);
  EXPECT_NEAR(free[6 * n + 4], turn(1, 1) - 1.0, 1e-12);
}

TEST(BodyFeaturesTest, TheHeadingFollowsTheLegsWhenTheBodyBendsOrLeans) {
  for (const double heading : {0.0, 1.0, -2.0, 3.0}) {
    const Eigen::Matrix3d yaw = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitY()).toRotationMatrix();
    // Standing, bent forward (about the body's x) by 90 degrees, leaning
    // back by 80, each also leaning sideways: the same heading.
    for (const double pitch : {0.0, M_PI / 2, -1.4, 0.6}) {
      for (const double roll : {0.0, 0.3, -0.5}) {
        const Eigen::Matrix3d r = yaw * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()).toRotationMatrix();
        EXPECT_NEAR(std::remainder(HeadingAngle(r) - heading, 2 * M_PI), 0.0, 1e-12) << heading << " " << pitch;
      }
    }
    // Lying on the side (the lateral axis vertical): the forward axis.
    const Eigen::Matrix3d lying = yaw * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    EXPECT_NEAR(std::remainder(HeadingAngle(lying) - heading, 2 * M_PI), 0.0, 1e-12) << heading;
  }
}

TEST(LocalPoseFeaturesTest, WeightsEachJointsThreeRotationBlocks) {
  const int joints = 3;
  Eigen::VectorXd body(BodyFeatureSize(joints));
  for (Eigen::Index i = 0; i < body.size(); ++i) body[i] = 0.5 * static_cast<double>(i);
  Eigen::MatrixXd weights(joints, 2);
  weights << 1.0, 0.0,  //
      0.0, 0.25,        //
      0.0, 0.75;
  const Eigen::MatrixXd x = LocalPoseFeatures(body, weights);
  ASSERT_EQ(x.rows(), kLocalPoseSize);
  ASSERT_EQ(x.cols(), 2);
  for (int b = 0; b < 3; ++b) {
    for (int c = 0; c < 6; ++c) {
      // Joint j's block b value c sits at 6 (b #joints + j) + c.
      const auto at = [&](int j) { return body[6 * (b * joints + j) + c]; };
      EXPECT_DOUBLE_EQ(x(6 * b + c, 0), at(0));
      EXPECT_DOUBLE_EQ(x(6 * b + c, 1), 0.25 * at(1) + 0.75 * at(2));
    }
  }
  EXPECT_THROW(LocalPoseFeatures(body.head(10), weights), std::invalid_argument);
}

TEST(BodyFeatureMaskTest, KeepsTheJointsWhoseSubtreeMovesTheGarment) {
  // 0 <- 1 <- 2 and 0 <- 3.
  Skeleton skeleton;
  skeleton.names = {"root", "upper", "lower", "other"};
  skeleton.parents = {-1, 0, 1, 0};
  skeleton.rest_heads = Eigen::Matrix3Xd::Zero(3, 4);
  SkinWeights weights;
  weights.offsets = {0, 2, 4};
  weights.joint = {1, 0, 1, 2};
  weights.value = {0.7, 0.3, 0.996, 0.004};
  const Eigen::VectorXd reach = JointReach(weights, skeleton);
  ASSERT_EQ(reach.size(), 4);
  EXPECT_DOUBLE_EQ(reach[0], 1.0);
  EXPECT_DOUBLE_EQ(reach[1], 1.0);  // vertex 1: 0.996 on it, 0.004 below
  EXPECT_DOUBLE_EQ(reach[2], 0.004);
  EXPECT_DOUBLE_EQ(reach[3], 0.0);
  const int n = 4;
  const Eigen::VectorXd mask = BodyFeatureMask(weights, skeleton, 0.01);
  ASSERT_EQ(mask.size(), BodyFeatureSize(n));
  for (int b = 0; b < 3; ++b) {
    for (int j = 0; j < n; ++j) {
      const double expected = j < 2 ? 1.0 : 0.0;
      for (int c = 0; c < 6; ++c) EXPECT_EQ(mask[6 * (b * n + j) + c], expected) << b << " " << j;
    }
  }
  // Gravity, the root's velocity and the shape are always read.
  EXPECT_TRUE((mask.tail(BodyFeatureSize(n) - 18 * n).array() == 1.0).all());
  EXPECT_TRUE((BodyFeatureMask(weights, skeleton, 0.0).array() == 1.0).all());
  weights.joint[3] = 7;
  EXPECT_THROW(JointReach(weights, skeleton), std::invalid_argument);
}

// The shirt follows the spine: with the joint mask a leg's swing changes
// nothing it is draped with, the model file keeps the mask, and the
// draper applies it as training does.
TEST_F(OneFitTrainerTest, AJointMaskHidesTheJointsTheGarmentDoesNotFollow) {
  OneFitTrainingGarment shirt = TubeShirt();
  const OneFitTrainingClip sway = Sway(body_, 8);
  OneFitTrainingClip kick = sway;
  const int leg = body_.skeleton.Find("LeftUpLeg");
  const Eigen::Vector3d hip = body_.skeleton.rest_heads.col(leg);
  for (int t = 0; t < 8; ++t) {
    const Eigen::Isometry3d swing = Eigen::Translation3d(hip) *
                                    Eigen::AngleAxisd(0.4 * std::sin(0.7 * t), Eigen::Vector3d::UnitX()) *
                                    Eigen::Translation3d(-hip);
    for (const int j : {leg, leg + 1}) kick.poses[t][j] = kick.poses[t][0] * swing;
  }
  for (const double reach : {0.0, 0.5}) {
    options_.joint_mask_reach = reach;
    OneFitTrainer trainer(body_, {shirt}, {sway, kick}, options_);
    const std::vector<double> weights = JitteredWeights(trainer, 7);
    const double difference = ClipPredictionDifference(trainer, weights, {2, 5});
    if (reach > 0.0) {
      EXPECT_EQ(difference, 0.0);
      EXPECT_EQ(trainer.JointMaskReport(),
                "joints read: shirt 2/12 (not Neck Head LeftArm LeftForeArm RightArm RightForeArm LeftUpLeg LeftLeg "
                "RightUpLeg RightLeg)");
      const OneFitModel loaded = RoundTrip(trainer, weights, "onefit_joint_mask.pfonefit");
      EXPECT_EQ(loaded.joint_mask_reach, reach);
      ExpectDraperPredictsAsTraining(body_, options_, kick, loaded, trainer, weights);
    } else {
      EXPECT_GT(difference, 1e-6);
      EXPECT_EQ(trainer.JointMaskReport(), "");
    }
  }
}

TEST_F(OneFitTrainerTest, AModelFileRoundTripsAndTheDraperPredictsAsTraining) {
  std::vector<double> weights = trainer_->InitialWeights();
  std::mt19937_64 rng(2);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (double& w : weights) w += normal(rng);
  const OneFitModel model = trainer_->MakeModel(weights);
  ASSERT_EQ(model.Validate(), "");
  const std::string path = ::testing::TempDir() + "/onefit_test.pfonefit";
  SaveOneFitModel(path, model);
  const OneFitModel loaded = LoadOneFitModel(path);
  EXPECT_EQ(loaded.weights, model.weights);
  EXPECT_EQ(loaded.network.decoder().sizes(), model.network.decoder().sizes());
  EXPECT_EQ(loaded.body_normalizer.inv_std, model.body_normalizer.inv_std);
  EXPECT_EQ(loaded.patch_area, options_.drape.patching.patch_area);

  ExpectDraperPredictsAsTraining(body_, options_, Bob(body_, 8), loaded, *trainer_, weights);

  // Damaged files are named, never half-read.
  const std::string bytes = FileBytes(path);
  const auto expect_error = [&](const std::string& content, const std::string& needle) {
    std::ofstream(path, std::ios::binary) << content;
    try {
      LoadOneFitModel(path);
      ADD_FAILURE() << "expected an error mentioning " << needle;
    } catch (const OneFitModelError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_EQ(e.kind(), ErrorKind::kInput);
    }
  };
  expect_error(bytes.substr(0, bytes.size() / 2), "truncated");
  expect_error("not a model at all", "bad magic");
  std::string wrong_version = bytes;
  wrong_version[8] = kOneFitModelVersion + 1;
  expect_error(wrong_version, "version " + std::to_string(kOneFitModelVersion + 1));
  std::string huge = bytes;
  huge[164] = '\xff';  // the patch encoder's layer count
  huge[165] = '\xff';
  expect_error(huge, "layer sizes");
  EXPECT_THROW(LoadOneFitModel(path + ".absent"), OneFitModelError);
}

TEST(FeatureNormalizerTest, FloorsTheSpreadClampsAndIgnoresConstants) {
  // Rows: a feature of spread 2, one of spread 1e-4, a constant one.
  Eigen::MatrixXd samples(3, 4);
  samples << 1.0, 5.0, 1.0, 5.0,  //
      0.3, 0.3002, 0.3, 0.3002,   //
      7.0, 7.0, 7.0, 7.0;
  const FeatureNormalizer n = FeatureNormalizer::Fit(samples);
  EXPECT_NEAR(n.inv_std[0], 0.5, 1e-12);
  EXPECT_NEAR(n.inv_std[1], 1.0 / kMinFeatureSpread, 1e-9);
  EXPECT_EQ(n.inv_std[2], 0.0);
  const Eigen::Vector3d x = n.Apply(Eigen::Vector3d(4.0, 0.3101, 100.0));
  EXPECT_NEAR(x[0], 0.5, 1e-12);
  EXPECT_NEAR(x[1], 0.01 / kMinFeatureSpread, 1e-9);
  EXPECT_EQ(x[2], 0.0);
  // Far outside training: clamped.
  EXPECT_EQ(n.Apply(Eigen::Vector3d(1e3, -2.0, 7.0))(0, 0), kFeatureClamp);
  EXPECT_EQ(n.Apply(Eigen::Vector3d(1e3, -2.0, 7.0))(1, 0), -kFeatureClamp);
}

// A version-1 file (before the warp head) loads as a model without one.
TEST(OneFitModelTest, OlderVersionsStillLoadAndTheFlagsRoundTrip) {
  const int order = 2, joints = 3;
  OneFitNetworkOptions options;
  options.patch_hidden = {4};
  options.body_hidden = {4};
  options.decoder_hidden = {5};
  options.patch_embedding = options.body_embedding = 2;
  OneFitModel model;
  model.jet_order = order;
  model.num_joints = joints;
  model.network =
      OneFitNetwork(PatchFeatureSize(order, joints), BodyFeatureSize(joints), NumJetCoefficients(order), options);
  for (FeatureNormalizer* n : {&model.patch_normalizer, &model.body_normalizer}) {
    const int size = n == &model.patch_normalizer ? PatchFeatureSize(order, joints) : BodyFeatureSize(joints);
    n->mean = Eigen::VectorXd::Zero(size);
    n->inv_std = Eigen::VectorXd::Ones(size);
  }
  model.weights.resize(model.network.num_parameters());
  model.network.Initialize(3, 1.0, model.weights.data());
  model.aligned_frames = true;
  model.patch_area = 0.008;
  model.max_fit_error = 0.005;
  const std::string path = ::testing::TempDir() + "/onefit_v6.pfonefit";
  SaveOneFitModel(path, model);
  EXPECT_TRUE(LoadOneFitModel(path).aligned_frames);
  EXPECT_EQ(LoadOneFitModel(path).patch_area, 0.008);
  EXPECT_EQ(LoadOneFitModel(path).max_fit_error, 0.005);
  EXPECT_EQ(LoadOneFitModel(path).root_rotation, RootRotation::kHeadingFree);
  model.root_rotation = RootRotation::kAbsolute;
  SaveOneFitModel(path, model);
  EXPECT_EQ(LoadOneFitModel(path).root_rotation, RootRotation::kAbsolute);
  model.root_rotation = RootRotation::kHeadingFree;
  SaveOneFitModel(path, model);
  std::string bytes = FileBytes(path);
  EXPECT_FALSE(LoadOneFitModel(path).curved_faces);
  model.curved_faces = true;
  SaveOneFitModel(path, model);
  EXPECT_TRUE(LoadOneFitModel(path).curved_faces);
  bytes = FileBytes(path);
  ASSERT_EQ(bytes[8], 15);  // the version
  EXPECT_EQ(LoadOneFitModel(path).joint_mask_reach, 0.0);
  EXPECT_EQ(LoadOneFitModel(path).warp_slide_bound, 0.0);
  EXPECT_TRUE(LoadOneFitModel(path).skin == SkinTransferOptions{});
  model.joint_mask_reach = 0.05;
  model.warp_slide_bound = 0.5;
  model.skin.smoothing = SkinSmoothing::kSurface;
  model.skin.smoothing_length = 0.2;
  model.skin.smoothing_iterations = 7;
  model.skin.anchor_distance = 0.001;
  model.skin.loose_distance = 0.03;
  model.skin.min_weight = 0.002;
  model.skin.resample_edge_length = 0.02;
  EXPECT_FALSE(LoadOneFitModel(path).loss_collision.recorded);
  model.loss_collision = {true, 3.0, 0.01, 0.004};
  SaveOneFitModel(path, model);
  EXPECT_EQ(LoadOneFitModel(path).joint_mask_reach, 0.05);
  EXPECT_EQ(LoadOneFitModel(path).warp_slide_bound, 0.5);
  EXPECT_TRUE(LoadOneFitModel(path).skin == model.skin);
  EXPECT_TRUE(LoadOneFitModel(path).loss_collision == model.loss_collision);
  bytes = FileBytes(path);
  // `bytes` with byte `at` set to `value` is refused.
  const auto expect_refused = [&bytes](size_t at, char value, const std::string& file) {
    std::string damaged = bytes;
    damaged[at] = value;
    std::ofstream(file, std::ios::binary) << damaged;
    EXPECT_THROW(LoadOneFitModel(file), OneFitModelError) << at;
  };
  // `bytes` as `version` wrote them: without the field at [at, at + size).
  const auto downgrade = [&bytes](char version, size_t at, size_t size, const std::string& file) {
    bytes[8] = version;
    bytes.erase(at, size);
    std::ofstream(file, std::ios::binary) << bytes;
  };
  const std::string path14 = ::testing::TempDir() + "/onefit_v14_old.pfonefit";
  expect_refused(136, 2, path14);       // the loss collision flag
  expect_refused(147, '\xbf', path14);  // a negative collision weight (its sign bit)
  expect_refused(155, '\x7f', path14);  // the margin's exponent: a margin over 1 m
  // Version 14: the loss's collision settings not recorded.
  downgrade(14, 136, 28, path14);
  EXPECT_FALSE(LoadOneFitModel(path14).loss_collision.recorded);
  EXPECT_TRUE(LoadOneFitModel(path14).skin == model.skin);
  const std::string path13 = ::testing::TempDir() + "/onefit_v13_old.pfonefit";
  expect_refused(88, 2, path13);        // the smoothing method
  expect_refused(135, '\x40', path13);  // the resample length's exponent: 0.02 * 2^16
  // Version 13: garments skinned with the defaults.
  downgrade(13, 88, 48, path13);
  EXPECT_TRUE(LoadOneFitModel(path13).skin == SkinTransferOptions{});
  EXPECT_EQ(LoadOneFitModel(path13).warp_slide_bound, 0.5);
  const std::string path12 = ::testing::TempDir() + "/onefit_v12_old.pfonefit";
  expect_refused(84, 1, path12);  // a feedback decoder without the proximity
  expect_refused(84, 2, path12);
  // Version 12: no feedback decoder.
  downgrade(12, 84, 4, path12);
  EXPECT_FALSE(LoadOneFitModel(path12).network.feedback());
  const std::string path11 = ::testing::TempDir() + "/onefit_v11_old.pfonefit";
  expect_refused(80, 5, path11);  // probes without the proximity
  // Version 11: one layout of probes (none here).
  downgrade(11, 80, 4, path11);
  EXPECT_FALSE(LoadOneFitModel(path11).network.body_proximity());
  const std::string path10 = ::testing::TempDir() + "/onefit_v10_old.pfonefit";
  expect_refused(76, 2, path10);  // the proximity flag out of range
  expect_refused(76, 1, path10);  // a proximity the decoder's input has no room for
  // Version 10: no body proximity.
  downgrade(10, 76, 4, path10);
  EXPECT_FALSE(LoadOneFitModel(path10).network.body_proximity());
  EXPECT_EQ(LoadOneFitModel(path10).warp_slide_bound, 0.5);
  const std::string path9 = ::testing::TempDir() + "/onefit_v9_old.pfonefit";
  expect_refused(75, '\x40', path9);  // the bound's exponent: 0.5 * 2^16
  // Version 9: no slide bound (each warp coefficient bounded).
  downgrade(9, 68, 8, path9);
  EXPECT_EQ(LoadOneFitModel(path9).warp_slide_bound, 0.0);
  EXPECT_EQ(LoadOneFitModel(path9).joint_mask_reach, 0.05);
  const std::string path8 = ::testing::TempDir() + "/onefit_v8_old.pfonefit";
  expect_refused(67, '\x40', path8);  // the reach's exponent: 0.05 * 2^16
  // Version 8: no joint mask (every joint read).
  downgrade(8, 60, 8, path8);
  EXPECT_EQ(LoadOneFitModel(path8).joint_mask_reach, 0.0);
  EXPECT_TRUE(LoadOneFitModel(path8).area_units);
  const std::string path7 = ::testing::TempDir() + "/onefit_v7_old.pfonefit";
  expect_refused(56, 2, path7);
  // Version 7: no units flag (the patches' scales).
  downgrade(7, 56, 4, path7);
  EXPECT_FALSE(LoadOneFitModel(path7).area_units);
  EXPECT_TRUE(LoadOneFitModel(path7).curved_faces);
  const std::string path6 = ::testing::TempDir() + "/onefit_v6_old.pfonefit";
  expect_refused(52, 2, path6);
  // Version 6: no curved faces flag (planar faces).
  downgrade(6, 52, 4, path6);
  EXPECT_FALSE(LoadOneFitModel(path6).curved_faces);
  EXPECT_EQ(LoadOneFitModel(path6).root_rotation, RootRotation::kHeadingFree);
  // Version 5: no root rotation flag (the root's rotation in the world).
  std::string v5 = bytes;
  v5[8] = 5;
  v5.erase(48, 4);
  const std::string path5 = ::testing::TempDir() + "/onefit_v5_old.pfonefit";
  std::ofstream(path5, std::ios::binary) << v5;
  EXPECT_EQ(LoadOneFitModel(path5).root_rotation, RootRotation::kAbsolute);
  EXPECT_EQ(LoadOneFitModel(path5).patch_area, 0.008);
  std::string bad_flag = bytes;
  bad_flag[48] = 7;
  std::ofstream(path5, std::ios::binary) << bad_flag;
  EXPECT_THROW(LoadOneFitModel(path5), OneFitModelError);
  // Version 4: no patching (the defaults of then: 0.04 m^2, 8 mm).
  std::string v4 = v5;
  v4[8] = 4;
  v4.erase(32, 16);
  const std::string path4 = ::testing::TempDir() + "/onefit_v4_old.pfonefit";
  std::ofstream(path4, std::ios::binary) << v4;
  EXPECT_EQ(LoadOneFitModel(path4).patch_area, 0.04);
  EXPECT_EQ(LoadOneFitModel(path4).max_fit_error, 8e-3);
  EXPECT_TRUE(LoadOneFitModel(path4).aligned_frames);
  // A patch area that is not positive is refused.
  std::string zero_area = bytes;
  std::fill(zero_area.begin() + 32, zero_area.begin() + 40, '\0');
  std::ofstream(path4, std::ios::binary) << zero_area;
  EXPECT_THROW(LoadOneFitModel(path4), OneFitModelError);
  // Version 3: no local pose flag (no local pose).
  std::string v3 = v4;
  v3[8] = 3;
  v3.erase(28, 4);
  const std::string path3 = ::testing::TempDir() + "/onefit_v3_old.pfonefit";
  std::ofstream(path3, std::ios::binary) << v3;
  EXPECT_TRUE(LoadOneFitModel(path3).aligned_frames);
  EXPECT_FALSE(LoadOneFitModel(path3).network.local_pose());
  // A flag that disagrees with the decoder is refused.
  std::string lying = bytes;
  lying[28] = 1;
  std::ofstream(path3, std::ios::binary) << lying;
  EXPECT_THROW(LoadOneFitModel(path3), OneFitModelError);
  // Version 2: no alignment flag (PCA's frames).
  std::string v2 = v4;
  v2[8] = 2;
  v2.erase(24, 8);
  const std::string path2 = ::testing::TempDir() + "/onefit_v2.pfonefit";
  std::ofstream(path2, std::ios::binary) << v2;
  EXPECT_FALSE(LoadOneFitModel(path2).aligned_frames);
  // Version 1: no warp order either.
  std::string v1 = v4;
  v1[8] = 1;
  v1.erase(20, 12);
  const std::string path1 = ::testing::TempDir() + "/onefit_v1.pfonefit";
  std::ofstream(path1, std::ios::binary) << v1;
  const OneFitModel loaded = LoadOneFitModel(path1);
  EXPECT_EQ(loaded.network.warp_order(), -1);
  EXPECT_FALSE(loaded.aligned_frames);
  EXPECT_EQ(loaded.weights, model.weights);
}

TEST(OneFitNetworkTest, OutputsMapToPatchParametersAndBack) {
  // Two patches of 3 coefficients (order 1), s, T and a warp of order 1
  // (3 monomials per direction), in both kinds of units.
  const int k = 3, patches = 2, warp = 6;
  PatchOutputMap map;
  map.rest = {0.1, 0.2, 0.3, 0.05, 1.0, 2.0, 3.0, -0.1, 0.0, 0.2, 0.08, -1.0, 0.5, 0.0};
  for (int p = patches - 1; p >= 0; --p) map.rest.insert(map.rest.begin() + (p + 1) * (k + 4), warp, 0.0);
  map.frames = {Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix(),
                Eigen::AngleAxisd(-0.7, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix()};
  for (const auto& [area_units, slide_bound] : {std::pair{false, 0.0}, {true, 0.0}, {true, 0.2}}) {
    map.units.resize(k + 4 + warp, patches);
    map.units.col(0) = PatchOutputUnits(1, 1, 0.05, 0.006, 1.2, area_units);
    map.units.col(1) = PatchOutputUnits(1, 1, 0.08, 0.01, 1.3, area_units);
    map.warp_slide_bound = slide_bound;
    Eigen::MatrixXd outputs = Eigen::MatrixXd::Zero(k + 4 + warp, patches);
    EXPECT_EQ(PatchParametersFromOutputs(map, outputs, k), map.rest);
    outputs.setRandom();
    outputs *= 0.1;
    // L = sum_i c_i params_i: its gradient in outputs against central differences.
    std::vector<double> c(map.rest.size());
    for (size_t i = 0; i < c.size(); ++i) c[i] = std::cos(1.0 + i);
    const Eigen::MatrixXd d = ChainPatchParameterGradient(map, outputs, k, c);
    const auto loss = [&](const Eigen::MatrixXd& y) {
      const std::vector<double> p = PatchParametersFromOutputs(map, y, k);
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
    // A warp output moves only its own coefficient, within its bound (each
    // coefficient's, or with a slide bound the whole component's).
    outputs.setZero();
    outputs(k + 4 + 1, 1) = 100.0;
    const std::vector<double> p = PatchParametersFromOutputs(map, outputs, k);
    const double bound = slide_bound > 0.0 ? slide_bound : kOutputBoundWarp * map.units(k + 4 + 1, 1);
    EXPECT_NEAR(p[(k + 4 + warp) + k + 4 + 1], bound, 1e-7);
    for (int c = 0; c < warp; ++c) {
      if (c != 1) {
        EXPECT_EQ(p[(k + 4 + warp) + k + 4 + c], 0.0) << c;
      }
    }
  }
}

TEST(OneFitNetworkTest, ASlideBoundHoldsEveryPointOnItsPatchAtAnyWarpOrder) {
  // (du, dv) = r sum_c a_c m_c(u / r, v / r), |m_c| <= 1 on the patch: with
  // a slide bound B, sum_c |a_c| < B however large the outputs, and tends
  // to B; near zero the outputs act as they do without it. Each
  // coefficient bounded instead (B = 0), the sum grows with the order.
  const int order = 4, k = NumJetCoefficients(order);
  double unbounded_sum[5];
  for (int warp_order = 0; warp_order <= 4; ++warp_order) {
    const int w = NumJetCoefficients(warp_order);
    const Eigen::VectorXd units = PatchOutputUnits(order, warp_order, 0.11, 0.01, 0.9, true);
    const double* u = units.data() + k + 4;
    std::vector<double> y(w), a(w);
    for (int c = 0; c < w; ++c) y[c] = c % 3 == 0 ? -50.0 : 50.0;
    BoundWarpComponent(u, y.data(), w, 0.6, a.data());
    double sum = 0.0;
    for (int c = 0; c < w; ++c) {
      sum += std::abs(a[c]);
      EXPECT_EQ(a[c] > 0.0, y[c] > 0.0) << warp_order;  // the direction kept
    }
    EXPECT_LT(sum, 0.6) << warp_order;
    EXPECT_GT(sum, 0.6 * (1.0 - 1e-9)) << warp_order;
    BoundWarpComponent(u, y.data(), w, 0.0, a.data());
    unbounded_sum[warp_order] = 0.0;
    for (int c = 0; c < w; ++c) unbounded_sum[warp_order] += std::abs(a[c]);
    // Small outputs pass nearly unchanged: a_c = u_c y_c (1 - O(S^2 / B^2)).
    for (int c = 0; c < w; ++c) y[c] = 1e-4 * (c + 1);
    BoundWarpComponent(u, y.data(), w, 0.6, a.data());
    double s = 0.0;
    for (int c = 0; c < w; ++c) s += std::abs(u[c] * y[c]);
    const double shrink = (s / 0.6) * (s / 0.6) / 3.0;  // 1 - tanh(x) / x <= x^2 / 3
    ASSERT_LT(shrink, 0.01);
    for (int c = 0; c < w; ++c) EXPECT_NEAR(a[c], u[c] * y[c], (shrink + 1e-9) * std::abs(u[c] * y[c])) << c;
    // Its chain against central differences, at moderate outputs.
    for (int c = 0; c < w; ++c) y[c] = 0.3 * std::sin(1.0 + c);
    std::vector<double> d_a(w), d_y(w);
    for (int c = 0; c < w; ++c) d_a[c] = std::cos(2.0 + c);
    ChainWarpComponent(u, y.data(), w, 0.6, d_a.data(), d_y.data());
    for (int c = 0; c < w; ++c) {
      std::vector<double> plus = y, minus = y, ap(w), am(w);
      plus[c] += 1e-6;
      minus[c] -= 1e-6;
      BoundWarpComponent(u, plus.data(), w, 0.6, ap.data());
      BoundWarpComponent(u, minus.data(), w, 0.6, am.data());
      double numeric = 0.0;
      for (int i = 0; i < w; ++i) numeric += d_a[i] * (ap[i] - am[i]) / 2e-6;
      EXPECT_NEAR(d_y[c], numeric, 1e-7) << warp_order << " " << c;
    }
  }
  EXPECT_GT(unbounded_sum[4], 2.0 * unbounded_sum[2]);
}

TEST(OneFitNetworkTest, AreaUnitsMoveAPatchAlikeWhateverItsScale) {
  // The same surface patch (area A) with two scales s0 (as a coarser
  // meshing's larger extent gives): the same output moves its jet by the
  // same height, in metres, at the same point, and its centre alike.
  const int order = 4, k = NumJetCoefficients(order);
  const double area = 0.01, x = 0.03, y = -0.02;
  double height[2];
  Eigen::Vector3d shift[2];
  const double scales[2] = {0.06, 0.09};
  for (int i = 0; i < 2; ++i) {
    const double s0 = scales[i];
    const Eigen::VectorXd units = PatchOutputUnits(order, -1, s0, area, 1.0, true);
    ASSERT_EQ(units.size(), k + 4);
    // The jet's height in metres at (x, y) m: s0 sum_c u_c y_c (x / s0)^i (y / s0)^j, y_c = 0.1 (c + 1).
    std::vector<double> alpha(k);
    for (int c = 0; c < k; ++c) alpha[c] = units[c] * 0.1 * (c + 1);
    height[i] = s0 * EvaluateJetHeight(order, alpha.data(), x / s0, y / s0);
    shift[i] = units.segment<3>(k + 1) * 0.2;
  }
  EXPECT_NEAR(height[0], height[1], 1e-12);
  EXPECT_NEAR((shift[0] - shift[1]).norm(), 0.0, 1e-15);
  EXPECT_NEAR(shift[0].x(), 0.2 * std::sqrt(area / 3.14159265358979323846), 1e-15);
  // Scale units: the outputs are the scale's (models before version 8).
  const Eigen::VectorXd legacy = PatchOutputUnits(order, 2, 0.06, area, 1.0, false);
  EXPECT_EQ(legacy.head(k), Eigen::VectorXd::Ones(k));
  EXPECT_EQ(legacy.segment<3>(k + 1), Eigen::Vector3d::Constant(0.06));
  EXPECT_EQ(legacy.tail(12), Eigen::VectorXd::Ones(12));
  EXPECT_THROW(PatchOutputUnits(order, -1, 0.06, 0.0, 1.0, true), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
