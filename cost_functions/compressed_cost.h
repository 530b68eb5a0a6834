// Gauss-Newton compression of a tall cost: wraps a CostFunction with m
// residuals over parameter blocks of total size n (m >> n) into one with
// n + 1 residuals that gives a Levenberg-Marquardt solver exactly the same
// cost, gradient and Gauss-Newton model:
//
//   J^T J = P^T L D L^T P                    (pivoted LDL^T, P a permutation)
//   R     = D^(1/2) L^T P                    so that R^T R = J^T J
//   r~    = D^(-1/2) L^-1 P J^T r            so that R^T r~ = J^T r
//   residuals  [r~; sqrt(|r|^2 - |r~|^2)],  Jacobian  [R; 0]
//
// The last residual keeps the cost |r|^2 exact; its gradient, J^T (I - Q) r
// with Q the projection onto J's range, is zero. Pivots below 1e-12 of
// J^T J's largest diagonal entry are dropped (their r~ and R rows are 0).
// Any R with R^T R = J^T J gives the solver the same model; the pivoted
// factorisation costs n^3 / 3 against the ~9 n^3 of the symmetric
// eigendecomposition used before (a flag's frame 7% less time on one
// thread, docs/benchmarks.md). A solver then forms an n by n system from
// n + 1 rows instead of m: for an image term with 10^5 pixel residuals
// and 40 parameters that is most of the work.
//
// Evaluate without Jacobians (trial steps) returns [0, ..., 0, |r|]: the
// cost is all a solver reads there.
#ifndef COST_FUNCTIONS_COMPRESSED_COST_H_
#define COST_FUNCTIONS_COMPRESSED_COST_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include <ceres/cost_function.h>
#include <Eigen/Core>
#include <Eigen/Cholesky>

namespace polyfit {

// The compression below (WriteCompressedResiduals) with R upper
// block-triangular over the parameter blocks of `sizes` (block Cholesky,
// each diagonal block pivoted within itself): block row i of R is zero left
// of block i, and right of it wherever `later` says so, so it may be a
// residual block over block i and later[i] alone. A solver forming J^T J
// from such row blocks multiplies sum_i b (1 + |later[i]|)^2 b^2 entries
// instead of (k b)^3 for k blocks of b.
//   S = J^T J, g = J^T r; for i = 1..k:  S_ii = P^T L D L^T P,
//   R_ii = D^(1/2) L^T P,  R_ij = D^(-1/2) L^-1 P S_ij,  r~_i = D^(-1/2) L^-1 P g_i,
//   S_jl -= R_ij^T R_il,  g_j -= R_ij^T r~_i   (j <= l, both in later[i])
// later[i]: the blocks j > i (ascending) where R_ij may be nonzero, that is
// S's block pattern with the fill of eliminating blocks in order
// (BlockFill); every other R_ij is zero and never touched. Pivots below
// `floor` are dropped (their rows are 0).
//   schur:  in, S's blocks (i, i) and (i, j in later[i]) (upper; the
//           diagonal blocks whole); the rest is not read. Overwritten.
//   g:      in, J^T r (n). Overwritten.
//   rows:   out, row block i of R: sizes[i] by sizes[i] + sum of
//           sizes[later[i]], blocks i, later[i]... side by side.
//   residuals: out, r~ (n) and sqrt(|r|^2 - |r~|^2) (n + 1).
inline void CompressBlockSparse(const std::vector<int32_t>& sizes, const std::vector<std::vector<int>>& later,
                                double squared_norm, double floor, Eigen::MatrixXd* schur, Eigen::VectorXd* g,
                                std::vector<Eigen::MatrixXd>* rows, Eigen::VectorXd* residuals) {
  const size_t k = sizes.size();
  // Kept per thread: fresh matrices of a few hundred columns cost more in
  // page faults than the factorisation.
  thread_local std::vector<Eigen::Index> offset;
  thread_local Eigen::MatrixXd off, diagonal;
  thread_local Eigen::VectorXd y;
  thread_local Eigen::LDLT<Eigen::MatrixXd> ldlt;
  offset.assign(k + 1, 0);
  for (size_t i = 0; i < k; ++i) offset[i + 1] = offset[i] + sizes[i];
  const Eigen::Index n = offset[k];
  residuals->setZero(n + 1);
  rows->resize(k);
  double compressed = 0.0;
  for (size_t i = 0; i < k; ++i) {
    const Eigen::Index c = offset[i], b = sizes[i];
    const std::vector<int>& right = later[i];
    Eigen::Index width = 0;
    for (const int j : right) width += sizes[j];
    ldlt.compute(schur->block(c, c, b, b));
    const Eigen::VectorXd& d = ldlt.vectorD();
    const auto& pivots = ldlt.transpositionsP();
    // L^-1 P [S_i,later  g_i]
    off.resize(b, width);
    for (Eigen::Index j = 0, w = 0; j < static_cast<Eigen::Index>(right.size()); w += sizes[right[j]], ++j) {
      off.middleCols(w, sizes[right[j]]) = schur->block(c, offset[right[j]], b, sizes[right[j]]);
    }
    off = pivots * off;
    y = pivots * g->segment(c, b);
    ldlt.matrixL().solveInPlace(off);
    ldlt.matrixL().solveInPlace(y);
    diagonal = ldlt.matrixU();
    diagonal = diagonal * Eigen::PermutationMatrix<Eigen::Dynamic>(pivots);
    Eigen::MatrixXd& row = (*rows)[i];
    row.resize(b, b + width);
    for (Eigen::Index r = 0; r < b; ++r) {
      if (!(d[r] > floor)) {
        off.row(r).setZero();
        y[r] = 0.0;
        row.row(r).head(b).setZero();
        continue;
      }
      const double s = std::sqrt(d[r]);
      row.row(r).head(b) = s * diagonal.row(r);
      off.row(r) /= s;
      y[r] /= s;
      (*residuals)[c + r] = y[r];
      compressed += y[r] * y[r];
    }
    if (width == 0) continue;
    row.rightCols(width) = off;
    for (Eigen::Index j = 0, wj = 0; j < static_cast<Eigen::Index>(right.size()); wj += sizes[right[j]], ++j) {
      const Eigen::Index cj = offset[right[j]], bj = sizes[right[j]];
      g->segment(cj, bj).noalias() -= off.middleCols(wj, bj).transpose() * y;
      for (Eigen::Index l = j, wl = wj; l < static_cast<Eigen::Index>(right.size()); wl += sizes[right[l]], ++l) {
        schur->block(cj, offset[right[l]], bj, sizes[right[l]]).noalias() -=
            off.middleCols(wj, bj).transpose() * off.middleCols(wl, sizes[right[l]]);
      }
    }
  }
  (*residuals)[n] = std::sqrt(std::max(0.0, squared_norm - compressed));
}

// For CompressBlockSparse: the blocks j > i of row block i of R, given
// S's block pattern `adjacent` (k lists, block i's neighbours, symmetric):
// the pattern with the fill of eliminating the blocks in order (each
// block's later neighbours become adjacent to one another).
inline std::vector<std::vector<int>> BlockFill(const std::vector<std::vector<int>>& adjacent) {
  const size_t k = adjacent.size();
  std::vector<std::vector<int>> later(k);
  for (size_t i = 0; i < k; ++i) {
    for (const int j : adjacent[i]) {
      if (j > static_cast<int>(i)) later[i].push_back(j);
    }
  }
  for (size_t i = 0; i < k; ++i) {
    std::sort(later[i].begin(), later[i].end());
    later[i].erase(std::unique(later[i].begin(), later[i].end()), later[i].end());
    // Eliminating i joins its later neighbours: the first inherits the rest.
    if (later[i].size() > 1) {
      std::vector<int>& first = later[later[i][0]];
      first.insert(first.end(), later[i].begin() + 1, later[i].end());
    }
  }
  return later;
}

// CompressBlockSparse with every R_ij (j > i) kept, on dense S and g; R as
// one n by n matrix (factor, zero below its diagonal blocks). Pivots below
// 1e-12 of J^T J's largest diagonal entry are dropped. Without jtj (cost
// only): residuals [0, ..., 0, |r|].
inline void CompressBlockTriangular(const std::vector<int32_t>& sizes, double squared_norm, const Eigen::MatrixXd* jtj,
                                    const Eigen::VectorXd* jtr, Eigen::VectorXd* residuals, Eigen::MatrixXd* factor) {
  int n = 0;
  for (const int32_t size : sizes) n += size;
  residuals->setZero(n + 1);
  if (jtj == nullptr) {
    (*residuals)[n] = std::sqrt(std::max(0.0, squared_norm));
    return;
  }
  thread_local Eigen::MatrixXd schur;
  thread_local Eigen::VectorXd g;
  thread_local std::vector<Eigen::MatrixXd> rows;
  thread_local std::vector<std::vector<int>> later;
  later.resize(sizes.size());
  for (size_t i = 0; i < sizes.size(); ++i) {
    later[i].clear();
    for (size_t j = i + 1; j < sizes.size(); ++j) later[i].push_back(static_cast<int>(j));
  }
  schur = *jtj;
  g = *jtr;
  const double floor = 1e-12 * std::max(jtj->diagonal().maxCoeff(), 1e-300);
  CompressBlockSparse(sizes, later, squared_norm, floor, &schur, &g, &rows, residuals);
  factor->setZero(n, n);
  for (size_t i = 0, c = 0; i < sizes.size(); c += sizes[i], ++i) {
    factor->block(c, c, sizes[i], n - c) = rows[i];
  }
}

// Writes the compressed residuals (n + 1) and Jacobians (row-major, one per
// parameter block of `sizes`) of a term with |r|^2 = squared_norm and
// normal equations J^T J, J^T r: CompressBlockTriangular with one block.
// Without jacobians, only the cost.
inline void WriteCompressedResiduals(const std::vector<int32_t>& sizes, double squared_norm, const Eigen::MatrixXd& jtj,
                                     const Eigen::VectorXd& jtr, double* residuals, double** jacobians) {
  const int n = static_cast<int>(jtr.size());
  Eigen::Map<Eigen::VectorXd> out(residuals, n + 1);
  out.setZero();
  if (jacobians == nullptr) {
    out[n] = std::sqrt(std::max(0.0, squared_norm));
    return;
  }
  // Kept per thread: at a few hundred parameters, fresh matrices cost more
  // in page faults than the factorisation.
  thread_local Eigen::MatrixXd factor;
  thread_local Eigen::VectorXd triangular;
  thread_local std::vector<int32_t> one_block(1);
  one_block[0] = n;
  CompressBlockTriangular(one_block, squared_norm, &jtj, &jtr, &triangular, &factor);
  out.head(n) = triangular.head(n);
  const double compressed = triangular.head(n).squaredNorm();
  out[n] = std::sqrt(std::max(0.0, squared_norm - compressed));
  for (size_t b = 0, cb = 0; b < sizes.size(); cb += sizes[b], ++b) {
    if (jacobians[b] == nullptr) continue;
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(jacobians[b], n + 1,
                                                                                           sizes[b]);
    jac.topRows(n) = factor.middleCols(cb, sizes[b]);  // R's columns
    jac.row(n).setZero();
  }
}

// The compression for terms that can form their normal equations directly
// (without the m by n Jacobian): subclasses give |r|^2, J^T J and J^T r.
class NormalEquationsCost : public ceres::CostFunction {
 public:
  // parameter_block_sizes: as the term's parameters.
  explicit NormalEquationsCost(const std::vector<int32_t>& parameter_block_sizes) {
    int n = 0;
    for (int size : parameter_block_sizes) {
      mutable_parameter_block_sizes()->push_back(size);
      n += size;
    }
    set_num_residuals(n + 1);
  }
  // jtj and jtr are null when only the cost is wanted.
  virtual bool EvaluateNormalEquations(double const* const* parameters, double* squared_norm, Eigen::MatrixXd* jtj,
                                       Eigen::VectorXd* jtr) const = 0;

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    double squared_norm = 0.0;
    const bool want = jacobians != nullptr;
    if (!EvaluateNormalEquations(parameters, &squared_norm, want ? &jtj_ : nullptr, want ? &jtr_ : nullptr)) {
      return false;
    }
    if (!want) {
      jtj_.resize(0, 0);
      jtr_.resize(num_residuals() - 1);
    }
    WriteCompressedResiduals(parameter_block_sizes(), squared_norm, jtj_, jtr_, residuals, jacobians);
    return true;
  }

 private:
  mutable Eigen::MatrixXd jtj_;
  mutable Eigen::VectorXd jtr_;
};

// Compresses any CostFunction (it forms J, then J^T J).
class CompressedCost : public ceres::CostFunction {
 public:
  // Takes ownership of `inner`.
  explicit CompressedCost(ceres::CostFunction* inner) : inner_(inner) {
    num_columns_ = 0;
    for (int size : inner->parameter_block_sizes()) {
      mutable_parameter_block_sizes()->push_back(size);
      num_columns_ += size;
    }
    set_num_residuals(num_columns_ + 1);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int m = inner_->num_residuals(), n = num_columns_;
    const std::vector<int32_t>& sizes = inner_->parameter_block_sizes();
    full_residuals_.resize(m);
    const bool want_jacobians = jacobians != nullptr;
    std::vector<double*> inner_jacobians(sizes.size(), nullptr);
    if (want_jacobians) {
      block_jacobians_.resize(sizes.size());
      for (size_t b = 0; b < sizes.size(); ++b) {
        block_jacobians_[b].resize(m, sizes[b]);
        inner_jacobians[b] = block_jacobians_[b].data();
      }
    }
    if (!inner_->Evaluate(parameters, full_residuals_.data(), want_jacobians ? inner_jacobians.data() : nullptr)) {
      return false;
    }
    Eigen::MatrixXd jtj;
    Eigen::VectorXd jtr(n);
    if (want_jacobians) {
      jtj.resize(n, n);
      for (size_t a = 0, ca = 0; a < sizes.size(); ca += sizes[a], ++a) {
        jtr.segment(ca, sizes[a]).noalias() = block_jacobians_[a].transpose() * full_residuals_;
        for (size_t b = 0, cb = 0; b <= a; cb += sizes[b], ++b) {
          jtj.block(ca, cb, sizes[a], sizes[b]).noalias() = block_jacobians_[a].transpose() * block_jacobians_[b];
          if (b != a) jtj.block(cb, ca, sizes[b], sizes[a]) = jtj.block(ca, cb, sizes[a], sizes[b]).transpose();
        }
      }
    }
    WriteCompressedResiduals(sizes, full_residuals_.squaredNorm(), jtj, jtr, residuals, jacobians);
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  int num_columns_ = 0;
  mutable Eigen::VectorXd full_residuals_;
  // Row-major, as Ceres writes them.
  mutable std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> block_jacobians_;
};

}  // namespace polyfit

#endif  // COST_FUNCTIONS_COMPRESSED_COST_H_
