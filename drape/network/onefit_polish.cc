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

// H_p := D^T H_p D in place, D = dp/dy block-diagonal per patch (stride
// by stride). D_p^T's columns come from the gradient's chain
// (ChainPatchParameterGradient computes D^T g), fed one unit vector per
// parameter, at every patch at once: the bounds' derivatives live in one
// place.
void ChainGaussNewton(const PatchOutputMap& map, const Eigen::MatrixXd& outputs, int num_coefficients,
                      Eigen::MatrixXd* h) {
  const Eigen::Index stride = outputs.rows(), num_patches = outputs.cols();
  std::vector<Eigen::MatrixXd> d_t(num_patches, Eigen::MatrixXd(stride, stride));  // D_p^T
  std::vector<double> unit(stride * num_patches);
  for (Eigen::Index j = 0; j < stride; ++j) {
    for (Eigen::Index p = 0; p < num_patches; ++p) {
      for (Eigen::Index c = 0; c < stride; ++c) unit[p * stride + c] = c == j ? 1.0 : 0.0;
    }
    const Eigen::MatrixXd column = ChainPatchParameterGradient(map, outputs, num_coefficients, unit);
    for (Eigen::Index p = 0; p < num_patches; ++p) d_t[p].col(j) = column.col(p);
  }
  Eigen::MatrixXd rows;
  for (Eigen::Index p = 0; p < num_patches; ++p) {
    rows.noalias() = d_t[p] * h->middleRows(p * stride, stride);
    h->middleRows(p * stride, stride) = rows;
  }
  Eigen::MatrixXd columns;
  for (Eigen::Index p = 0; p < num_patches; ++p) {
    columns.noalias() = h->middleCols(p * stride, stride) * d_t[p].transpose();
    h->middleCols(p * stride, stride) = columns;
  }
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
                                        PolishScratch* scratch, Eigen::MatrixXd* gauss_newton,
                                        Eigen::VectorXd* gradient) {
  GarmentData& g = *garments_[sample.garment];
  Eigen::MatrixXd outputs;
  OneFitNetwork::Cache cache;
  PrepareSample(weights, weights, sample, thread, epoch_, &outputs, &cache);
  const int k = network_.num_coefficients();
  const std::vector<double> params = PatchParametersFromOutputs(g.map, outputs, k);
  std::vector<double> d_params;
  Eigen::MatrixXd& h_y = scratch->h_y;
  const double energy = g.solvers[thread]->EvaluateGaussNewton(params, &d_params, &h_y);
  ChainGaussNewton(g.map, outputs, k, &h_y);
  const Eigen::MatrixXd g_y = ChainPatchParameterGradient(g.map, outputs, k, d_params);  // O by P
  // h~ (I + 1 by P).
  const Eigen::MatrixXd& last_input = cache.decoder.inputs.back();
  const Eigen::Index width = last_input.rows() + 1, num_patches = last_input.cols(), o_size = outputs.rows();
  const Eigen::Index n = o_size * num_patches;
  Eigen::MatrixXd h(width, num_patches);
  h.topRows(width - 1) = last_input;
  h.row(width - 1).setOnes();
  Eigen::Map<Eigen::MatrixXd>(gradient->data(), o_size, width) += g_y * h.transpose();
  // Blocks are summed output-major, (o, i) at o width + i: contiguous
  // products; OutputLayerGaussNewton reorders the sum once.
  Eigen::MatrixXd& by_patch = scratch->by_patch;
  by_patch.resize(num_patches, width);
  for (Eigen::Index o2 = 0; o2 < o_size; ++o2) {
    // Output o' of every patch: columns o', o' + O, ... of H_y.
    const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>> columns(h_y.data() + o2 * n, n, num_patches,
                                                                             Eigen::OuterStride<>(o_size * n));
    scratch->by_output.noalias() = columns * h.transpose();  // n by width
    for (Eigen::Index o = 0; o < o_size; ++o) {
      for (Eigen::Index p = 0; p < num_patches; ++p) by_patch.row(p) = scratch->by_output.row(p * o_size + o);
      gauss_newton->block(o * width, o2 * width, width, width).noalias() += h * by_patch;
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
  std::vector<PolishScratch> scratch(threads);
  std::vector<Eigen::VectorXd> gradients(threads, Eigen::VectorXd::Zero(t));
  std::vector<double> energies(samples.size(), 0.0);
  ParallelFor(
      threads, threads,
      [&](int, int thread) {
        for (size_t k = thread; k < mine.size(); k += threads) {
          energies[mine[k]] = SampleGaussNewton(aligned.data(), samples[mine[k]], thread, &scratch[thread],
                                                &blocks[thread], &gradients[thread]);
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
  // Output-major (o width + i) to the weights' order (o + O i).
  const Eigen::Index o_size = network_.num_outputs(), width = t / o_size;
  std::vector<Eigen::Index> order(t);
  for (Eigen::Index o = 0; o < o_size; ++o) {
    for (Eigen::Index i = 0; i < width; ++i) order[o * width + i] = o + o_size * i;
  }
  gauss_newton->resize(t, t);
  for (int c = 0; c < t; ++c) {
    for (int r = 0; r < t; ++r) (*gauss_newton)(order[r], order[c]) = h(r, c);
  }
  return sums[0];
}

OneFitPolishSummary OneFitTrainer::PolishOutputLayer(std::vector<double>* weights, const PolishCallback& on_step) {
  const auto start = Clock::now();
  if (network_.feedback()) {
    throw std::invalid_argument("OneFitTrainer::PolishOutputLayer: the feedback decoder reads the decoder's outputs");
  }
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
    // Cholesky (blocked; Eigen's LDLT is not); LDLT where rounding leaves
    // the damped matrix short of positive definite.
    const Eigen::LLT<Eigen::MatrixXd> llt(damped);
    const Eigen::VectorXd step =
        llt.info() == Eigen::Success ? Eigen::VectorXd(llt.solve(-g)) : Eigen::VectorXd(damped.ldlt().solve(-g));
    OneFitPolishStep record;
    record.damping = damping;
    if (step.allFinite()) {
      for (int i = 0; i < t; ++i) candidate[offset + i] = (*weights)[offset + i] + step[i];
      // The loss the Gauss-Newton model describes: the frames before
      // predicted by the current weights, held as data as in training.
      record.loss = LossWithHistory(candidate.data(), weights->data(), samples, nullptr);
    } else {
      record.loss = std::numeric_limits<double>::infinity();
    }
    record.accepted = std::isfinite(record.loss) && record.loss < loss;
    if (record.accepted) {
      *weights = candidate;
      damping = std::max(damping / 3.0, 1e-9);
      // The frames before follow the new weights: the next model starts
      // from the loss with them.
      loss = it + 1 < o.iterations ? OutputLayerGaussNewton(weights->data(), samples, &h, &g)
                                   : Loss(weights->data(), samples, nullptr);
    } else {
      candidate = *weights;
      damping *= 4.0;
    }
    record.time_s = Seconds(start);
    summary.steps.push_back(record);
    if (on_step) on_step(it + 1, record);
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
