// Closed-form weighted least-squares jet fit in a patch's local frame: the
// kernel under JetFitter and the orientation refinement.
//
//   min_alpha  sum_m w_m (z_m - sum_k alpha_k u_m^a v_m^b)^2
//
// solved by normal equations on the (u, v) in [-1, 1]^2 monomial basis with
// Jacobi equilibration; a near-singular system (cond > 1e12) falls back to a
// rank-revealing decomposition that zeroes the undetermined coefficients.
// K is the number of coefficients at compile time, or Eigen::Dynamic. All
// buffers are reused: after Reserve() a Solve() does not allocate (fixed K).
#ifndef POLYFIT_PATCH_LOCAL_JET_SOLVER_H_
#define POLYFIT_PATCH_LOCAL_JET_SOLVER_H_

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/QR>

#include "polyfit/jet/jet_basis.h"
#include "polyfit/patch/jet_patch.h"

namespace polyfit {
namespace internal {

// Points are processed in blocks of kBlock: every monomial of a block is
// one Eigen packet, so the recurrence and the moment sums vectorise.
constexpr int kBlock = 8;

template <int K>
class LocalJetSolver {
 public:
  using MatrixK = Eigen::Matrix<double, K, K>;
  using VectorK = Eigen::Matrix<double, K, 1>;
  // Column-major with the leading dimension padded to whole blocks.
  using Design = Eigen::Matrix<double, Eigen::Dynamic, K>;
  using ConstDesignMap = Eigen::Map<const Design, 0, Eigen::OuterStride<>>;
  using VectorMap = Eigen::Map<Eigen::VectorXd>;

  void Reserve(int max_points, int num_coefficients) {
    const size_t m = Padded(std::max(max_points, 1));
    if (a_buffer_.size() < m * num_coefficients) a_buffer_.resize(m * num_coefficients);
    if (b_buffer_.size() < m) {
      for (auto* b : {&b_buffer_, &r_buffer_, &u_buffer_, &v_buffer_, &w_buffer_}) b->resize(m);
    }
  }

  // local: 3 by >= m, rows u, v, z. sqrt_w: m square-root weights or null.
  // order must match K when K is fixed.
  // Returns kJetFitRankDeficient or 0.
  uint32_t Solve(int order, const Eigen::Matrix3Xd& local, int m, const double* sqrt_w) {
    // With K fixed the order is a compile-time constant and loops unroll.
    constexpr int kOrder = K == Eigen::Dynamic ? 0 : OrderOf(K);
    const int n = kOrder > 0 ? kOrder : order;
    const int k = NumJetCoefficients(n);
    const int mp = static_cast<int>(Padded(m));
    Reserve(m, k);
    order_ = n;
    m_ = m;
    // Contiguous, zero-weight-padded copies: the rows of a 3 by M matrix are
    // strided. b = sqrt(w) z.
    double* u = u_buffer_.data();
    double* v = v_buffer_.data();
    double* w = w_buffer_.data();
    double* b = b_buffer_.data();
    for (int i = 0; i < m; ++i) {
      u[i] = local(0, i);
      v[i] = local(1, i);
      w[i] = sqrt_w ? sqrt_w[i] : 1.0;
      b[i] = w[i] * local(2, i);
    }
    for (int i = m; i < mp; ++i) u[i] = v[i] = w[i] = b[i] = 0.0;

    // A^T A depends only on the moments sum_m w_m u^p v^q, p + q <= 2n
    // (45 at order 4, 153 at order 8), A^T b on sum_m w_m z_m u^a v^b.
    using Packet = Eigen::Array<double, kBlock, 1>;
    constexpr int kMaxMoments = NumJetCoefficients(2 * kMaxJetOrder);
    const int num_moments = NumJetCoefficients(2 * n);
    Packet moment_sums[kMaxMoments];
    Packet atb_sums[kMaxJetCoefficients];
    for (int c = 0; c < num_moments; ++c) moment_sums[c].setZero();
    for (int c = 0; c < k; ++c) atb_sums[c].setZero();
    double* a = a_buffer_.data();
    for (int i = 0; i < mp; i += kBlock) {
      const Packet pu = Packet::Map(u + i), pv = Packet::Map(v + i);
      const Packet pw = Packet::Map(w + i), pb = Packet::Map(b + i);
      Packet mono[kMaxMoments];  // sqrt(w) u^a v^b
      mono[0] = pw;
      for (int d = 1, c = 1; d <= 2 * n; ++d) {
        const int prev = (d - 1) * d / 2;
        for (int j = 0; j < d; ++j, ++c) mono[c] = mono[prev + j] * pu;
        mono[c] = mono[prev + d - 1] * pv;
        ++c;
      }
      for (int c = 0; c < num_moments; ++c) moment_sums[c] += mono[c] * pw;
      for (int c = 0; c < k; ++c) {
        Packet::Map(a + size_t(c) * mp + i) = mono[c];
        atb_sums[c] += mono[c] * pb;
      }
    }
    double moments[kMaxMoments];
    for (int c = 0; c < num_moments; ++c) moments[c] = moment_sums[c].sum();
    atb_.resize(k);
    for (int c = 0; c < k; ++c) atb_[c] = atb_sums[c].sum();
    ata_.resize(k, k);
    for (int dj = 0, j = 0; dj <= n; ++dj) {
      for (int bj = 0; bj <= dj; ++bj, ++j) {
        for (int dl = 0, l = 0; dl <= n; ++dl) {
          for (int bl = 0; bl <= dl; ++bl, ++l) {
            ata_(j, l) = moments[JetCoefficientIndex(dj - bj + dl - bl, bj + bl)];
          }
        }
      }
    }

    // Jacobi equilibration; an all-zero column (v == 0 everywhere) stays 0.
    scaling_.resize(k);
    const double max_diag = ata_.diagonal().maxCoeff();
    for (int j = 0; j < k; ++j) {
      const double d = ata_(j, j);
      scaling_[j] = d > 1e-300 && d > 1e-24 * max_diag ? 1.0 / std::sqrt(d) : 0.0;
    }
    ata_ = scaling_.asDiagonal() * ata_ * scaling_.asDiagonal();
    atb_ = scaling_.asDiagonal() * atb_;

    uint32_t flags = 0;
    use_llt_ = false;
    if (scaling_.minCoeff() > 0.0) {
      llt_.compute(ata_);
      if (llt_.info() == Eigen::Success) {
        const auto pivots = llt_.matrixLLT().diagonal().cwiseAbs2();
        use_llt_ = pivots.minCoeff() > 1e-12 * pivots.maxCoeff();
      }
    }
    if (use_llt_) {
      alpha_ = llt_.solve(atb_);
    } else {
      flags |= kJetFitRankDeficient;
      cod_.setThreshold(1e-10);
      cod_.compute(ata_);
      alpha_ = cod_.solve(atb_);
    }
    alpha_ = scaling_.asDiagonal() * alpha_;

    const ConstDesignMap design(a, m, k, Eigen::OuterStride<>(mp));
    VectorMap r(r_buffer_.data(), m);
    r.noalias() = VectorMap(b, m) - design * alpha_;
    ssr_ = r.squaredNorm();
    return flags;
  }

  int order() const { return order_; }
  const VectorK& alpha() const { return alpha_; }
  // Sum of squared weighted residuals of the last Solve().
  double ssr() const { return ssr_; }
  // Weighted residuals sqrt(w) (z - h(u, v)) of the last Solve().
  Eigen::Map<const Eigen::VectorXd> residual() const { return Eigen::Map<const Eigen::VectorXd>(r_buffer_.data(), m_); }
  bool well_conditioned() const { return use_llt_; }

  // j: m by c (c small). j <- (I - P) j, P the orthogonal projector onto the
  // weighted design's columns. Needs a well-conditioned last Solve().
  template <typename Derived>
  void ProjectOut(Eigen::MatrixBase<Derived>& j) const {
    const int k = NumJetCoefficients(order_);
    const ConstDesignMap a(a_buffer_.data(), m_, k, Eigen::OuterStride<>(Padded(m_)));
    Eigen::Matrix<double, K, Derived::ColsAtCompileTime> atj = scaling_.asDiagonal() * (a.transpose() * j);
    atj = scaling_.asDiagonal() * llt_.solve(atj);
    j.noalias() -= a * atj;
  }

 private:
  static size_t Padded(int m) { return (static_cast<size_t>(m) + kBlock - 1) / kBlock * kBlock; }
  static constexpr int OrderOf(int k) {
    int n = 0;
    while (NumJetCoefficients(n) < k) ++n;
    return n;
  }

  int order_ = 0;
  int m_ = 0;
  std::vector<double> a_buffer_, b_buffer_, r_buffer_, u_buffer_, v_buffer_, w_buffer_;
  MatrixK ata_;
  VectorK atb_, alpha_, scaling_;
  Eigen::LLT<MatrixK> llt_;
  Eigen::CompleteOrthogonalDecomposition<MatrixK> cod_;
  bool use_llt_ = false;
  double ssr_ = 0.0;
};

}  // namespace internal
}  // namespace polyfit

#endif  // POLYFIT_PATCH_LOCAL_JET_SOLVER_H_
