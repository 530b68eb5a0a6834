#include "polyfit/mesh/cotangent_laplacian.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include <Eigen/Geometry>

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
// coupling moves to the right side).
class ImplicitStep {
 public:
  ImplicitStep(const CotangentLaplacian& laplacian, const Eigen::VectorXd& mass, const std::vector<double>& rate,
               double tau)
      : laplacian_(laplacian), tau_(tau), held_(mass.size(), false), scaled_mass_(mass.size()), diagonal_(mass.size()) {
    for (int i = 0; i < mass.size(); ++i) {
      held_[i] = !(rate[i] > 0.0) || laplacian.offsets[i] == laplacian.offsets[i + 1];
      scaled_mass_[i] = held_[i] ? mass[i] : mass[i] / rate[i];
      double sum = 0.0;
      for (int k = laplacian.offsets[i]; k < laplacian.offsets[i + 1]; ++k) sum += laplacian.weight[k];
      diagonal_[i] = scaled_mass_[i] + tau * sum;
    }
  }

  // x = A b for one column; held rows give b.
  void Solve(const Eigen::VectorXd& b, Eigen::VectorXd* x) const {
    const int n = static_cast<int>(b.size());
    // Right side over the free vertices, the held ones' coupling folded in.
    Eigen::VectorXd rhs(n);
    for (int i = 0; i < n; ++i) {
      if (held_[i]) {
        rhs[i] = 0.0;
        continue;
      }
      rhs[i] = scaled_mass_[i] * b[i];
      for (int k = laplacian_.offsets[i]; k < laplacian_.offsets[i + 1]; ++k) {
        if (held_[laplacian_.neighbour[k]]) rhs[i] += tau_ * laplacian_.weight[k] * b[laplacian_.neighbour[k]];
      }
    }
    *x = b;  // the start, and the held values
    Eigen::VectorXd r = rhs - Multiply(*x), z(n), p(n), q(n);
    // 1e-8 of the right side: weights below 1e-3 are dropped anyway.
    const double stop = 1e-16 * std::max(rhs.squaredNorm(), 1e-300);
    z = r.cwiseQuotient(diagonal_);
    p = z;
    double rz = r.dot(z);
    for (int it = 0; it < 10 * n + 100 && r.squaredNorm() > stop; ++it) {
      q = Multiply(p);
      const double alpha = rz / p.dot(q);
      *x += alpha * p;
      r -= alpha * q;
      z = r.cwiseQuotient(diagonal_);
      const double next = r.dot(z);
      p = z + (next / rz) * p;
      rz = next;
    }
  }

 private:
  // The free block of the system times v; held rows and columns are zero
  // (v's held entries are ignored, x's held entries stay put).
  Eigen::VectorXd Multiply(const Eigen::VectorXd& v) const {
    const int n = static_cast<int>(v.size());
    Eigen::VectorXd out(n);
    for (int i = 0; i < n; ++i) {
      if (held_[i]) {
        out[i] = 0.0;
        continue;
      }
      double sum = diagonal_[i] * v[i];
      for (int k = laplacian_.offsets[i]; k < laplacian_.offsets[i + 1]; ++k) {
        if (!held_[laplacian_.neighbour[k]]) sum -= tau_ * laplacian_.weight[k] * v[laplacian_.neighbour[k]];
      }
      out[i] = sum;
    }
    return out;
  }

  const CotangentLaplacian& laplacian_;
  double tau_;
  std::vector<bool> held_;
  Eigen::VectorXd scaled_mass_, diagonal_;
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
  const ImplicitStep step(laplacian, mass, rate.empty() ? std::vector<double>(n, 1.0) : rate, t / substeps);
  Eigen::MatrixXd out = fields;
  Eigen::VectorXd column(n), next(n);
  for (Eigen::Index c = 0; c < fields.cols(); ++c) {
    if (fields.col(c).cwiseAbs().maxCoeff() == 0.0) continue;  // most joints touch no garment
    column = fields.col(c);
    for (int s = 0; s < substeps; ++s) {
      step.Solve(column, &next);
      column.swap(next);
    }
    out.col(c) = column;
  }
  return out;
}

}  // namespace polyfit
