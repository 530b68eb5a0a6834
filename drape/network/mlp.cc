#include "drape/network/mlp.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace polyfit {

Mlp::Mlp(std::vector<int> sizes, bool residual, double leaky_slope)
    : sizes_(std::move(sizes)), residual_(residual), leaky_slope_(leaky_slope) {
  if (sizes_.size() < 2) throw std::invalid_argument("Mlp: at least an input and an output size are needed");
  for (int n : sizes_) {
    if (n < 1) throw std::invalid_argument("Mlp: every layer size must be positive");
  }
  if (!(leaky_slope_ >= 0.0 && leaky_slope_ < 1.0)) throw std::invalid_argument("Mlp: leaky_slope must be in [0, 1)");
  offsets_.resize(sizes_.size() - 1);
  // Counted in 64 bits: the weights are indexed by int.
  long long offset = 0;
  for (int l = 0; l + 1 < static_cast<int>(sizes_.size()); ++l) {
    offsets_[l] = static_cast<int>(offset);
    offset += static_cast<long long>(sizes_[l + 1]) * sizes_[l] + sizes_[l + 1];
    if (offset > std::numeric_limits<int>::max()) throw std::invalid_argument("Mlp: more than 2^31 parameters");
  }
  num_parameters_ = static_cast<int>(offset);
}

void Mlp::Initialize(std::uint64_t seed, double last_layer_scale, double* params) const {
  std::mt19937_64 rng(seed);
  for (int l = 0; l < num_layers(); ++l) {
    std::normal_distribution<double> normal(0.0, std::sqrt(2.0 / sizes_[l]));
    const double scale = l + 1 == num_layers() ? last_layer_scale : 1.0;
    for (int i = 0; i < sizes_[l + 1] * sizes_[l]; ++i) params[weight_offset(l) + i] = scale * normal(rng);
    for (int i = 0; i < sizes_[l + 1]; ++i) params[bias_offset(l) + i] = 0.0;
  }
}

void Mlp::Forward(const double* params, const Eigen::MatrixXd& x, Eigen::MatrixXd* y, MlpCache* cache) const {
  if (x.rows() != input_size()) throw std::invalid_argument("Mlp::Forward: the input has the wrong size");
  if (cache != nullptr) {
    cache->inputs.resize(num_layers());
    cache->activations.resize(num_layers());
  }
  Eigen::MatrixXd h = x;
  for (int l = 0; l < num_layers(); ++l) {
    const Eigen::Map<const Eigen::MatrixXd> w(params + weight_offset(l), sizes_[l + 1], sizes_[l]);
    const Eigen::Map<const Eigen::VectorXd> b(params + bias_offset(l), sizes_[l + 1]);
    Eigen::MatrixXd a = w * h;
    a.colwise() += b;
    if (cache != nullptr) {
      cache->inputs[l] = h;
      cache->activations[l] = a;
    }
    if (l + 1 == num_layers()) {
      *y = std::move(a);
      return;
    }
    const Eigen::MatrixXd f = (a.array() > 0.0).select(a, leaky_slope_ * a);
    h = SkipsAt(l) ? Eigen::MatrixXd(h + f) : f;
  }
}

void Mlp::Backward(const double* params, const MlpCache& cache, const Eigen::MatrixXd& dy, double* gradient,
                   Eigen::MatrixXd* dx) const {
  if (static_cast<int>(cache.inputs.size()) != num_layers() || dy.rows() != output_size()) {
    throw std::invalid_argument("Mlp::Backward: the cache or dL/dy does not fit the network");
  }
  // g: dL/dh_(l+1) on entry (dL/dy for the last layer), dL/da_l after the
  // activation's derivative, dL/dh_l on exit.
  Eigen::MatrixXd g = dy;
  for (int l = num_layers() - 1; l >= 0; --l) {
    Eigen::MatrixXd skip;
    if (l + 1 < num_layers()) {
      const Eigen::MatrixXd& a = cache.activations[l];
      if (SkipsAt(l)) skip = g;  // the skip passes dL/dh_(l+1) on unchanged
      g = (a.array() > 0.0).select(g, leaky_slope_ * g);
    }
    Eigen::Map<Eigen::MatrixXd> dw(gradient + weight_offset(l), sizes_[l + 1], sizes_[l]);
    Eigen::Map<Eigen::VectorXd> db(gradient + bias_offset(l), sizes_[l + 1]);
    dw.noalias() += g * cache.inputs[l].transpose();
    db += g.rowwise().sum();
    if (l == 0 && dx == nullptr) return;
    const Eigen::Map<const Eigen::MatrixXd> w(params + weight_offset(l), sizes_[l + 1], sizes_[l]);
    Eigen::MatrixXd dh = w.transpose() * g;
    if (skip.size() > 0) dh += skip;
    g = std::move(dh);
  }
  if (dx != nullptr) *dx = std::move(g);
}

std::string Mlp::Describe() const {
  std::string s;
  for (size_t l = 0; l < sizes_.size(); ++l) s += (l > 0 ? "-" : "") + std::to_string(sizes_[l]);
  return s + (residual_ ? " residual" : "") + ", LeakyReLU " + std::to_string(leaky_slope_).substr(0, 4);
}

}  // namespace polyfit
