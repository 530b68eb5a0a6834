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

template <int K>
class LocalJetSolver {
 public:
  using MatrixK = Eigen::Matrix<double, K, K>;
  using VectorK = Eigen::Matrix<double, K, 1>;
  // Column-major: each monomial over all points is contiguous, so columns
  // are built by vectorised recurrence and A^T A is K(K+1)/2 dot products.
  using Design = Eigen::Matrix<double, Eigen::Dynamic, K>;
  using DesignMap = Eigen::Map<Design>;
  using VectorMap = Eigen::Map<Eigen::VectorXd>;

  void Reserve(int max_points, int num_coefficients) {
    const size_t m = static_cast<size_t>(std::max(max_points, 1));
    if (a_buffer_.size() < m * num_coefficients) a_buffer_.resize(m * num_coefficients);
    if (b_buffer_.size() < m) {
      b_buffer_.resize(m);
      r_buffer_.resize(m);
      u_buffer_.resize(m);
      v_buffer_.resize(m);
    }
    const size_t scratch = m * (2 * kMaxJetOrder + 1);
    if (scratch_[0].size() < scratch) {
      scratch_[0].resize(scratch);
      scratch_[1].resize(scratch);
    }
  }

  // local: 3 by >= m, rows u, v, z. sqrt_w: m square-root weights or null.
  // Returns kJetFitRankDeficient or 0.
  uint32_t Solve(int order, const Eigen::Matrix3Xd& local, int m, const double* sqrt_w) {
    const int k = NumJetCoefficients(order);
    Reserve(m, k);
    order_ = order;
    m_ = m;
    DesignMap a(a_buffer_.data(), m, k);
    VectorMap b(b_buffer_.data(), m);
    // Contiguous copies: the rows of a 3 by M matrix are strided.
    VectorMap u(u_buffer_.data(), m), v(v_buffer_.data(), m);
    u = local.row(0).head(m).transpose();
    v = local.row(1).head(m).transpose();
    if (sqrt_w) {
      a.col(0) = Eigen::Map<const Eigen::VectorXd>(sqrt_w, m);
    } else {
      a.col(0).setOnes();
    }
    b = a.col(0).cwiseProduct(local.row(2).head(m).transpose());
    // Column (i, j) of degree d = i + j from degree d - 1: times u, or times v.
    for (int d = 1, c = 1; d <= order; ++d) {
      const int prev = (d - 1) * d / 2;
      for (int j = 0; j <= d; ++j, ++c) {
        if (j < d) {
          a.col(c) = a.col(prev + j).cwiseProduct(u);
        } else {
          a.col(c) = a.col(prev + j - 1).cwiseProduct(v);
        }
      }
    }
    // A^T A depends only on the moments sum_m w_m u^p v^q, p + q <= 2n:
    // (2n+1)(2n+2)/2 sums (45 for n = 4) instead of K(K+1)/2 dot products
    // (120). Degrees <= n are A's columns; higher ones roll through scratch.
    double moments[NumJetCoefficients(2 * kMaxJetOrder)];
    // Columns carry sqrt(w); one more factor sqrt(w) = a.col(0) makes w.
    const auto w0 = a.col(0);
    for (int c = 0; c < k; ++c) moments[c] = a.col(c).dot(w0);
    const double* prev_cols = a_buffer_.data();
    int prev_offset = order * (order + 1) / 2;  // first column of degree n
    for (int d = order + 1, c = k; d <= 2 * order; ++d) {
      double* cols = d % 2 ? scratch_[0].data() : scratch_[1].data();
      for (int j = 0; j <= d; ++j, ++c) {
        Eigen::Map<Eigen::VectorXd> col(cols + size_t(j) * m, m);
        const bool times_u = j < d;
        col = Eigen::Map<const Eigen::VectorXd>(prev_cols + size_t(prev_offset + j - !times_u) * m, m)
                  .cwiseProduct(times_u ? u : v);
        moments[c] = col.dot(w0);
      }
      prev_cols = cols;
      prev_offset = 0;
    }
    ata_.resize(k, k);
    for (int dj = 0, j = 0; dj <= order; ++dj) {
      for (int bj = 0; bj <= dj; ++bj, ++j) {
        for (int dl = 0, l = 0; dl <= order; ++dl) {
          for (int bl = 0; bl <= dl; ++bl, ++l) {
            ata_(j, l) = moments[JetCoefficientIndex(dj - bj + dl - bl, bj + bl)];
          }
        }
      }
    }
    atb_.resize(k);
    for (int j = 0; j < k; ++j) atb_[j] = a.col(j).dot(b);

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

    VectorMap r(r_buffer_.data(), m);
    r.noalias() = b - a * alpha_;
    ssr_ = r.squaredNorm();
    return flags;
  }

  int order() const { return order_; }
  const VectorK& alpha() const { return alpha_; }
  // Sum of squared weighted residuals of the last Solve().
  double ssr() const { return ssr_; }
  // Weighted residuals sqrt(w) (z - h(u, v)) of the last Solve().
  Eigen::Map<const Eigen::VectorXd> residual() const {
    return Eigen::Map<const Eigen::VectorXd>(r_buffer_.data(), m_);
  }
  bool well_conditioned() const { return use_llt_; }

  // j: m by c (c small). j <- (I - P) j, P the orthogonal projector onto the
  // weighted design's columns. Needs a well-conditioned last Solve().
  template <typename Derived>
  void ProjectOut(Eigen::MatrixBase<Derived>& j) const {
    const int k = NumJetCoefficients(order_);
    Eigen::Map<const Design> a(a_buffer_.data(), m_, k);
    Eigen::Matrix<double, K, Derived::ColsAtCompileTime> atj =
        scaling_.asDiagonal() * (a.transpose() * j);
    atj = scaling_.asDiagonal() * llt_.solve(atj);
    j.noalias() -= a * atj;
  }

 private:
  int order_ = 0;
  int m_ = 0;
  std::vector<double> a_buffer_, b_buffer_, r_buffer_, u_buffer_, v_buffer_;
  std::vector<double> scratch_[2];  // monomial columns of degrees n+1..2n
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
