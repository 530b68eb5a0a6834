#include "drape/network/onefit_network.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "drape/network/body_proximity.h"
#include "drape/network/onefit_features.h"
#include "polyfit/jet/jet_basis.h"

namespace polyfit {
namespace {

std::vector<int> Sizes(int input, const std::vector<int>& hidden, int output) {
  std::vector<int> sizes{input};
  sizes.insert(sizes.end(), hidden.begin(), hidden.end());
  sizes.push_back(output);
  return sizes;
}

}  // namespace

std::string OneFitNetworkOptions::Validate() const {
  if (patch_embedding < 1 || body_embedding < 1) return "embeddings must have at least one value";
  for (const std::vector<int>* hidden : {&patch_hidden, &body_hidden, &decoder_hidden}) {
    for (int n : *hidden) {
      if (n < 1) return "hidden layers must have at least one unit";
    }
  }
  if (!(initial_output_scale > 0.0)) return "initial_output_scale must be > 0";
  if (warp_order < -1 || warp_order > kMaxJetOrder)
    return "warp_order must be in [-1, " + std::to_string(kMaxJetOrder) + "]";
  if (body_proximity && !IsProximityLayout(proximity_probes)) {
    return "proximity_probes must be " + std::to_string(kProximityProbes) + " or " +
           std::to_string(kRimProximityProbes);
  }
  if (feedback && !body_proximity) return "feedback reads the body proximity: it needs body_proximity";
  if (feedback_passes < 1 || feedback_passes > kMaxFeedbackPasses) {
    return "feedback_passes must be in [1, " + std::to_string(kMaxFeedbackPasses) + "]";
  }
  for (int n : feedback_hidden) {
    if (n < 1) return "hidden layers must have at least one unit";
  }
  return {};
}

OneFitNetwork::OneFitNetwork(int patch_features, int body_features, int num_coefficients,
                             const OneFitNetworkOptions& options)
    : patch_encoder_(Sizes(patch_features, options.patch_hidden, options.patch_embedding)),
      body_encoder_(Sizes(body_features, options.body_hidden, options.body_embedding)),
      decoder_(Sizes(options.patch_embedding + options.body_embedding + (options.local_pose ? kLocalPoseSize : 0) +
                         (options.body_proximity ? ProximitySize(options.proximity_probes) : 0),
                     options.decoder_hidden, num_coefficients + 4 + 2 * NumJetCoefficients(options.warp_order))),
      num_coefficients_(num_coefficients),
      warp_order_(options.warp_order),
      local_size_(options.local_pose ? kLocalPoseSize : 0),
      proximity_size_(options.body_proximity ? ProximitySize(options.proximity_probes) : 0) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("OneFitNetworkOptions: " + problem);
  }
  if (options.feedback) {
    feedback_passes_ = options.feedback_passes;
    feedback_ = Mlp(Sizes(decoder_.input_size() + decoder_.output_size() + proximity_size_, options.feedback_hidden,
                          decoder_.output_size()));
  }
  Check();
}

OneFitNetwork::OneFitNetwork(Mlp patch_encoder, Mlp body_encoder, Mlp decoder, int num_coefficients, int warp_order,
                             int proximity_probes, Mlp feedback, int feedback_passes)
    : patch_encoder_(std::move(patch_encoder)),
      body_encoder_(std::move(body_encoder)),
      decoder_(std::move(decoder)),
      feedback_(std::move(feedback)),
      feedback_passes_(feedback_passes),
      num_coefficients_(num_coefficients),
      warp_order_(warp_order),
      proximity_size_(ProximitySize(proximity_probes)) {
  if (proximity_probes != 0 && !IsProximityLayout(proximity_probes)) {
    throw std::invalid_argument("OneFitNetwork: " + std::to_string(proximity_probes) + " proximity probes per patch");
  }
  local_size_ = decoder_.input_size() - patch_encoder_.output_size() - body_encoder_.output_size() - proximity_size_;
  Check();
}

int OneFitNetwork::proximity_probes() const { return proximity_size_ / kProximityValuesPerProbe; }

void OneFitNetwork::Initialize(std::uint64_t seed, double output_scale, double* weights) const {
  patch_encoder_.Initialize(seed, 1.0, weights);
  body_encoder_.Initialize(seed + 1, 1.0, weights + body_encoder_offset());
  decoder_.Initialize(seed + 2, output_scale, weights + decoder_offset());
  if (feedback()) feedback_.Initialize(seed + 3, output_scale, weights + feedback_offset());
}

std::vector<std::pair<int, int>> OneFitNetwork::WeightMatrixRanges() const {
  std::vector<std::pair<int, int>> ranges;
  const auto add = [&ranges](const Mlp& mlp, int offset) {
    for (int l = 0; l < mlp.num_layers(); ++l) {
      ranges.emplace_back(offset + mlp.weight_offset(l), mlp.sizes()[l + 1] * mlp.sizes()[l]);
    }
  };
  add(patch_encoder_, 0);
  add(body_encoder_, body_encoder_offset());
  add(decoder_, decoder_offset());
  if (feedback()) add(feedback_, feedback_offset());
  return ranges;
}

namespace {

// x_k of every patch (kLocalPoseSize by #patches), checked.
Eigen::MatrixXd LocalPose(const Eigen::VectorXd& body_features, const Eigen::MatrixXd* joint_weights,
                          Eigen::Index num_patches) {
  if (joint_weights == nullptr || joint_weights->cols() != num_patches) {
    throw std::invalid_argument("OneFitNetwork: a network with the local pose needs the patches' joint weights");
  }
  return LocalPoseFeatures(body_features, *joint_weights);
}

// p_k of every patch, checked.
const Eigen::MatrixXd& Proximity(const Eigen::MatrixXd* proximity, int size, Eigen::Index num_patches) {
  if (proximity == nullptr || proximity->rows() != size || proximity->cols() != num_patches) {
    throw std::invalid_argument("OneFitNetwork: a network with the body proximity needs every patch's");
  }
  return *proximity;
}

}  // namespace

void OneFitNetwork::Forward(const double* weights, const Eigen::MatrixXd& patch_features,
                            const Eigen::VectorXd& body_features, const Eigen::MatrixXd* joint_weights,
                            const Eigen::MatrixXd* proximity, Eigen::MatrixXd* outputs, Cache* cache) const {
  const Eigen::Index num_patches = patch_features.cols();
  Eigen::MatrixXd z_t, z_b;
  patch_encoder_.Forward(weights, patch_features, &z_t, cache != nullptr ? &cache->patch : nullptr);
  body_encoder_.Forward(weights + body_encoder_offset(), body_features, &z_b,
                        cache != nullptr ? &cache->body : nullptr);
  const Eigen::MatrixXd joint = AssembleDecoderInput(z_t, z_b, body_features, joint_weights, proximity);
  decoder_.Forward(weights + decoder_offset(), joint, outputs, cache != nullptr ? &cache->decoder : nullptr);
  if (cache != nullptr) cache->num_patches = static_cast<int>(num_patches);
}

Eigen::MatrixXd OneFitNetwork::AssembleDecoderInput(const Eigen::MatrixXd& z_t, const Eigen::MatrixXd& z_b,
                                                    const Eigen::VectorXd& body_features,
                                                    const Eigen::MatrixXd* joint_weights,
                                                    const Eigen::MatrixXd* proximity) const {
  const Eigen::Index num_patches = z_t.cols();
  Eigen::MatrixXd joint(decoder_.input_size(), num_patches);
  joint.topRows(z_t.rows()) = z_t;
  joint.middleRows(z_t.rows(), z_b.rows()) = z_b.col(0).replicate(1, num_patches);
  const Eigen::Index inputs = z_t.rows() + z_b.rows();
  if (local_size_ > 0) joint.middleRows(inputs, local_size_) = LocalPose(body_features, joint_weights, num_patches);
  if (proximity_size_ > 0) joint.bottomRows(proximity_size_) = Proximity(proximity, proximity_size_, num_patches);
  return joint;
}

void OneFitNetwork::Feedback(const double* weights, const Eigen::MatrixXd& decoder_input,
                             const Eigen::MatrixXd& outputs, const Eigen::MatrixXd& proximity, Eigen::MatrixXd* refined,
                             Cache* cache, int pass) const {
  if (!feedback()) throw std::invalid_argument("OneFitNetwork::Feedback: the network has no feedback decoder");
  const Eigen::Index num_patches = outputs.cols();
  if (decoder_input.rows() != decoder_.input_size() || decoder_input.cols() != num_patches ||
      outputs.rows() != num_outputs() || proximity.rows() != proximity_size_ || proximity.cols() != num_patches) {
    throw std::invalid_argument("OneFitNetwork::Feedback: inputs of the wrong size");
  }
  Eigen::MatrixXd input(feedback_.input_size(), num_patches);
  input << decoder_input, outputs, proximity;
  MlpCache* pass_cache = nullptr;
  if (cache != nullptr) {
    if (static_cast<int>(cache->feedback.size()) <= pass) cache->feedback.resize(pass + 1);
    pass_cache = &cache->feedback[pass];
  }
  feedback_.Forward(weights + feedback_offset(), input, refined, pass_cache);
  *refined += outputs;
}

void OneFitNetwork::FeedbackBackward(const double* weights, const Cache& cache, const Eigen::MatrixXd& d_refined,
                                     double* gradient, Eigen::MatrixXd* d_outputs, Eigen::MatrixXd* d_proximity,
                                     Eigen::MatrixXd* d_decoder_input, int pass) const {
  Eigen::MatrixXd d_input;
  feedback_.Backward(weights + feedback_offset(), cache.feedback.at(pass), d_refined, gradient + feedback_offset(),
                     &d_input);
  const int joint = decoder_.input_size(), out = num_outputs();
  *d_outputs = d_refined + d_input.middleRows(joint, out);
  *d_proximity = d_input.bottomRows(proximity_size_);
  if (d_decoder_input->size() == 0) {
    *d_decoder_input = d_input.topRows(joint);
  } else {
    *d_decoder_input += d_input.topRows(joint);
  }
}

void OneFitNetwork::Backward(const double* weights, const Cache& cache, const Eigen::MatrixXd& d_outputs,
                             double* gradient, const Eigen::MatrixXd* d_decoder_input) const {
  Eigen::MatrixXd d_joint;
  decoder_.Backward(weights + decoder_offset(), cache.decoder, d_outputs, gradient + decoder_offset(), &d_joint);
  if (d_decoder_input != nullptr) d_joint += *d_decoder_input;
  EncodersBackward(weights, cache, d_joint, gradient);
}

void OneFitNetwork::EncodersBackward(const double* weights, const Cache& cache, const Eigen::MatrixXd& d_joint,
                                     double* gradient) const {
  const int e_t = patch_encoder_.output_size();
  const Eigen::MatrixXd d_z_t = d_joint.topRows(e_t);
  // The local pose and the proximity are inputs: their rows carry no
  // gradient to the weights.
  const Eigen::MatrixXd d_z_b = d_joint.middleRows(e_t, body_encoder_.output_size()).rowwise().sum();
  patch_encoder_.Backward(weights, cache.patch, d_z_t, gradient);
  body_encoder_.Backward(weights + body_encoder_offset(), cache.body, d_z_b, gradient + body_encoder_offset());
}

namespace {

// An MLP's first layer split over its input [z_T; rest]: W_T z_T + b (its
// width by #patches), the part that depends on the garment only.
Eigen::MatrixXd FirstLayerGarmentHalf(const Mlp& mlp, const double* params, const Eigen::MatrixXd& z_t) {
  const int width = mlp.sizes()[1];
  const Eigen::Map<const Eigen::MatrixXd> w(params + mlp.weight_offset(0), width, mlp.input_size());
  const Eigen::Map<const Eigen::VectorXd> b(params + mlp.bias_offset(0), width);
  Eigen::MatrixXd half = w.leftCols(z_t.rows()) * z_t;
  half.colwise() += b;
  return half;
}

// The MLP's output from its first layer's pre-activation a: its layers
// 1.. (`tail`, an MLP of their own over the same weights' layout) after
// the activation, or a itself for a one-layer MLP.
template <typename T>
void FinishFromFirstLayer(const Mlp& mlp, const Mlp& tail, const T* params, MatrixX<T> a, MatrixX<T>* outputs) {
  if (mlp.num_layers() == 1) {
    *outputs = std::move(a);
    return;
  }
  const MatrixX<T> h = (a.array() > T(0)).select(a, T(mlp.leaky_slope()) * a);
  *outputs = tail.ForwardT<T>(params + mlp.weight_offset(1), h);
}

}  // namespace

Eigen::MatrixXd OneFitNetwork::GarmentHalf(const double* weights, const Eigen::MatrixXd& patch_features) const {
  Eigen::MatrixXd z_t;
  patch_encoder_.Forward(weights, patch_features, &z_t);
  return FirstLayerGarmentHalf(decoder_, weights + decoder_offset(), z_t);
}

template <typename T>
void OneFitNetwork::ForwardWithGarmentHalf(const T* weights, const MatrixX<T>& garment_half,
                                           const Eigen::VectorXd& body_features, const Eigen::MatrixXd* joint_weights,
                                           const Eigen::MatrixXd* proximity, MatrixX<T>* outputs,
                                           VectorX<T>* body_embedding, MatrixX<T>* patch_inputs) const {
  const MatrixX<T> z_b = body_encoder_.ForwardT<T>(weights + body_encoder_offset(), body_features.template cast<T>());
  if (body_embedding != nullptr) *body_embedding = z_b.col(0);
  const T* d = weights + decoder_offset();
  const int width = decoder_.sizes()[1], e_t = patch_encoder_.output_size();
  const Eigen::Index n = garment_half.cols();
  const Eigen::Map<const MatrixX<T>> w(d + decoder_.weight_offset(0), width, decoder_.input_size());
  MatrixX<T> a = garment_half;
  a.colwise() += w.middleCols(e_t, z_b.rows()) * z_b.col(0);
  // x_k and p_k stacked: their weights' columns are adjacent, so one
  // product (a is read and written once, not once per input).
  MatrixX<T> local_inputs(local_size_ + proximity_size_, n);
  if (local_size_ > 0) {
    local_inputs.topRows(local_size_) = LocalPose(body_features, joint_weights, n).template cast<T>();
  }
  if (proximity_size_ > 0) {
    local_inputs.bottomRows(proximity_size_) = Proximity(proximity, proximity_size_, n).template cast<T>();
  }
  if (local_inputs.rows() > 0) a.noalias() += w.rightCols(local_inputs.rows()) * local_inputs;
  if (patch_inputs != nullptr) *patch_inputs = std::move(local_inputs);
  FinishFromFirstLayer<T>(decoder_, decoder_tail_, d, std::move(a), outputs);
}

template void OneFitNetwork::ForwardWithGarmentHalf<double>(const double*, const Eigen::MatrixXd&,
                                                            const Eigen::VectorXd&, const Eigen::MatrixXd*,
                                                            const Eigen::MatrixXd*, Eigen::MatrixXd*, Eigen::VectorXd*,
                                                            Eigen::MatrixXd*) const;
template void OneFitNetwork::ForwardWithGarmentHalf<float>(const float*, const Eigen::MatrixXf&, const Eigen::VectorXd&,
                                                           const Eigen::MatrixXd*, const Eigen::MatrixXd*,
                                                           Eigen::MatrixXf*, Eigen::VectorXf*, Eigen::MatrixXf*) const;

Eigen::MatrixXd OneFitNetwork::FeedbackGarmentHalf(const double* weights, const Eigen::MatrixXd& patch_features) const {
  if (!feedback()) throw std::invalid_argument("OneFitNetwork: the network has no feedback decoder");
  Eigen::MatrixXd z_t;
  patch_encoder_.Forward(weights, patch_features, &z_t);
  return FirstLayerGarmentHalf(feedback_, weights + feedback_offset(), z_t);
}

template <typename T>
void OneFitNetwork::FeedbackWithGarmentHalf(const T* weights, const MatrixX<T>& feedback_half,
                                            const VectorX<T>& body_embedding, const MatrixX<T>& patch_inputs,
                                            const MatrixX<T>& outputs, const Eigen::MatrixXd& output_proximity,
                                            MatrixX<T>* refined) const {
  const T* f = weights + feedback_offset();
  const int width = feedback_.sizes()[1], e_t = patch_encoder_.output_size();
  const int e_b = static_cast<int>(body_embedding.size());
  const Eigen::Index n = feedback_half.cols();
  if (!feedback() || e_b != body_encoder_.output_size() || patch_inputs.rows() != local_size_ + proximity_size_ ||
      patch_inputs.cols() != n || outputs.rows() != num_outputs() || outputs.cols() != n ||
      output_proximity.rows() != proximity_size_ || output_proximity.cols() != n) {
    throw std::invalid_argument("OneFitNetwork::FeedbackWithGarmentHalf: inputs of the wrong size");
  }
  const Eigen::Map<const MatrixX<T>> w(f + feedback_.weight_offset(0), width, feedback_.input_size());
  MatrixX<T> a = feedback_half;
  a.colwise() += w.middleCols(e_t, e_b) * body_embedding;
  // [x_k; p_k; D's outputs; the proximity at them]: adjacent columns of
  // F's first layer, one product.
  const Eigen::Index k = patch_inputs.rows();
  MatrixX<T> x(k + outputs.rows() + proximity_size_, n);
  x.topRows(k) = patch_inputs;
  x.middleRows(k, outputs.rows()) = outputs;
  x.bottomRows(proximity_size_) = output_proximity.template cast<T>();
  a.noalias() += w.rightCols(x.rows()) * x;
  FinishFromFirstLayer<T>(feedback_, feedback_tail_, f, std::move(a), refined);
  *refined += outputs;
}

template void OneFitNetwork::FeedbackWithGarmentHalf<double>(const double*, const Eigen::MatrixXd&,
                                                             const Eigen::VectorXd&, const Eigen::MatrixXd&,
                                                             const Eigen::MatrixXd&, const Eigen::MatrixXd&,
                                                             Eigen::MatrixXd*) const;
template void OneFitNetwork::FeedbackWithGarmentHalf<float>(const float*, const Eigen::MatrixXf&,
                                                            const Eigen::VectorXf&, const Eigen::MatrixXf&,
                                                            const Eigen::MatrixXf&, const Eigen::MatrixXd&,
                                                            Eigen::MatrixXf*) const;

void OneFitNetwork::Check() {
  if (warp_order_ < -1 || warp_order_ > kMaxJetOrder) throw std::invalid_argument("OneFitNetwork: bad warp order");
  if ((local_size_ != 0 && local_size_ != kLocalPoseSize) ||
      decoder_.input_size() !=
          patch_encoder_.output_size() + body_encoder_.output_size() + local_size_ + proximity_size_ ||
      decoder_.output_size() != num_coefficients_ + 4 + 2 * NumJetCoefficients(warp_order_)) {
    throw std::invalid_argument("OneFitNetwork: the encoders' embeddings and the decoder's sizes do not chain");
  }
  // The garment half is precomputed without the decoder's input, which a
  // skip at its first layer would need.
  if (decoder_.SkipsAt(0)) {
    throw std::invalid_argument(
        "OneFitNetwork: the decoder's first hidden layer must differ in width from the embeddings together");
  }
  if (feedback() && (proximity_size_ == 0 ||
                     feedback_.input_size() != decoder_.input_size() + decoder_.output_size() + proximity_size_ ||
                     feedback_.output_size() != decoder_.output_size())) {
    throw std::invalid_argument(
        "OneFitNetwork: the feedback decoder needs the body proximity and must read the decoder's input, outputs and "
        "proximity and give its outputs");
  }
  if (feedback() && (feedback_passes_ < 1 || feedback_passes_ > kMaxFeedbackPasses)) {
    throw std::invalid_argument("OneFitNetwork: " + std::to_string(feedback_passes_) + " feedback passes");
  }
  if (feedback() && feedback_.SkipsAt(0)) {
    throw std::invalid_argument(
        "OneFitNetwork: the feedback decoder's first hidden layer must differ in width from "
        "its input");
  }
  if (feedback() && feedback_.num_layers() > 1) {
    feedback_tail_ = Mlp(std::vector<int>(feedback_.sizes().begin() + 1, feedback_.sizes().end()), feedback_.residual(),
                         feedback_.leaky_slope());
  }
  // Layers 1.. of the decoder, as an MLP of their own (same weights layout).
  if (decoder_.num_layers() > 1) {
    decoder_tail_ = Mlp(std::vector<int>(decoder_.sizes().begin() + 1, decoder_.sizes().end()), decoder_.residual(),
                        decoder_.leaky_slope());
  }
}

namespace {

// b(y) = c tanh(y / c) and b'(y).
double Bound(double y, double c) { return c * std::tanh(y / c); }
double BoundSlope(double y, double c) {
  const double t = std::tanh(y / c);
  return 1.0 - t * t;
}

// b(y) over `count` rows of outputs from `row`, all patches at once:
// tanh(x) = 1 - 2 / (exp(2x) + 1), whose exp Eigen vectorises (its tanh
// is scalar in double); within 1e-16 of c tanh(y / c) (+-c where exp
// overflows, NaN for NaN).
Eigen::ArrayXXd BoundRows(const Eigen::MatrixXd& outputs, int row, int count, double c) {
  const Eigen::ArrayXXd e = (outputs.middleRows(row, count).array() * (2.0 / c)).exp();
  return c - (2.0 * c) / (e + 1.0);
}

}  // namespace

Eigen::VectorXd PatchOutputUnits(int jet_order, int warp_order, double s0, double area, double warp_radius,
                                 bool area_units) {
  const int k = NumJetCoefficients(jet_order), w = warp_order >= 0 ? 2 * NumJetCoefficients(warp_order) : 0;
  Eigen::VectorXd units = Eigen::VectorXd::Ones(k + 4 + w);
  if (!area_units) {
    units.segment<3>(k + 1).setConstant(s0);
    return units;
  }
  if (!(area > 0.0) || !(s0 > 0.0) || !(warp_radius > 0.0)) {
    throw std::invalid_argument("PatchOutputUnits: a patch without area, scale or extent");
  }
  const double rho = std::sqrt(area / 3.14159265358979323846);
  const auto degree_units = [&](int order, double ratio, double* out) {
    int c = 0;
    for (int d = 0; d <= order; ++d) {
      for (int b = 0; b <= d; ++b) out[c++] = std::pow(ratio, d - 1);
    }
  };
  degree_units(jet_order, s0 / rho, units.data());
  units.segment<3>(k + 1).setConstant(rho);
  if (w > 0) {
    degree_units(warp_order, s0 * warp_radius / rho, units.data() + k + 4);
    units.segment(k + 4 + w / 2, w / 2) = units.segment(k + 4, w / 2);
  }
  return units;
}

namespace {

// Smooths |t| in S so that S >= sum |t_c| everywhere and S > 0.
constexpr double kWarpNormSmoothing = 1e-6;

// g(S) = B tanh(S / B) / S and g'(S), by their series where S << B.
void WarpShrink(double s, double bound, double* g, double* dg) {
  const double x = s / bound;
  if (x < 1e-4) {
    *g = 1.0 - x * x / 3.0;
    *dg = -2.0 * x / (3.0 * bound);
    return;
  }
  const double t = std::tanh(x);
  *g = t / x;
  *dg = ((1.0 - t * t) - *g) / s;
}

double WarpNorm(const double* u, const double* y, int n) {
  double s = 0.0;
  for (int c = 0; c < n; ++c) s += std::hypot(u[c] * y[c], kWarpNormSmoothing);
  return s;
}

}  // namespace

void BoundWarpComponent(const double* u, const double* y, int n, double slide_bound, double* a) {
  if (slide_bound == 0.0) {
    for (int c = 0; c < n; ++c) a[c] = u[c] * Bound(y[c], kOutputBoundWarp);
    return;
  }
  double g, dg;
  WarpShrink(WarpNorm(u, y, n), slide_bound, &g, &dg);
  for (int c = 0; c < n; ++c) a[c] = g * u[c] * y[c];
}

void ChainWarpComponent(const double* u, const double* y, int n, double slide_bound, const double* d_a, double* d_y) {
  if (slide_bound == 0.0) {
    for (int c = 0; c < n; ++c) d_y[c] = d_a[c] * u[c] * BoundSlope(y[c], kOutputBoundWarp);
    return;
  }
  // a_c = g(S) t_c, t_c = u_c y_c, dS/dt_c = t_c / hypot(t_c, smoothing).
  double g, dg, t_dot_da = 0.0;
  WarpShrink(WarpNorm(u, y, n), slide_bound, &g, &dg);
  for (int c = 0; c < n; ++c) t_dot_da += u[c] * y[c] * d_a[c];
  for (int c = 0; c < n; ++c) {
    const double t = u[c] * y[c];
    d_y[c] = u[c] * (g * d_a[c] + dg * t / std::hypot(t, kWarpNormSmoothing) * t_dot_da);
  }
}

std::vector<double> PatchParametersFromOutputs(const PatchOutputMap& map, const Eigen::MatrixXd& outputs,
                                               int num_coefficients, bool with_warps) {
  const int num_patches = static_cast<int>(outputs.cols());
  const int stride = static_cast<int>(outputs.rows());
  const int k = num_coefficients;
  if (static_cast<int>(map.rest.size()) != stride * num_patches || map.num_patches() != num_patches ||
      map.units.rows() != stride || map.units.cols() != num_patches || stride < k + 4 || (stride - k - 4) % 2 != 0) {
    throw std::invalid_argument("PatchParametersFromOutputs: sizes disagree");
  }
  const int w = (stride - k - 4) / 2;
  std::vector<double> params(map.rest.size());
  const Eigen::ArrayXXd alpha = BoundRows(outputs, 0, k, kOutputBoundAlpha);
  const Eigen::ArrayXXd scale = BoundRows(outputs, k, 1, kOutputBoundLogScale).exp();
  const Eigen::ArrayXXd centre = BoundRows(outputs, k + 1, 3, kOutputBoundTranslation);
  for (int p = 0; p < num_patches; ++p) {
    const double* r = map.rest.data() + p * stride;
    const double* u = map.units.col(p).data();
    double* out = params.data() + p * stride;
    for (int c = 0; c < k; ++c) out[c] = r[c] + u[c] * alpha(c, p);
    out[k] = r[k] * scale(0, p);
    Eigen::Vector3d d;
    for (int c = 0; c < 3; ++c) d[c] = u[k + 1 + c] * centre(c, p);
    Eigen::Map<Eigen::Vector3d>(out + k + 1) = Eigen::Map<const Eigen::Vector3d>(r + k + 1) + map.frames[p] * d;
    for (int half = 0; half < 2 * w; half += w) {
      const int c0 = k + 4 + half;
      if (!with_warps) {
        std::copy(r + c0, r + c0 + w, out + c0);
        continue;
      }
      BoundWarpComponent(u + c0, outputs.col(p).data() + c0, w, map.warp_slide_bound, out + c0);
      for (int c = c0; c < c0 + w; ++c) out[c] += r[c];
    }
  }
  return params;
}

Eigen::MatrixXd ChainPatchParameterGradient(const PatchOutputMap& map, const Eigen::MatrixXd& outputs,
                                            int num_coefficients, const std::vector<double>& gradient) {
  const int num_patches = static_cast<int>(outputs.cols());
  const int stride = static_cast<int>(outputs.rows());
  const int k = num_coefficients;
  if (static_cast<int>(gradient.size()) != stride * num_patches || map.units.rows() != stride ||
      map.units.cols() != num_patches || stride < k + 4 || (stride - k - 4) % 2 != 0) {
    throw std::invalid_argument("ChainPatchParameterGradient: sizes disagree");
  }
  const int w = (stride - k - 4) / 2;
  Eigen::MatrixXd d(stride, num_patches);
  for (int p = 0; p < num_patches; ++p) {
    const double* g = gradient.data() + p * stride;
    const double* u = map.units.col(p).data();
    const double s0 = map.rest[p * stride + k];
    for (int c = 0; c < k; ++c) d(c, p) = g[c] * u[c] * BoundSlope(outputs(c, p), kOutputBoundAlpha);
    d(k, p) = g[k] * s0 * std::exp(Bound(outputs(k, p), kOutputBoundLogScale)) *
              BoundSlope(outputs(k, p), kOutputBoundLogScale);
    const Eigen::Vector3d dt = map.frames[p].transpose() * Eigen::Map<const Eigen::Vector3d>(g + k + 1);
    for (int c = 0; c < 3; ++c) {
      d(k + 1 + c, p) = dt[c] * u[k + 1 + c] * BoundSlope(outputs(k + 1 + c, p), kOutputBoundTranslation);
    }
    for (int half = 0; half < 2 * w; half += w) {
      const int c0 = k + 4 + half;
      ChainWarpComponent(u + c0, outputs.col(p).data() + c0, w, map.warp_slide_bound, g + c0, d.col(p).data() + c0);
    }
  }
  return d;
}

}  // namespace polyfit
