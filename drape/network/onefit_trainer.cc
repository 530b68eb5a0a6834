#include "drape/network/onefit_trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>

#include "drape/network/onefit_draper.h"
#include "drape/network/onefit_trainer_garment.h"
#include "drape/network/output_proximity.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// A mini-batch's loss as Ceres' first-order function of the scaled
// weights x = w / c. L-BFGS restarts with every Solve, and its first step
// moves the largest weight by about 1: in units of c it is a modest step.
class BatchLoss : public ceres::FirstOrderFunction {
 public:
  BatchLoss(OneFitTrainer* trainer, const std::vector<OneFitSample>* samples, double scale)
      : trainer_(trainer), samples_(samples), scale_(scale), weights_(trainer->num_parameters()) {}
  bool Evaluate(const double* x, double* cost, double* gradient) const override {
    for (size_t i = 0; i < weights_.size(); ++i) weights_[i] = scale_ * x[i];
    *cost = trainer_->Loss(weights_.data(), *samples_, gradient);
    if (gradient != nullptr) {
      for (size_t i = 0; i < weights_.size(); ++i) gradient[i] *= scale_;
    }
    return std::isfinite(*cost);
  }
  int NumParameters() const override { return trainer_->num_parameters(); }

 private:
  OneFitTrainer* trainer_;
  const std::vector<OneFitSample>* samples_;
  double scale_;
  mutable std::vector<double> weights_;
};

}  // namespace

std::string OneFitTrainerOptions::Validate() const {
  if (std::string p = network.Validate(); !p.empty()) return "network: " + p;
  if (!(warp_slide_bound >= 0.0 && warp_slide_bound <= 1.0)) return "warp_slide_bound must be in [0, 1]";
  if (network.warp_order > kMaxTrainedWarpOrder && warp_slide_bound == 0.0) {
    return "network: warp_order " + std::to_string(network.warp_order) + " does not train (its slides leave the " +
           "patches and the loss diverges); at most " + std::to_string(kMaxTrainedWarpOrder) +
           " without a warp_slide_bound";
  }
  if (std::string p = drape.Validate(); !p.empty()) return "drape: " + p;
  if (batch_size < 1 || iterations_per_batch < 1 || num_batches < 0 || (num_batches == 0 && polish.iterations == 0)) {
    return "batch_size and iterations_per_batch must be >= 1, num_batches >= 1 (0 with a polish)";
  }
  if (polish.iterations < 0 || polish.samples < 1 || !(polish.initial_damping > 0.0)) {
    return "polish: iterations must be >= 0, samples >= 1 and initial_damping > 0";
  }
  if (polish.iterations > 0 && network.feedback) {
    return "polish: it fits the decoder's output layer, which the feedback decoder reads: not with feedback";
  }
  if (lbfgs_rank < 1) return "lbfgs_rank must be >= 1";
  if (!(weight_step > 0.0)) return "weight_step must be > 0";
  if (!(learning_rate > 0.0)) return "learning_rate must be > 0";
  if (warmup_batches < 0) return "warmup_batches must be >= 0";
  if (!(final_rate_fraction > 0.0 && final_rate_fraction <= 1.0)) return "final_rate_fraction must be in (0, 1]";
  if (average_batches < 0) return "average_batches must be >= 0";
  if (!(weight_decay >= 0.0) || !std::isfinite(weight_decay)) return "weight_decay must be finite and >= 0";
  if (weight_decay > 0.0 && optimizer != OneFitOptimizer::kAdam) return "weight_decay needs the Adam optimiser";
  if (average_batches > 0 && optimizer != OneFitOptimizer::kAdam) {
    return "average_batches needs the Adam optimiser (its average is checkpointed with Adam's moments)";
  }
  if (validation_every < 0 || validation_frames < 1) return "validation_every >= 0 and validation_frames >= 1";
  if (num_threads < 1) return "num_threads must be >= 1";
  const OneFitDistribution& d = distribution;
  if (d.num_processes < 1 || d.process < 0 || d.process >= d.num_processes) {
    return "distribution: process must be in [0, num_processes)";
  }
  if (d.num_processes > 1 && !d.all_reduce) return "distribution: several processes need all_reduce";
  if (!(kext_final_epoch >= 0.0) || !std::isfinite(kext_final_epoch)) return "kext_final_epoch must be >= 0";
  if (!std::isfinite(collision_start)) return "collision_start must be finite (< 0: no curriculum)";
  if (!(collision_ramp[0] >= 0.0 && collision_ramp[0] <= collision_ramp[1] && collision_ramp[1] <= 1.0)) {
    return "collision_ramp must satisfy 0 <= start <= end <= 1";
  }
  if (!(joint_mask_reach >= 0.0 && joint_mask_reach <= 1.0)) return "joint_mask_reach must be in [0, 1]";
  if (teacher.clips < 0 || teacher.max_frames < 0 || teacher.lead_in < 0 || teacher.batches < 0) {
    return "teacher: clips, max_frames, lead_in and batches must be >= 0";
  }
  if ((teacher.clips > 0) != (teacher.batches > 0)) return "teacher: clips and batches go together";
  if (!(teacher.weight >= 0.0) || !std::isfinite(teacher.weight)) return "teacher: weight must be finite and >= 0";
  if (!(teacher.max_inside_percent >= 0.0) || !(teacher.max_edge_strain_percent >= 0.0)) {
    return "teacher: max_inside_percent and max_edge_strain_percent must be >= 0";
  }
  if (teacher.batches > 0 && optimizer != OneFitOptimizer::kAdam) return "teacher: it needs the Adam optimiser";
  if (!(warp_target_weight >= 0.0) || !std::isfinite(warp_target_weight)) {
    return "warp_target_weight must be finite and >= 0";
  }
  if (warp_target_sweeps < 1) return "warp_target_sweeps must be >= 1";
  // (Whether the network has a warp head is checked by Train: a
  // fine-tune's comes from its model.)
  if (warp_target_weight > 0.0 && optimizer != OneFitOptimizer::kAdam) {
    return "warp_target_weight needs the Adam optimiser";
  }
  return {};
}

std::string OneFitTrainingSummary::BriefReport() const {
  char line[256];
  const double first = batches.empty() ? 0.0 : batches.front().initial_loss;
  const double last = batches.empty() ? 0.0 : batches.back().final_loss;
  std::snprintf(line, sizeof(line), "%s: %zu batches, loss %.4g -> %.4g J, %.1f s",
                TerminationTypeToString(termination_type), batches.size(), first, last, total_time_s);
  std::string report = line;
  if (!message.empty()) report += " (" + message + ")";
  if (undone_batches > 0) {
    report += "; " + std::to_string(undone_batches) + " batches undone (their loss grew over " +
              std::to_string(static_cast<int>(kSpikeRatio)) + "-fold)";
  }
  if (!polish.steps.empty()) report += "\n" + polish.BriefReport();
  if (!teacher.batches.empty()) report = teacher.BriefReport() + "\n" + report;
  return report;
}

namespace {

std::vector<OneFitTrainingBody> OneBody(const SkinnedBody& body, std::vector<OneFitTrainingGarment> garments,
                                        std::vector<OneFitTrainingClip> clips) {
  std::vector<OneFitTrainingBody> bodies(1);
  bodies[0].body = body;
  bodies[0].garments = std::move(garments);
  bodies[0].clips = std::move(clips);
  return bodies;
}

// The blocks' columns joined left to right, copied once (appending block
// by block copied every earlier column again: quadratic in the clips).
Eigen::MatrixXd JoinColumns(const std::vector<Eigen::MatrixXd>& blocks) {
  Eigen::Index rows = 0, cols = 0;
  for (const Eigen::MatrixXd& b : blocks) {
    rows = b.rows();
    cols += b.cols();
  }
  Eigen::MatrixXd joined(rows, cols);
  cols = 0;
  for (const Eigen::MatrixXd& b : blocks) {
    joined.middleCols(cols, b.cols()) = b;
    cols += b.cols();
  }
  return joined;
}

}  // namespace

OneFitTrainer::OneFitTrainer(const SkinnedBody& body, std::vector<OneFitTrainingGarment> garments,
                             std::vector<OneFitTrainingClip> clips, const OneFitTrainerOptions& options)
    : OneFitTrainer(OneBody(body, std::move(garments), std::move(clips)), options) {}

OneFitTrainer::OneFitTrainer(std::vector<OneFitTrainingBody> bodies, const OneFitTrainerOptions& options)
    : options_(options) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("OneFitTrainerOptions: " + problem);
  }
  if (bodies.empty()) throw std::invalid_argument("OneFitTrainer: no body");
  DrapeSolverOptions drape = options.drape;
  drape.num_threads = 1;                                // samples run side by side instead
  drape.slide.warp_order = options.network.warp_order;  // the loss reads the warp head's slides
  std::vector<Eigen::MatrixXd> patch_blocks, body_blocks;
  for (int b = 0; b < static_cast<int>(bodies.size()); ++b) {
    OneFitTrainingBody& body = bodies[b];
    if (body.garments.empty() || body.clips.empty())
      throw std::invalid_argument("OneFitTrainer: no garment or no clip");
    if (body.body.skeleton.num_joints() != bodies[0].body.skeleton.num_joints()) {
      throw std::invalid_argument("OneFitTrainer: the bodies' rigs differ");
    }
    skeletons_.push_back(body.body.skeleton);
    if (options.network.body_proximity) {
      proximity_.resize(options.num_threads);
      for (auto& cache : proximity_) {
        if (!cache) cache = std::make_unique<ProximityCache>();
        cache->bodies.push_back(std::make_unique<PosedBodySamples>(body.body));
        cache->posed.emplace_back(-1, -1);
      }
    }
    for (const OneFitTrainingGarment& g : body.garments) {
      AddGarment(body.body, g, b, drape);
      patch_blocks.push_back(garments_.back()->raw_features);
    }
    body_clips_.emplace_back();
    for (OneFitTrainingClip& clip : body.clips) {
      if (clip.poses.empty()) throw std::invalid_argument("OneFitTrainer: clip '" + clip.name + "' has no frame");
      body_clips_.back().push_back(static_cast<int>(clips_.size()));
      clips_.push_back(std::move(clip));
      clip_body_.push_back(b);
      body_blocks.push_back(ClipBodyFeatures(static_cast<int>(clips_.size()) - 1));
    }
  }
  num_training_clips_ = static_cast<int>(clips_.size());
  const Eigen::MatrixXd all_patch_features = JoinColumns(patch_blocks), body_samples = JoinColumns(body_blocks);
  patch_normalizer_ = FeatureNormalizer::Fit(all_patch_features);
  for (auto& g : garments_) g->features = patch_normalizer_.Apply(g->raw_features);
  body_normalizer_ = FeatureNormalizer::Fit(body_samples);
  const int num_coefficients = NumJetCoefficients(options.drape.patching.jet_order);
  network_ = OneFitNetwork(static_cast<int>(all_patch_features.rows()), static_cast<int>(body_samples.rows()),
                           num_coefficients, options.network);
}

void OneFitTrainer::AddGarment(const SkinnedBody& body, const OneFitTrainingGarment& g, int body_index,
                               const DrapeSolverOptions& drape) {
  auto data = std::make_unique<GarmentData>();
  data->name = g.name;
  DrapeSolverOptions own = drape;
  own.patching.seed = g.patch_seed;
  data->body = body_index;
  try {
    for (int t = 0; t < options_.num_threads; ++t) {
      data->solvers.push_back(std::make_unique<DrapeSolver>(body, g.mesh, g.weights, own));
    }
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("OneFitTrainer: garment '" + g.name + "': " + e.what());
  }
  const DrapeSolver& solver = *data->solvers.front();
  data->map = MakePatchOutputMap(solver, options_.drape.patching.jet_order, options_.network.warp_order,
                                 options_.area_units, options_.warp_slide_bound);
  data->raw_features = PatchFeatures(solver.model(), data->map.rest, data->map.units, options_.drape.patching.jet_order,
                                     g.weights, body.skeleton);
  data->joint_weights = PatchJointWeights(solver.model(), g.weights, body.skeleton.num_joints());
  data->body_mask = BodyFeatureMask(g.weights, body.skeleton, options_.joint_mask_reach);
  if (options_.network.body_proximity)
    data->probes = MakePatchProbes(solver.model(), solver.PatchRestAreas(), data->joint_weights,
                                   options_.network.proximity_probes);
  garments_.push_back(std::move(data));
}

// The raw body features of every frame of a clip (the normalisers' data).
Eigen::MatrixXd OneFitTrainer::ClipBodyFeatures(int clip) const {
  const OneFitTrainingClip& c = clips_[clip];
  const Skeleton& skeleton = skeletons_[clip_body_[clip]];
  Eigen::MatrixXd features(BodyFeatureSize(skeleton.num_joints()), c.poses.size());
  for (int t = 0; t < static_cast<int>(c.poses.size()); ++t) {
    const auto pose = [&](int f) -> const JointTransforms& { return c.poses[std::max(f, 0)]; };
    features.col(t) = BodyFeatures(skeleton, pose(t - 2), pose(t - 1), pose(t), c.fps, c.shape, options_.root_rotation);
  }
  return features;
}

OneFitTrainer::~OneFitTrainer() = default;

std::vector<double> OneFitTrainer::InitialWeights() const {
  std::vector<double> weights(network_.num_parameters());
  network_.Initialize(options_.seed, options_.network.initial_output_scale, weights.data());
  return weights;
}

std::string OneFitTrainer::JointMaskReport() const {
  if (options_.joint_mask_reach <= 0.0) return {};
  std::string report = "joints read:";
  for (const auto& g : garments_) {
    const Skeleton& skeleton = skeletons_[g->body];
    const int n = skeleton.num_joints();
    std::string unread;
    for (int j = 0; j < n; ++j) {
      if (g->body_mask[6 * j] == 0.0) unread += (unread.empty() ? "" : " ") + skeleton.names[j];
    }
    const Eigen::Index read = (g->body_mask.head(6 * n).array() != 0.0).count() / 6;
    report += " " + g->name + " " + std::to_string(read) + "/" + std::to_string(n);
    if (!unread.empty()) report += " (not " + unread + ")";
  }
  return report;
}

Eigen::VectorXd OneFitTrainer::GarmentBodyFeatures(const GarmentData& g, int clip, int frame) const {
  const OneFitTrainingClip& c = clips_[clip];
  const auto pose = [&](int f) -> const JointTransforms& { return c.poses[std::clamp(f, 0, int(c.poses.size()) - 1)]; };
  Eigen::VectorXd features =
      body_normalizer_.Apply(BodyFeatures(skeletons_[clip_body_[clip]], pose(frame - 2), pose(frame - 1), pose(frame),
                                          c.fps, c.shape, options_.root_rotation));
  features.array() *= g.body_mask.array();
  return features;
}

OneFitModel OneFitTrainer::MakeModel(const std::vector<double>& weights) const {
  OneFitModel model;
  model.jet_order = options_.drape.patching.jet_order;
  model.num_joints = skeletons_.front().num_joints();
  model.aligned_frames = options_.drape.patching.align_frames;
  model.patch_area = options_.drape.patching.patch_area;
  model.max_fit_error = options_.drape.patching.max_fit_error;
  model.curved_faces = options_.drape.patching.curved_faces;
  model.root_rotation = options_.root_rotation;
  model.area_units = options_.area_units;
  model.joint_mask_reach = options_.joint_mask_reach;
  model.warp_slide_bound = options_.warp_slide_bound;
  model.skin = options_.skin;
  model.loss_collision = {true, options_.drape.physics.weights.collision,
                          options_.drape.physics.weights.collision_margin, options_.drape.physics.margin_floor};
  model.network = network_;
  model.patch_normalizer = patch_normalizer_;
  model.body_normalizer = body_normalizer_;
  model.weights = weights;
  return model;
}

void OneFitTrainer::StartFrom(const OneFitModel& model) {
  if (model.jet_order != options_.drape.patching.jet_order || model.num_joints != skeletons_.front().num_joints() ||
      model.network.warp_order() != options_.network.warp_order ||
      model.aligned_frames != options_.drape.patching.align_frames ||
      model.patch_area != options_.drape.patching.patch_area ||
      model.max_fit_error != options_.drape.patching.max_fit_error ||
      model.curved_faces != options_.drape.patching.curved_faces || model.root_rotation != options_.root_rotation ||
      model.area_units != options_.area_units || model.joint_mask_reach != options_.joint_mask_reach ||
      model.warp_slide_bound != options_.warp_slide_bound || model.skin != options_.skin ||
      model.network.body_proximity() != options_.network.body_proximity ||
      (model.network.body_proximity() && model.network.proximity_probes() != options_.network.proximity_probes) ||
      model.network.feedback() != options_.network.feedback ||
      (model.network.feedback() && model.network.feedback_passes() != options_.network.feedback_passes)) {
    throw std::invalid_argument(
        "OneFitTrainer::StartFrom: the model's jet order, warp order, slide bound, patching, skinning, root feature, "
        "output units, joint mask, body proximity, feedback or rig differs from the training's");
  }
  if (model.patch_normalizer.mean.size() != patch_normalizer_.mean.size() ||
      model.body_normalizer.mean.size() != body_normalizer_.mean.size()) {
    throw std::invalid_argument("OneFitTrainer::StartFrom: the model's features differ from the training's");
  }
  network_ = model.network;
  patch_normalizer_ = model.patch_normalizer;
  body_normalizer_ = model.body_normalizer;
  for (auto& g : garments_) g->features = patch_normalizer_.Apply(g->raw_features);
}

PosedBodySamples& OneFitTrainer::BodyPosedAt(int body, int clip, int frame, int thread) {
  ProximityCache& cache = *proximity_.at(thread);
  const OneFitTrainingClip& c = clips_[clip];
  frame = std::clamp(frame, 0, static_cast<int>(c.poses.size()) - 1);
  PosedBodySamples& samples = *cache.bodies[body];
  if (cache.posed[body] != std::make_pair(clip, frame)) {
    samples.Pose(c.poses[frame]);
    cache.posed[body] = {clip, frame};
  }
  return samples;
}

const Eigen::MatrixXd* OneFitTrainer::ProximityAt(int garment, int clip, int frame, int thread) {
  if (proximity_.empty()) return nullptr;
  ProximityCache& cache = *proximity_.at(thread);
  const OneFitTrainingClip& c = clips_[clip];
  frame = std::clamp(frame, 0, static_cast<int>(c.poses.size()) - 1);
  const auto key = std::make_tuple(garment, clip, frame);
  if (const auto it = cache.features.find(key); it != cache.features.end()) return &it->second;
  // A bound on the memory (about 27 KB an entry at 170 patches): a batch
  // holds at most 3 batch_size frames.
  if (cache.features.size() >= 1024) cache.features.clear();
  const GarmentData& g = *garments_[garment];
  Eigen::MatrixXd& features = cache.features[key];
  BodyProximityFeatures(g.probes, c.poses[frame], BodyPosedAt(g.body, clip, frame, thread), &features);
  return &features;
}

void OneFitTrainer::ApplyFeedback(const double* weights, int garment, int clip, int frame, int thread,
                                  std::vector<OutputProximity>* at, OneFitNetwork::Cache* cache,
                                  Eigen::MatrixXd* outputs) {
  const OneFitTrainingClip& c = clips_[clip];
  const int f = std::clamp(frame, 0, static_cast<int>(c.poses.size()) - 1);
  const GarmentData& g = *garments_[garment];
  const PosedBodySamples& body = BodyPosedAt(g.body, clip, f, thread);
  at->clear();
  at->reserve(network_.feedback_passes());
  Eigen::MatrixXd refined;
  for (int pass = 0; pass < network_.feedback_passes(); ++pass) {
    at->emplace_back(g.map, g.probes, options_.drape.patching.jet_order);
    const Eigen::MatrixXd& proximity = at->back().Evaluate(*outputs, c.poses[f], body);
    network_.Feedback(weights, cache->decoder.inputs.front(), *outputs, proximity, &refined, cache, pass);
    outputs->swap(refined);
  }
}

std::vector<double> OneFitTrainer::Predict(const double* weights, int garment, int clip, int frame) {
  return PredictOn(weights, garment, clip, frame, 0);
}

std::vector<double> OneFitTrainer::PredictOn(const double* weights, int garment, int clip, int frame, int thread) {
  Eigen::MatrixXd outputs;
  std::vector<OutputProximity> at;
  Outputs(weights, garment, clip, frame, thread, &outputs, nullptr, &at);
  return PatchParametersFromOutputs(garments_[garment]->map, outputs, network_.num_coefficients());
}

void OneFitTrainer::Outputs(const double* weights, int garment, int clip, int frame, int thread,
                            Eigen::MatrixXd* outputs, OneFitNetwork::Cache* cache, std::vector<OutputProximity>* at) {
  const GarmentData& g = *garments_.at(garment);
  if (g.body != clip_body_.at(clip)) throw std::invalid_argument("OneFitTrainer: a garment and a clip of two bodies");
  OneFitNetwork::Cache local;  // the feedback's input
  if (cache == nullptr && network_.feedback()) cache = &local;
  network_.Forward(weights, g.features, GarmentBodyFeatures(g, clip, frame), &g.joint_weights,
                   ProximityAt(garment, clip, frame, thread), outputs, cache);
  at->clear();
  if (network_.feedback()) ApplyFeedback(weights, garment, clip, frame, thread, at, cache, outputs);
}

void OneFitTrainer::PrepareSample(const double* weights, const double* history_weights, const OneFitSample& sample,
                                  int thread, double epoch, Eigen::MatrixXd* outputs, OneFitNetwork::Cache* cache) {
  GarmentData& g = *garments_[sample.garment];
  DrapeSolver& solver = *g.solvers[thread];
  const OneFitTrainingClip& clip = clips_[sample.clip];
  const int last = static_cast<int>(clip.poses.size()) - 1;
  const auto pose = [&](int f) -> const JointTransforms& { return clip.poses[std::clamp(f, 0, last)]; };
  // The network's own positions at t - 1 and t - 2: inertia's data.
  Eigen::Matrix3Xd history[2];
  for (int back = 1; back <= 2; ++back) {
    const int f = std::max(sample.frame - back, 0);
    history[back - 1] = solver.PositionsAt(PredictOn(history_weights, sample.garment, sample.clip, f, thread), pose(f));
  }
  solver.SetHistory(history[0], history[1]);
  solver.Pose(pose(sample.frame), epoch);
  network_.Forward(weights, g.features, GarmentBodyFeatures(g, sample.clip, sample.frame), &g.joint_weights,
                   ProximityAt(sample.garment, sample.clip, sample.frame, thread), outputs, cache);
}

double OneFitTrainer::SampleLoss(const double* weights, const double* history_weights, const OneFitSample& sample,
                                 int thread, double* gradient, double epoch) {
  GarmentData& g = *garments_[sample.garment];
  Eigen::MatrixXd outputs;
  OneFitNetwork::Cache cache;
  const bool feedback = network_.feedback();
  PrepareSample(weights, history_weights, sample, thread, epoch, &outputs,
                gradient != nullptr || feedback ? &cache : nullptr);
  std::vector<OutputProximity> at;  // per pass of F
  if (feedback) ApplyFeedback(weights, sample.garment, sample.clip, sample.frame, thread, &at, &cache, &outputs);
  const std::vector<double> params = PatchParametersFromOutputs(g.map, outputs, network_.num_coefficients());
  std::vector<double> d_params;
  const double energy = g.solvers[thread]->Evaluate(params, gradient != nullptr ? &d_params : nullptr);
  if (gradient != nullptr) BackPropagate(weights, g, outputs, cache, at, d_params, gradient);
  return energy;
}

void OneFitTrainer::BackPropagate(const double* weights, const GarmentData& g, const Eigen::MatrixXd& outputs,
                                  const OneFitNetwork::Cache& cache, const std::vector<OutputProximity>& at,
                                  const std::vector<double>& d_params, double* gradient) {
  Eigen::MatrixXd d_outputs = ChainPatchParameterGradient(g.map, outputs, network_.num_coefficients(), d_params);
  // Back through F's passes to D's outputs: directly, and through the
  // proximity at the patches each pass read.
  Eigen::MatrixXd d_decoder_input;  // what reaches the encoders through F's passes
  for (int pass = static_cast<int>(at.size()) - 1; pass >= 0; --pass) {
    Eigen::MatrixXd d_input, d_proximity;
    network_.FeedbackBackward(weights, cache, d_outputs, gradient, &d_input, &d_proximity, &d_decoder_input, pass);
    d_outputs = d_input + at[pass].Chain(d_proximity);
  }
  network_.Backward(weights, cache, d_outputs, gradient, at.empty() ? nullptr : &d_decoder_input);
}

double OneFitTrainer::Loss(const double* weights, const std::vector<OneFitSample>& samples, double* gradient) {
  return LossWithHistory(weights, weights, samples, gradient);
}

double OneFitTrainer::LossWithHistory(const double* weights, const double* history_weights,
                                      const std::vector<OneFitSample>& samples, double* gradient) {
  const int n = num_parameters();
  // Eigen's vectorised kernels round differently with the alignment of
  // the arrays they read, so the weights and the gradients are copied to
  // Eigen's (always aligned) storage: the same weights, the same bits.
  const Eigen::VectorXd aligned = Eigen::Map<const Eigen::VectorXd>(weights, n);
  // The history's weights are copied only when they are others.
  const bool same_history = history_weights == weights;
  const Eigen::VectorXd aligned_history =
      same_history ? Eigen::VectorXd() : Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(history_weights, n));
  history_weights = same_history ? aligned.data() : aligned_history.data();
  return MeanOverSamples(
      static_cast<int>(samples.size()),
      [&](int i, int thread, double* g) {
        return SampleLoss(aligned.data(), history_weights, samples[i], thread, g, epoch_);
      },
      gradient);
}

double OneFitTrainer::MeanOverSamples(int count, const std::function<double(int, int, double*)>& sample_loss,
                                      double* gradient) {
  const OneFitDistribution& d = options_.distribution;
  std::vector<int> mine;  // this process's share of the samples
  for (int i = d.process; i < count; i += d.num_processes) mine.push_back(i);
  const int threads = std::max(1, std::min<int>(options_.num_threads, static_cast<int>(mine.size())));
  const int n = num_parameters();
  std::vector<Eigen::VectorXd> gradients(threads);
  std::vector<double> losses(count, 0.0);
  if (gradient != nullptr) {
    for (auto& g : gradients) g = Eigen::VectorXd::Zero(n);
  }
  // Samples dealt to threads in a fixed pattern (thread t takes t, t + T,
  // ...), so that the sums, and training, do not depend on timing.
  ParallelFor(
      threads, threads,
      [&](int, int t) {
        for (size_t k = t; k < mine.size(); k += threads) {
          losses[mine[k]] = sample_loss(mine[k], t, gradient != nullptr ? gradients[t].data() : nullptr);
        }
      },
      1);
  const double scale = 1.0 / static_cast<double>(count);
  // [loss, gradient]: reduced over the processes in one call.
  std::vector<double> sums(gradient != nullptr ? n + 1 : 1, 0.0);
  for (int i : mine) sums[0] += scale * losses[i];
  if (gradient != nullptr) {
    for (const auto& g : gradients) {
      for (int i = 0; i < n; ++i) sums[i + 1] += scale * g[i];
    }
  }
  if (d.num_processes > 1) d.all_reduce(sums.data(), static_cast<int>(sums.size()));
  if (gradient != nullptr) std::copy(sums.begin() + 1, sums.end(), gradient);
  return sums[0];
}

OneFitBatchSummary OneFitTrainer::LbfgsBatch(const std::vector<OneFitSample>& batch, int index,
                                             std::vector<double>* weights) {
  ceres::GradientProblemSolver::Options solver;
  solver.line_search_direction_type = ceres::LBFGS;
  solver.max_lbfgs_rank = options_.lbfgs_rank;
  solver.max_num_iterations = options_.iterations_per_batch;
  solver.logging_type = ceres::SILENT;
  ceres::GradientProblem problem(new BatchLoss(this, &batch, options_.weight_step));
  ceres::GradientProblemSolver::Summary result;
  std::vector<double> x(weights->size());
  for (size_t i = 0; i < x.size(); ++i) x[i] = (*weights)[i] / options_.weight_step;
  ceres::Solve(solver, problem, x.data(), &result);
  for (size_t i = 0; i < x.size(); ++i) (*weights)[i] = options_.weight_step * x[i];
  OneFitBatchSummary record;
  record.batch = index;
  record.initial_loss = result.initial_cost;
  record.final_loss = result.final_cost;
  record.iterations = static_cast<int>(result.iterations.size()) - 1;
  return record;
}

double AdamStepSize(const OneFitTrainerOptions& options, long long step) {
  // Counted in Adam's steps, so that a resumed run continues the schedule.
  const double warmup = static_cast<double>(options.warmup_batches) * options.iterations_per_batch;
  const double total = static_cast<double>(options.num_batches) * options.iterations_per_batch;
  const double s = static_cast<double>(step);
  if (s < warmup) return options.learning_rate * s / warmup;
  if (options.final_rate_fraction == 1.0 || total <= warmup) return options.learning_rate;
  const double t = std::min(1.0, (s - warmup) / (total - warmup));
  const double fraction =
      options.final_rate_fraction + (1.0 - options.final_rate_fraction) * 0.5 * (1.0 + std::cos(M_PI * t));
  return options.learning_rate * fraction;
}

OneFitBatchSummary OneFitTrainer::AdamBatch(const std::vector<OneFitSample>& batch, int index, AdamState* state,
                                            std::vector<double>* weights) {
  OneFitBatchSummary record;
  record.batch = index;
  // With the teacher's term: its distance over a batch of its frames
  // (drawn per batch, seeded) adds its gradient; the record keeps the
  // loss alone.
  const double teacher_weight =
      teacher_.empty() ? 0.0 : options_.teacher.weight * (1.0 - static_cast<double>(index) / options_.num_batches);
  std::vector<int> teacher_batch;
  std::vector<double> teacher_gradient;
  if (teacher_weight > 0.0) {
    std::mt19937_64 rng(options_.seed * 1000003u + static_cast<std::uint64_t>(index));
    std::uniform_int_distribution<int> draw(0, num_teacher_frames() - 1);
    teacher_batch.resize(options_.batch_size);
    for (int& i : teacher_batch) i = draw(rng);
    teacher_gradient.resize(weights->size());
  }
  // With the warp target: the warps the batch's jets ask for, once per
  // batch; its gradient added as the teacher's.
  std::vector<TeacherFrame> warp_targets;
  if (options_.warp_target_weight > 0.0) {
    warp_targets = WarpTargets(weights->data(), batch);
    if (teacher_gradient.empty()) teacher_gradient.resize(weights->size());
  }
  // g += weight times the gradient that `term` writes into the buffer.
  const auto pull = [&](double weight, double* g, const std::function<void(double*)>& term) {
    term(teacher_gradient.data());
    for (size_t i = 0; i < teacher_gradient.size(); ++i) g[i] += weight * teacher_gradient[i];
  };
  const auto loss = [&](const double* w, double* g) {
    const double value = Loss(w, batch, g);
    if (teacher_weight > 0.0) pull(teacher_weight, g, [&](double* d) { TeacherLoss(w, teacher_batch, d); });
    if (!warp_targets.empty()) {
      pull(options_.warp_target_weight, g, [&](double* d) { WarpTargetLoss(w, warp_targets, d); });
    }
    return value;
  };
  record.initial_loss = AdamSteps(
      loss, [&](long long step) { return AdamStepSize(options_, step); }, state, weights);
  record.iterations = options_.iterations_per_batch;
  record.final_loss = Loss(weights->data(), batch, nullptr);
  return record;
}

// Adam (Kingma and Ba): m = b1 m + (1 - b1) g, v = b2 v + (1 - b2) g^2,
// w -= rate m_hat / (sqrt(v_hat) + eps), its moments kept across batches;
// with weight decay (AdamW) the layers' matrices also W -= rate lambda W,
// from the weights the gradient was taken at.
double OneFitTrainer::AdamSteps(const std::function<double(const double*, double*)>& loss,
                                const std::function<double(long long)>& rate_at, AdamState* state,
                                std::vector<double>* weights) {
  constexpr double kBeta1 = 0.9, kBeta2 = 0.999, kEpsilon = 1e-8;
  const size_t n = weights->size();
  if (state->m.size() != n) {
    state->m.assign(n, 0.0);
    state->v.assign(n, 0.0);
  }
  std::vector<double> gradient(n);
  const std::vector<std::pair<int, int>> decayed = network_.WeightMatrixRanges();
  double initial = 0.0;
  for (int k = 0; k < options_.iterations_per_batch; ++k) {
    const double value = loss(weights->data(), gradient.data());
    if (k == 0) initial = value;
    ++state->steps;
    const double c1 = 1.0 - std::pow(kBeta1, state->steps), c2 = 1.0 - std::pow(kBeta2, state->steps);
    const double rate = rate_at(state->steps);
    if (options_.weight_decay > 0.0) {
      const double shrink = 1.0 - rate * options_.weight_decay;
      for (const auto& [offset, size] : decayed) {
        for (int i = offset; i < offset + size; ++i) (*weights)[i] *= shrink;
      }
    }
    for (size_t i = 0; i < n; ++i) {
      state->m[i] = kBeta1 * state->m[i] + (1.0 - kBeta1) * gradient[i];
      state->v[i] = kBeta2 * state->v[i] + (1.0 - kBeta2) * gradient[i] * gradient[i];
      (*weights)[i] -= rate * (state->m[i] / c1) / (std::sqrt(state->v[i] / c2) + kEpsilon);
    }
  }
  return initial;
}

void OneFitTrainer::SetValidationClip(OneFitTrainingClip clip) {
  if (clip.poses.empty())
    throw std::invalid_argument("OneFitTrainer: validation clip '" + clip.name + "' has no frame");
  clips_.resize(num_training_clips_);  // a second call replaces the first
  clip_body_.resize(num_training_clips_);
  clips_.push_back(std::move(clip));
  clip_body_.push_back(0);
  validation_clip_ = num_training_clips_;
}

int ValidationFrame(int i, int count, int clip_frames) {
  // The middle of the i-th of `count` equal spans: a clip's calm opening
  // frames alone would pick checkpoints on its easiest poses.
  return static_cast<int>((2 * static_cast<long>(i) + 1) * clip_frames / (2 * static_cast<long>(count)));
}

double OneFitTrainer::CollisionWeightAt(int batch) const {
  const double final_weight = options_.drape.physics.weights.collision;
  if (options_.collision_start < 0.0) return final_weight;
  const double t = static_cast<double>(batch) / std::max(options_.num_batches, 1);
  const auto [begin, end] = options_.collision_ramp;
  const double along = t <= begin ? 0.0 : t >= end ? 1.0 : (t - begin) / (end - begin);
  return options_.collision_start + along * (final_weight - options_.collision_start);
}

void OneFitTrainer::SetCollisionWeight(double weight) {
  for (const std::unique_ptr<GarmentData>& g : garments_) {
    for (const std::unique_ptr<DrapeSolver>& solver : g->solvers) solver->SetCollisionWeight(weight);
  }
}

void OneFitTrainer::ValidationDrape(const double* weights, int garment, int clip, int frames, double* inside_percent,
                                    double* edge_strain_percent, double* loss) {
  DrapeSolver& solver = *garments_.at(garment)->solvers.front();
  const OneFitTrainingClip& c = clips_.at(clip);
  const ClothRest rest = PrepareClothRest(solver.rest_garment());
  const int count = std::min(frames, static_cast<int>(c.poses.size()));
  double inside = 0.0, strain = 0.0;
  for (int i = 0; i < count; ++i) {
    const int f = ValidationFrame(i, count, static_cast<int>(c.poses.size()));
    solver.Pose(c.poses[f]);
    const Eigen::Matrix3Xd x = solver.PositionsOf(Predict(weights, garment, clip, f));
    const Eigen::VectorXd d = solver.SignedDistances(x);
    inside += 100.0 * (d.array() < 0.0).count() / static_cast<double>(d.size()) / count;
    strain += MeasureCloth(rest, x).edge_strain_percent / count;
  }
  *inside_percent = inside;
  *edge_strain_percent = strain;
  if (loss != nullptr) {
    // The loss's own collision weight, whatever the batch's.
    const double batch_weight = solver.collision_weight();
    solver.SetCollisionWeight(options_.drape.physics.weights.collision);
    double sum = 0.0;
    for (int i = 0; i < count; ++i) {
      const int f = ValidationFrame(i, count, static_cast<int>(c.poses.size()));
      sum += SampleLoss(weights, weights, {garment, clip, f}, 0, nullptr, options_.kext_final_epoch);
    }
    solver.SetCollisionWeight(batch_weight);
    *loss = sum / count;
  }
}

namespace {

// avg += (w - avg) / n: an exponential average over about n batches.
void UpdateAverage(const std::vector<double>& weights, int n, std::vector<double>* average) {
  const double share = 1.0 / n;
  for (size_t i = 0; i < weights.size(); ++i) (*average)[i] += share * (weights[i] - (*average)[i]);
}

}  // namespace

OneFitSample OneFitTrainer::DrawSample(std::mt19937_64* rng) const {
  OneFitSample s;
  s.garment = std::uniform_int_distribution<int>(0, static_cast<int>(garments_.size()) - 1)(*rng);
  const std::vector<int>& clips = body_clips_[garments_[s.garment]->body];
  s.clip = clips[std::uniform_int_distribution<int>(0, static_cast<int>(clips.size()) - 1)(*rng)];
  s.frame = std::uniform_int_distribution<int>(0, static_cast<int>(clips_[s.clip].poses.size()) - 1)(*rng);
  return s;
}

OneFitTrainingSummary OneFitTrainer::Train(std::vector<double>* weights, int first_batch, const BatchCallback& on_batch,
                                           OneFitAdamState* adam_state) {
  const auto start = Clock::now();
  if (static_cast<int>(weights->size()) != num_parameters()) {
    throw std::invalid_argument("OneFitTrainer::Train: " + std::to_string(weights->size()) +
                                " weights, the network has " + std::to_string(num_parameters()));
  }
  if (options_.warp_target_weight > 0.0 && network_.warp_order() < 0) {
    throw std::invalid_argument("OneFitTrainer::Train: the warp target needs a network with a warp head");
  }
  OneFitTrainingSummary summary;
  std::mt19937_64 rng(options_.seed);
  std::vector<OneFitSample> batch(options_.batch_size);
  std::vector<double> best = *weights;
  AdamState local_adam;
  AdamState& adam = adam_state != nullptr ? *adam_state : local_adam;
  AdamState adam_before;
  // The average starts at the weights the run starts from (a resumed run's
  // comes with Adam's moments).
  const bool averaging = options_.average_batches > 0;
  if (averaging && adam.average.size() != weights->size()) adam.average = *weights;
  if (!averaging) adam.average.clear();
  const std::vector<double>& validated = averaging ? adam.average : *weights;
  for (int b = 0; b < options_.num_batches; ++b) {
    for (OneFitSample& s : batch) s = DrawSample(&rng);
    if (b < first_batch) continue;
    epoch_ = options_.kext_final_epoch * b / options_.num_batches;
    SetCollisionWeight(CollisionWeightAt(b));
    adam_before = adam;
    OneFitBatchSummary record = options_.optimizer == OneFitOptimizer::kAdam ? AdamBatch(batch, b, &adam, weights)
                                                                             : LbfgsBatch(batch, b, weights);
    // Every process sees the same losses, so all undo the same batches.
    if (record.final_loss > kSpikeRatio * record.initial_loss) {
      record.undone = true;
      ++summary.undone_batches;
      *weights = best;
      adam = adam_before;
    }
    summary.batches.push_back(record);
    const bool finite = std::all_of(weights->begin(), weights->end(), [](double w) { return std::isfinite(w); });
    if (!finite || !std::isfinite(record.final_loss)) {
      *weights = best;
      summary.batches.back().time_s = Seconds(start);
      summary.termination_type = TerminationType::kFailure;
      summary.message = "batch " + std::to_string(b) + " left non-finite weights; the last good ones are kept";
      break;
    }
    if (averaging) UpdateAverage(*weights, options_.average_batches, &adam.average);
    if (options_.validation_every > 0 && (b + 1) % options_.validation_every == 0 &&
        options_.distribution.process == 0) {
      OneFitBatchSummary& record_back = summary.batches.back();
      ValidationDrape(validated.data(), 0, validation_clip_, options_.validation_frames,
                      &record_back.validation_inside_percent, &record_back.validation_edge_strain_percent,
                      &record_back.validation_loss);
    }
    summary.batches.back().time_s = Seconds(start);
    best = *weights;
    if (on_batch) on_batch(summary.batches.back(), *weights, validated);
  }
  SetCollisionWeight(options_.drape.physics.weights.collision);
  if (averaging) *weights = adam.average;
  if (summary.termination_type != TerminationType::kFailure) {
    summary.termination_type = TerminationType::kNoConvergence;
    summary.message = "the batch budget ran out (training runs a fixed number of batches)";
  }
  summary.total_time_s = Seconds(start);
  return summary;
}

}  // namespace polyfit
