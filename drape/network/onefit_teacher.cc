// The warm start of OneFit's network from the reference drape
// (OneFitTeacherOptions): reference drapes on some training clips per
// garment, then Adam on the network's distance to their positions.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>

#include "drape/motion/blend_pose.h"
#include "drape/network/onefit_trainer.h"
#include "drape/network/onefit_trainer_garment.h"
#include "drape/network/output_proximity.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {
namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// DistanceTo's E = 1/2 mean a |d|^2 (m^2) as the root mean square (mm).
double RmsMillimetres(double distance) { return 1e3 * std::sqrt(2.0 * std::max(distance, 0.0)); }

}  // namespace

std::string OneFitTeacherSummary::BriefReport() const {
  char line[256];
  const double first = batches.empty() ? 0.0 : batches.front().initial_rms_mm;
  const double last = batches.empty() ? 0.0 : batches.back().final_rms_mm;
  std::snprintf(line, sizeof(line),
                "teacher: %d reference frames (%.1f s), %zu batches, distance %.2f -> %.2f mm, %.1f s", frames,
                reference_time_s, batches.size(), first, last, total_time_s);
  std::string report = line;
  if (std::isfinite(validation_inside_percent)) {
    std::snprintf(line, sizeof(line), "; validation after it: epsilon_c %.2f%% epsilon_e %.2f%% loss %.5g J",
                  validation_inside_percent, validation_edge_strain_percent, validation_loss);
    report += line;
  }
  return report;
}

OneFitTeacherDrape OneFitTrainer::ReferenceDrape(int garment, int clip, int thread, std::vector<TeacherFrame>* out) {
  DrapeSolver& solver = *garments_[garment]->solvers[thread];
  const OneFitTrainingClip& c = clips_[clip];
  const Skeleton& skeleton = skeletons_[clip_body_[clip]];
  const OneFitTeacherOptions& o = options_.teacher;
  // From rest: the training loss's evaluations leave the solver's own
  // state as they found it, but an earlier clip's drape does not.
  solver.Pose(std::vector<Eigen::Isometry3d>(skeleton.num_joints(), Eigen::Isometry3d::Identity()));
  const std::vector<double> rest = solver.RestPatchParameters();
  solver.Adopt(rest);
  solver.Adopt(rest);
  int step = 0;
  for (int k = 0; k < o.lead_in; ++k, ++step) {
    solver.Step(BlendFromRest(skeleton, c.poses.front(), (k + 1.0) / (o.lead_in + 1.0)), step);
  }
  const int frames = o.max_frames > 0 ? std::min<int>(o.max_frames, c.poses.size()) : static_cast<int>(c.poses.size());
  OneFitTeacherDrape record{garments_[garment]->name, c.name};
  const ClothRest cloth = PrepareClothRest(solver.rest_garment());
  for (int f = 0; f < frames; ++f, ++step) {
    if (!solver.Step(c.poses[f], step).IsSolutionUsable()) continue;
    const Eigen::Matrix3Xd x = solver.positions();
    const Eigen::VectorXd d = solver.SignedDistances(x);
    const double inside = 100.0 * (d.array() < 0.0).count() / static_cast<double>(d.size());
    const double strain = MeasureCloth(cloth, x).edge_strain_percent;
    if (inside > o.max_inside_percent || strain > o.max_edge_strain_percent) {
      ++record.dropped;
      continue;
    }
    record.inside_percent += inside;
    record.edge_strain_percent += strain;
    // PositionsAt leaves the body posed: the solver's next Step poses both.
    const Eigen::Matrix3Xd skinned = solver.PositionsAt(rest, c.poses[f]);
    record.from_skinning_mm += 1e3 * std::sqrt((x - skinned).colwise().squaredNorm().mean());
    ++record.frames;
    out->push_back({garment, clip, f, x});
  }
  if (record.frames > 0) {
    record.inside_percent /= record.frames;
    record.edge_strain_percent /= record.frames;
    record.from_skinning_mm /= record.frames;
  }
  return record;
}

double OneFitTrainer::TeacherSampleLoss(const double* weights, const TeacherFrame& frame, int thread,
                                        double* gradient, bool warps_only, bool translations) {
  const GarmentData& g = *garments_[frame.garment];
  DrapeSolver& solver = *g.solvers[thread];
  Eigen::MatrixXd outputs;
  OneFitNetwork::Cache cache;
  std::vector<OutputProximity> at;
  Outputs(weights, frame.garment, frame.clip, frame.frame, thread, &outputs, gradient != nullptr ? &cache : nullptr,
          &at);
  const std::vector<double> params = PatchParametersFromOutputs(g.map, outputs, network_.num_coefficients());
  solver.PositionsAt(params, clips_[frame.clip].poses[frame.frame]);  // poses the garment's skinning
  std::vector<double> d_params;
  const double distance = solver.DistanceTo(params, frame.target, gradient != nullptr ? &d_params : nullptr);
  if (gradient == nullptr) return distance;
  if (warps_only) {
    const int stride = solver.num_patch_parameters(), warp = network_.num_coefficients() + 4;
    const int t = network_.num_coefficients() + 1;  // T's first
    for (size_t i = 0; i < d_params.size(); ++i) {
      const int j = static_cast<int>(i) % stride;
      if (j < warp && !(translations && j >= t)) d_params[i] = 0.0;
    }
  }
  BackPropagate(weights, g, outputs, cache, at, d_params, gradient);
  return distance;
}

std::vector<OneFitTrainer::TeacherFrame> OneFitTrainer::WarpTargets(const double* weights,
                                                                    const std::vector<OneFitSample>& batch) {
  const Eigen::VectorXd aligned = Eigen::Map<const Eigen::VectorXd>(weights, num_parameters());
  std::vector<TeacherFrame> targets(batch.size());
  MeanOverSamples(
      static_cast<int>(batch.size()),
      [&](int i, int thread, double*) {
        const OneFitSample& s = batch[i];
        DrapeSolver& solver = *garments_[s.garment]->solvers[thread];
        solver.Pose(clips_[s.clip].poses[s.frame], epoch_);  // the body: the warps' collision term
        const std::vector<double> solved =
            solver.SolveWarps(PredictOn(aligned.data(), s.garment, s.clip, s.frame, thread),
                              options_.warp_target_sweeps, 2, options_.warp_target_translations);
        targets[i] = TeacherFrame{s.garment, s.clip, s.frame, solver.PositionsOf(solved)};
        return 0.0;
      },
      nullptr);
  return targets;
}

double OneFitTrainer::WarpTargetDistance(const double* weights, const std::vector<OneFitSample>& samples) {
  return WarpTargetLoss(weights, WarpTargets(weights, samples), nullptr);
}

double OneFitTrainer::WarpTargetLoss(const double* weights, const std::vector<TeacherFrame>& targets,
                                     double* gradient) {
  const Eigen::VectorXd aligned = Eigen::Map<const Eigen::VectorXd>(weights, num_parameters());
  return MeanOverSamples(
      static_cast<int>(targets.size()),
      [&](int i, int thread, double* g) {
        return TeacherSampleLoss(aligned.data(), targets[i], thread, g, true, options_.warp_target_translations);
      },
      gradient);
}

double OneFitTrainer::TeacherLoss(const double* weights, const std::vector<int>& frames, double* gradient) {
  const Eigen::VectorXd aligned = Eigen::Map<const Eigen::VectorXd>(weights, num_parameters());
  return MeanOverSamples(
      static_cast<int>(frames.size()),
      [&](int i, int thread, double* g) {
        return TeacherSampleLoss(aligned.data(), teacher_.at(frames[i]), thread, g);
      },
      gradient);
}

// The teacher's targets: per garment, o.clips of its body's clips (drawn
// from *rng), (garment, clip) pairs dealt to threads in a fixed pattern
// and their frames gathered in that order into teacher_.
void OneFitTrainer::RunReferenceDrapes(std::mt19937_64* rng, OneFitTeacherSummary* summary) {
  std::vector<std::pair<int, int>> jobs;
  for (int g = 0; g < static_cast<int>(garments_.size()); ++g) {
    std::vector<int> clips = body_clips_[garments_[g]->body];
    std::shuffle(clips.begin(), clips.end(), *rng);
    clips.resize(std::min<size_t>(clips.size(), options_.teacher.clips));
    for (int c : clips) jobs.emplace_back(g, c);
  }
  std::vector<std::vector<TeacherFrame>> drapes(jobs.size());
  summary->drapes.resize(jobs.size());
  const int threads = std::max(1, std::min<int>(options_.num_threads, static_cast<int>(jobs.size())));
  ParallelFor(
      threads, threads,
      [&](int, int t) {
        for (size_t j = t; j < jobs.size(); j += threads)
          summary->drapes[j] = ReferenceDrape(jobs[j].first, jobs[j].second, t, &drapes[j]);
      },
      1);
  teacher_.clear();
  for (auto& d : drapes) std::move(d.begin(), d.end(), std::back_inserter(teacher_));
  summary->frames = num_teacher_frames();
}

OneFitTeacherSummary OneFitTrainer::Teach(std::vector<double>* weights, const TeacherCallback& on_batch) {
  const auto start = Clock::now();
  const OneFitTeacherOptions& o = options_.teacher;
  OneFitTeacherSummary summary;
  if (o.clips == 0 || o.batches == 0) return summary;
  std::mt19937_64 rng(options_.seed ^ 0x7eac4e2u);
  RunReferenceDrapes(&rng, &summary);
  summary.reference_time_s = Seconds(start);
  if (teacher_.empty()) {
    summary.total_time_s = Seconds(start);
    return summary;
  }
  // Adam on the distance, its step scheduled over the teacher's batches
  // as training's is over its own.
  OneFitTrainerOptions schedule = options_;
  schedule.num_batches = o.batches;
  schedule.warmup_batches = std::min(options_.warmup_batches, o.batches / 4);
  AdamState adam;
  std::uniform_int_distribution<int> draw(0, num_teacher_frames() - 1);
  std::vector<int> batch(options_.batch_size);
  for (int b = 0; b < o.batches; ++b) {
    for (int& i : batch) i = draw(rng);
    OneFitTeacherBatch record;
    record.batch = b;
    record.initial_rms_mm =
        RmsMillimetres(AdamSteps([&](const double* w, double* g) { return TeacherLoss(w, batch, g); },
                                 [&](long long step) { return AdamStepSize(schedule, step); }, &adam, weights));
    record.final_rms_mm = RmsMillimetres(TeacherLoss(weights->data(), batch, nullptr));
    record.time_s = Seconds(start);
    summary.batches.push_back(record);
    if (on_batch) on_batch(record);
  }
  if (options_.validation_every > 0 && options_.distribution.process == 0) {
    ValidationDrape(weights->data(), 0, validation_clip_, options_.validation_frames,
                    &summary.validation_inside_percent, &summary.validation_edge_strain_percent,
                    &summary.validation_loss);
  }
  summary.total_time_s = Seconds(start);
  return summary;
}

}  // namespace polyfit
