// The second-order polish of OneFit's network (OneFitPolishOptions).
//
// With h_k the decoder's last hidden activation at patch k (width I) and
// h~_k = [h_k; 1], the output layer gives y_k = Theta h~_k, Theta = [W b]
// (O by I + 1, its weights' layout column-major). A sample's residuals r
// depend on the patch parameters p = f(y) (the output bounds), so
//   J_Theta = J_p D K,   D = dp/dy (per patch),   K[(k, o), (o', i)] = delta_oo' h~_k[i]
// and its Gauss-Newton blocks are
//   H_Theta[(o, i), (o', i')] = sum_k,l H_y[(k, o), (l, o')] h~_k[i] h~_l[i'],
//   H_y = D^T (J_p^T J_p) D,   g_Theta[(o, i)] = sum_k g_y[(k, o)] h~_k[i].
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <Eigen/Cholesky>

#include "drape/network/onefit_trainer.h"
#include "drape/network/onefit_trainer_garment.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {
namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

using StridedMap = Eigen::Map<Eigen::MatrixXd, 0, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>>;

// H_y = D^T H_p D, D the output bounds' Jacobian, applied as the gradient's
// chain (ChainPatchParameterGradient computes D^T g) to each column of H_p
// and then of (D^T H_p)^T: the bounds' derivatives live in one place.
Eigen::MatrixXd ChainGaussNewton(const std::vector<double>& rest, const std::vector<Eigen::Matrix3d>& frames,
                                 const Eigen::MatrixXd& outputs, int num_coefficients, const Eigen::MatrixXd& h_p) {
  const Eigen::Index n = h_p.rows();
  Eigen::MatrixXd half(n, n), h_y(n, n);
  std::vector<double> column(n);
  for (int pass = 0; pass < 2; ++pass) {
    const Eigen::MatrixXd& in = pass == 0 ? h_p : half;
    Eigen::MatrixXd& out = pass == 0 ? half : h_y;
    for (Eigen::Index c = 0; c < n; ++c) {
      // (D^T H_p)^T's columns are D^T H_p's rows.
      for (Eigen::Index r = 0; r < n; ++r) column[r] = pass == 0 ? in(r, c) : in(c, r);
      const Eigen::MatrixXd chained = ChainPatchParameterGradient(rest, frames, outputs, num_coefficients, column);
      out.col(c) = Eigen::Map<const Eigen::VectorXd>(chained.data(), n);
    }
  }
  return h_y;
}

}  // namespace

std::string OneFitPolishSummary::BriefReport() const {
  char line[320];
  int accepted = 0;
  for (const OneFitPolishStep& s : steps) accepted += s.accepted ? 1 : 0;
  std::snprintf(line, sizeof(line),
                "polish %s: %zu steps (%d kept), loss %.5g -> %.5g J; validation epsilon_c %.2f -> %.2f%%, "
                "epsilon_e %.2f -> %.2f%%, loss %.5g -> %.5g J; %.1f s",
                TerminationTypeToString(termination_type), steps.size(), accepted, initial_loss, final_loss,
                validation_inside_before, validation_inside_after, validation_strain_before, validation_strain_after,
                validation_loss_before, validation_loss_after, total_time_s);
  std::string report = line;
  if (!message.empty()) report += " (" + message + ")";
  return report;
}

int OneFitTrainer::output_layer_offset() const {
  const Mlp& d = network_.decoder();
  return network_.decoder_offset() + d.weight_offset(d.num_layers() - 1);
}

int OneFitTrainer::num_output_layer_parameters() const {
  const Mlp& d = network_.decoder();
  return d.output_size() * (d.sizes()[d.num_layers() - 1] + 1);
}

double OneFitTrainer::SampleGaussNewton(const double* weights, const OneFitSample& sample, int thread,
                                        Eigen::MatrixXd* gauss_newton, Eigen::VectorXd* gradient) {
  GarmentData& g = *garments_[sample.garment];
  Eigen::MatrixXd outputs;
  OneFitNetwork::Cache cache;
  PrepareSample(weights, sample, thread, epoch_, &outputs, &cache);
  const int k = network_.num_coefficients();
  const std::vector<double> params = PatchParametersFromOutputs(g.rest, g.frames, outputs, k);
  std::vector<double> d_params;
  Eigen::MatrixXd h_p;
  const double energy = g.solvers[thread]->EvaluateGaussNewton(params, &d_params, &h_p);
  const Eigen::MatrixXd h_y = ChainGaussNewton(g.rest, g.frames, outputs, k, h_p);
  const Eigen::MatrixXd g_y = ChainPatchParameterGradient(g.rest, g.frames, outputs, k, d_params);  // O by P
  // h~ (I + 1 by P).
  const Eigen::MatrixXd& last_input = cache.decoder.inputs.back();
  const Eigen::Index width = last_input.rows(), num_patches = last_input.cols(), o_size = outputs.rows();
  const Eigen::Index n = o_size * num_patches, t = o_size * (width + 1);
  Eigen::MatrixXd h(width + 1, num_patches);
  h.topRows(width) = last_input;
  h.row(width).setOnes();
  Eigen::Map<Eigen::MatrixXd>(gradient->data(), o_size, width + 1) += g_y * h.transpose();
  // Output o' of every patch: columns o', o' + O, ... of H_y.
  Eigen::MatrixXd by_output(n, width + 1);
  for (Eigen::Index o2 = 0; o2 < o_size; ++o2) {
    const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>> columns(h_y.data() + o2 * n, n, num_patches,
                                                                             Eigen::OuterStride<>(o_size * n));
    by_output.noalias() = columns * h.transpose();
    for (Eigen::Index o = 0; o < o_size; ++o) {
      const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>> rows(
          by_output.data() + o, num_patches, width + 1, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>(n, o_size));
      // Theta's (o, i) is weight o + O i.
      StridedMap block(gauss_newton->data() + o + o2 * t, width + 1, width + 1,
                       Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>(o_size * t, o_size));
      block.noalias() += h * rows;
    }
  }
  return energy;
}

double OneFitTrainer::OutputLayerGaussNewton(const double* weights, const std::vector<OneFitSample>& samples,
                                             Eigen::MatrixXd* gauss_newton, Eigen::VectorXd* gradient) {
  const OneFitDistribution& d = options_.distribution;
  std::vector<size_t> mine;
  for (size_t i = d.process; i < samples.size(); i += d.num_processes) mine.push_back(i);
  const int threads = std::max(1, std::min<int>(options_.num_threads, static_cast<int>(mine.size())));
  const int t = num_output_layer_parameters();
  const Eigen::VectorXd aligned = Eigen::Map<const Eigen::VectorXd>(weights, num_parameters());
  std::vector<Eigen::MatrixXd> blocks(threads, Eigen::MatrixXd::Zero(t, t));
  std::vector<Eigen::VectorXd> gradients(threads, Eigen::VectorXd::Zero(t));
  std::vector<double> energies(samples.size(), 0.0);
  ParallelFor(
      threads, threads,
      [&](int, int thread) {
        for (size_t k = thread; k < mine.size(); k += threads) {
          energies[mine[k]] =
              SampleGaussNewton(aligned.data(), samples[mine[k]], thread, &blocks[thread], &gradients[thread]);
        }
      },
      1);
  const double scale = 1.0 / static_cast<double>(samples.size());
  // [loss, gradient, blocks]: one reduction over the processes.
  std::vector<double> sums(1 + t + static_cast<size_t>(t) * t, 0.0);
  for (size_t i : mine) sums[0] += scale * energies[i];
  Eigen::Map<Eigen::VectorXd> g(sums.data() + 1, t);
  Eigen::Map<Eigen::MatrixXd> h(sums.data() + 1 + t, t, t);
  for (int thread = 0; thread < threads; ++thread) {
    g += scale * gradients[thread];
    h += scale * blocks[thread];
  }
  if (d.num_processes > 1) d.all_reduce(sums.data(), static_cast<int>(sums.size()));
  *gradient = g;
  *gauss_newton = h;
  return sums[0];
}

OneFitPolishSummary OneFitTrainer::PolishOutputLayer(std::vector<double>* weights) {
  const auto start = Clock::now();
  const OneFitPolishOptions& o = options_.polish;
  OneFitPolishSummary summary;
  // Its own seeded draw, so that the polish's samples do not depend on how
  // long training ran.
  std::mt19937_64 rng(options_.seed + 0x9e3779b97f4a7c15ULL);
  std::vector<OneFitSample> samples(o.samples);
  for (OneFitSample& s : samples) s = DrawSample(&rng);
  epoch_ = options_.kext_final_epoch;
  const bool validate = options_.distribution.process == 0 && options_.validation_frames > 0;
  if (validate) {
    ValidationDrape(weights->data(), 0, validation_clip_, options_.validation_frames, &summary.validation_inside_before,
                    &summary.validation_strain_before, &summary.validation_loss_before);
  }
  const int offset = output_layer_offset(), t = num_output_layer_parameters();
  Eigen::MatrixXd h;
  Eigen::VectorXd g;
  double loss = OutputLayerGaussNewton(weights->data(), samples, &h, &g);
  summary.initial_loss = loss;
  double damping = o.initial_damping;
  std::vector<double> candidate = *weights;
  for (int it = 0; it < o.iterations; ++it) {
    // Marquardt's scaling, floored so that a weight no sample moves (a dead
    // unit's) still gets a finite step.
    Eigen::MatrixXd damped = h;
    const double floor = 1e-12 * std::max(1e-300, h.diagonal().maxCoeff());
    damped.diagonal() += damping * h.diagonal().cwiseMax(floor);
    const Eigen::VectorXd step = damped.ldlt().solve(-g);
    OneFitPolishStep record;
    record.damping = damping;
    if (step.allFinite()) {
      for (int i = 0; i < t; ++i) candidate[offset + i] = (*weights)[offset + i] + step[i];
      record.loss = Loss(candidate.data(), samples, nullptr);
    } else {
      record.loss = std::numeric_limits<double>::infinity();
    }
    record.accepted = std::isfinite(record.loss) && record.loss < loss;
    if (record.accepted) {
      *weights = candidate;
      damping = std::max(damping / 3.0, 1e-9);
      if (it + 1 < o.iterations) loss = OutputLayerGaussNewton(weights->data(), samples, &h, &g);
      loss = record.loss;
    } else {
      candidate = *weights;
      damping *= 4.0;
    }
    record.time_s = Seconds(start);
    summary.steps.push_back(record);
  }
  summary.final_loss = loss;
  if (validate) {
    ValidationDrape(weights->data(), 0, validation_clip_, options_.validation_frames, &summary.validation_inside_after,
                    &summary.validation_strain_after, &summary.validation_loss_after);
  }
  summary.termination_type = TerminationType::kNoConvergence;
  summary.message = "the iteration budget ran out";
  summary.total_time_s = Seconds(start);
  return summary;
}

}  // namespace polyfit
