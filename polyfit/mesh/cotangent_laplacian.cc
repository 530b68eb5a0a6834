#include "polyfit/mesh/cotangent_laplacian.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include <Eigen/Geometry>
#include <suitesparse/cholmod.h>

namespace polyfit {

CotangentLaplacian MakeCotangentLaplacian(const TriangleMesh& mesh, bool clamp_negative_weights) {
  const int n = mesh.num_vertices();
  // Half-weights per directed edge, then summed per edge after sorting.
  std::vector<std::pair<std::pair<int, int>, double>> half;
  half.reserve(static_cast<size_t>(mesh.num_faces()) * 6);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      // The angle at corner c faces the edge (i, j).
      const int o = mesh.faces(c, f), i = mesh.faces((c + 1) % 3, f), j = mesh.faces((c + 2) % 3, f);
      const Eigen::Vector3d a = mesh.vertices.col(i) - mesh.vertices.col(o);
      const Eigen::Vector3d b = mesh.vertices.col(j) - mesh.vertices.col(o);
      const double sine = a.cross(b).norm();
      if (!(sine > 1e-12 * a.squaredNorm() + 1e-300) || i == j) continue;
      const double w = 0.5 * a.dot(b) / sine;
      half.push_back({{i, j}, w});
      half.push_back({{j, i}, w});
    }
  }
  std::sort(half.begin(), half.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  CotangentLaplacian laplacian;
  laplacian.offsets.assign(n + 1, 0);
  for (size_t k = 0; k < half.size();) {
    size_t end = k;
    double w = 0.0;
    for (; end < half.size() && half[end].first == half[k].first; ++end) w += half[end].second;
    if (clamp_negative_weights ? w > 0.0 : w != 0.0) {
      laplacian.neighbour.push_back(half[k].first.second);
      laplacian.weight.push_back(w);
      ++laplacian.offsets[half[k].first.first + 1];
    }
    k = end;
  }
  for (int v = 0; v < n; ++v) laplacian.offsets[v + 1] += laplacian.offsets[v];
  return laplacian;
}

Eigen::MatrixXd CotangentLaplacian::Apply(const Eigen::MatrixXd& fields) const {
  Eigen::MatrixXd out(fields.rows(), fields.cols());
  for (int i = 0; i < num_vertices(); ++i) {
    out.row(i).setZero();
    for (int k = offsets[i]; k < offsets[i + 1]; ++k)
      out.row(i) += weight[k] * (fields.row(i) - fields.row(neighbour[k]));
  }
  return out;
}

void CotangentLaplacian::ApplyToColumns(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd* out) const {
  for (int i = 0; i < num_vertices(); ++i) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int k = offsets[i]; k < offsets[i + 1]; ++k) sum += weight[k] * (x.col(i) - x.col(neighbour[k]));
    out->col(i) = sum;
  }
}

Eigen::MatrixXd CotangentLaplacian::ToDense() const {
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(num_vertices(), num_vertices());
  for (int i = 0; i < num_vertices(); ++i) {
    for (int k = offsets[i]; k < offsets[i + 1]; ++k) {
      dense(i, neighbour[k]) -= weight[k];
      dense(i, i) += weight[k];
    }
  }
  return dense;
}

namespace {

// One implicit step for all columns: solves (M + tau C L) x = M b.
// Free vertices (rate > 0) form the symmetric positive definite system
// (M / rate + tau L) x = M b / rate, held ones keep b's values (their
// coupling moves to the right side). The free block is factored once by
// CHOLMOD (sparse Cholesky, fill-reducing order) and every step and column
// reuses the factor: conjugate gradients took hundreds of products per
// column and step on a finely split garment (1.5 s for a suit's skinning).
class ImplicitStep {
 public:
  ImplicitStep(const CotangentLaplacian& laplacian, const Eigen::VectorXd& mass, const std::vector<double>& rate,
               double tau)
      : laplacian_(laplacian), tau_(tau), row_(mass.size(), -1), scaled_mass_(mass.size()) {
    cholmod_start(&common_);
    // Simplicial LDL^T: no BLAS, so the same weights whatever BLAS and
    // threads a machine has (as fast as supernodal at these sizes).
    common_.supernodal = CHOLMOD_SIMPLICIAL;
    const int n = static_cast<int>(mass.size());
    for (int i = 0; i < n; ++i) {
      const bool held = !(rate[i] > 0.0) || laplacian.offsets[i] == laplacian.offsets[i + 1];
      scaled_mass_[i] = held ? mass[i] : mass[i] / rate[i];
      if (!held) {
        row_[i] = static_cast<int>(vertex_.size());
        vertex_.push_back(i);
      }
    }
    if (vertex_.empty()) return;
    // The lower triangle, column by column (CHOLMOD's compressed columns).
    const size_t m = vertex_.size();
    cholmod_sparse* system =
        cholmod_allocate_sparse(m, m, m + laplacian.weight.size() / 2 + 1, 1, 1, -1, CHOLMOD_REAL, &common_);
    if (system == nullptr) Fail("DiffuseHeat: out of memory for the implicit step");
    int* column_start = static_cast<int*>(system->p);
    int* row = static_cast<int*>(system->i);
    double* value = static_cast<double*>(system->x);
    int nonzeros = 0;
    std::vector<std::pair<int, double>> below;
    for (size_t c = 0; c < m; ++c) {
      const int i = vertex_[c];
      column_start[c] = nonzeros;
      double sum = 0.0;
      below.clear();
      for (int k = laplacian.offsets[i]; k < laplacian.offsets[i + 1]; ++k) {
        sum += laplacian.weight[k];
        const int r = row_[laplacian.neighbour[k]];
        if (r > static_cast<int>(c)) below.emplace_back(r, -tau * laplacian.weight[k]);
      }
      std::sort(below.begin(), below.end());
      row[nonzeros] = static_cast<int>(c);
      value[nonzeros++] = scaled_mass_[i] + tau * sum;
      for (const auto& [r, w] : below) {
        row[nonzeros] = r;
        value[nonzeros++] = w;
      }
    }
    column_start[m] = nonzeros;
    factor_ = cholmod_analyze(system, &common_);
    const bool factored = factor_ != nullptr && cholmod_factorize(system, factor_, &common_) &&
                          common_.status == CHOLMOD_OK && factor_->minor == factor_->n;
    cholmod_free_sparse(&system, &common_);
    if (!factored) Fail("DiffuseHeat: the implicit step's system could not be factored");
  }
  ~ImplicitStep() { Release(); }
  ImplicitStep(const ImplicitStep&) = delete;
  ImplicitStep& operator=(const ImplicitStep&) = delete;

  // x = A b for every column (#V by k); held rows give b.
  void Solve(const Eigen::MatrixXd& b, Eigen::MatrixXd* x) {
    *x = b;
    if (vertex_.empty()) return;
    const size_t m = vertex_.size();
    cholmod_dense* rhs = cholmod_allocate_dense(m, b.cols(), m, CHOLMOD_REAL, &common_);
    if (rhs == nullptr) throw std::runtime_error("DiffuseHeat: out of memory for the implicit step");
    // Right side over the free vertices, the held ones' coupling folded in.
    Eigen::Map<Eigen::MatrixXd> right(static_cast<double*>(rhs->x), static_cast<Eigen::Index>(m), b.cols());
    for (size_t r = 0; r < m; ++r) {
      const int i = vertex_[r];
      right.row(r) = scaled_mass_[i] * b.row(i);
      for (int k = laplacian_.offsets[i]; k < laplacian_.offsets[i + 1]; ++k) {
        const int j = laplacian_.neighbour[k];
        if (row_[j] < 0) right.row(r) += tau_ * laplacian_.weight[k] * b.row(j);
      }
    }
    cholmod_dense* solved = cholmod_solve(CHOLMOD_A, factor_, rhs, &common_);
    cholmod_free_dense(&rhs, &common_);
    if (solved == nullptr) throw std::runtime_error("DiffuseHeat: the implicit step could not be solved");
    const Eigen::Map<const Eigen::MatrixXd> out(static_cast<const double*>(solved->x), static_cast<Eigen::Index>(m),
                                                b.cols());
    for (size_t r = 0; r < m; ++r) x->row(vertex_[r]) = out.row(r);
    cholmod_free_dense(&solved, &common_);
  }

 private:
  void Release() {
    if (factor_ != nullptr) cholmod_free_factor(&factor_, &common_);
    cholmod_finish(&common_);
  }
  // A constructor that throws runs no destructor: CHOLMOD's memory first.
  [[noreturn]] void Fail(const char* message) {
    Release();
    throw std::runtime_error(message);
  }

  const CotangentLaplacian& laplacian_;
  double tau_;
  std::vector<int> row_;     // per vertex, its row in the system, -1 if held
  std::vector<int> vertex_;  // per row, its vertex
  Eigen::VectorXd scaled_mass_;
  cholmod_common common_;
  cholmod_factor* factor_ = nullptr;
};

}  // namespace

Eigen::MatrixXd DiffuseHeat(const TriangleMesh& mesh, const Eigen::MatrixXd& fields, double t,
                            const std::vector<double>& rate, int substeps) {
  const int n = mesh.num_vertices();
  if (fields.rows() != n) throw std::invalid_argument("DiffuseHeat: one row of fields per vertex is needed");
  if (!rate.empty() && static_cast<int>(rate.size()) != n)
    throw std::invalid_argument("DiffuseHeat: one rate per vertex is needed");
  if (!(t >= 0.0) || substeps < 1) throw std::invalid_argument("DiffuseHeat: t >= 0 and substeps >= 1 are needed");
  for (const double r : rate) {
    if (!(r >= 0.0)) throw std::invalid_argument("DiffuseHeat: rates must be >= 0");
  }
  if (n == 0 || t == 0.0) return fields;
  const CotangentLaplacian laplacian = MakeCotangentLaplacian(mesh);
  const Eigen::VectorXd mass = VertexAreas(mesh);
  ImplicitStep step(laplacian, mass, rate.empty() ? std::vector<double>(n, 1.0) : rate, t / substeps);
  // Most joints touch no garment: only the non-zero fields are diffused.
  std::vector<Eigen::Index> live;
  for (Eigen::Index c = 0; c < fields.cols(); ++c) {
    if (fields.col(c).cwiseAbs().maxCoeff() != 0.0) live.push_back(c);
  }
  Eigen::MatrixXd out = fields;
  if (live.empty()) return out;
  Eigen::MatrixXd columns(n, static_cast<Eigen::Index>(live.size())), next;
  for (size_t c = 0; c < live.size(); ++c) columns.col(c) = fields.col(live[c]);
  for (int s = 0; s < substeps; ++s) {
    step.Solve(columns, &next);
    columns.swap(next);
  }
  for (size_t c = 0; c < live.size(); ++c) out.col(live[c]) = columns.col(c);
  return out;
}

}  // namespace polyfit
