// A multilayer perceptron over a batch of samples (columns), its weights in
// one flat vector so that a trainer sees one parameter block
// (ceres::GradientProblem). With sizes n_0 .. n_L:
//
//   h_0 = x                                                   (n_0 by N)
//   a_l = W_l h_l + b_l                                       W_l: n_(l+1) by n_l
//   h_(l+1) = h_l + f(a_l)   when residual and n_(l+1) = n_l   (a skip connection)
//             f(a_l)          otherwise
//   y = a_(L-1)              (the last layer is linear)
//
// f is LeakyReLU (f(a) = a for a > 0, slope a otherwise). Parameters, in
// order, per layer: W_l column-major, then b_l. The forward pass is
// templated on the scalar, so that ceres::Jet checks the hand-written
// backward pass (mlp_test.cc).
#ifndef POLYFIT_DRAPE_NETWORK_MLP_H_
#define POLYFIT_DRAPE_NETWORK_MLP_H_

#include <cstdint>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

namespace polyfit {

// The activations a forward pass keeps for the backward pass.
struct MlpCache {
  std::vector<Eigen::MatrixXd> inputs;       // h_l, l = 0 .. L-1
  std::vector<Eigen::MatrixXd> activations;  // a_l
};

class Mlp {
 public:
  Mlp() = default;
  // sizes: n_0 .. n_L, at least two, all positive.
  explicit Mlp(std::vector<int> sizes, bool residual = true, double leaky_slope = 0.01);

  int input_size() const { return sizes_.front(); }
  int output_size() const { return sizes_.back(); }
  int num_layers() const { return static_cast<int>(sizes_.size()) - 1; }
  int num_parameters() const { return num_parameters_; }
  const std::vector<int>& sizes() const { return sizes_; }
  bool residual() const { return residual_; }
  double leaky_slope() const { return leaky_slope_; }
  // Offset of W_l and of b_l in the parameters.
  int weight_offset(int l) const { return offsets_[l]; }
  int bias_offset(int l) const { return offsets_[l] + sizes_[l + 1] * sizes_[l]; }

  // He initialisation (normal, variance 2 / n_l), zero biases; the last
  // layer's weights scaled by last_layer_scale, so that a new network
  // starts near zero output. params: num_parameters().
  void Initialize(std::uint64_t seed, double last_layer_scale, double* params) const;

  // x: n_0 by N; y: n_L by N. cache (may be null) keeps what Backward reads.
  void Forward(const double* params, const Eigen::MatrixXd& x, Eigen::MatrixXd* y, MlpCache* cache = nullptr) const;

  // Given dL/dy (n_L by N) and the cache of the forward pass, adds dL/dparams
  // to gradient (num_parameters()) and, if dx is not null, sets dL/dx.
  void Backward(const double* params, const MlpCache& cache, const Eigen::MatrixXd& dy, double* gradient,
                Eigen::MatrixXd* dx = nullptr) const;

  // The same forward pass for any scalar (ceres::Jet), without a cache.
  template <typename T>
  Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic> ForwardT(
      const T* params, const Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>& x) const {
    using Matrix = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;
    Matrix h = x;
    for (int l = 0; l < num_layers(); ++l) {
      const Eigen::Map<const Matrix> w(params + weight_offset(l), sizes_[l + 1], sizes_[l]);
      const Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, 1>> b(params + bias_offset(l), sizes_[l + 1]);
      Matrix a = w * h;
      a.colwise() += b;
      if (l + 1 == num_layers()) return a;
      if constexpr (std::is_floating_point_v<T>) {
        // max(a, slope a) is LeakyReLU for slope < 1, and vectorises.
        a = a.array().max(T(leaky_slope_) * a.array()).matrix();
      } else {
        for (Eigen::Index i = 0; i < a.size(); ++i) {
          if (!(a.data()[i] > T(0.0))) a.data()[i] *= T(leaky_slope_);
        }
      }
      h = SkipsAt(l) ? Matrix(h + a) : a;
    }
    return h;
  }

  // Whether hidden layer l adds its input back (a skip connection).
  bool SkipsAt(int l) const { return residual_ && l + 1 < num_layers() && sizes_[l + 1] == sizes_[l]; }

  // "16-32-32-8 residual, slope 0.01"
  std::string Describe() const;

 private:
  std::vector<int> sizes_;
  std::vector<int> offsets_;
  int num_parameters_ = 0;
  bool residual_ = true;
  double leaky_slope_ = 0.01;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_MLP_H_
