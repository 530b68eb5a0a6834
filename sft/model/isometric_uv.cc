#include "sft/model/isometric_uv.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/SVD>

#include "polyfit/jet/jet_basis.h"

namespace polyfit {
namespace {

constexpr int kMaxDalpha = kMaxJetCoefficients - 3;
const double kRootHalf = std::sqrt(0.5);
const double kRoot2 = std::sqrt(2.0);

// A slope g = |grad z| lengthens the surface along grad z by sqrt(1 + g^2)
// per unit of (u, v): the uv that keeps lengths shortens along it by
// 1 - 1 / sqrt(1 + g^2) = f(g^2) g^2,
//   f(q) = 1 / (sqrt(1 + q) (1 + sqrt(1 + q))),
// f(0) = 1/2 (von Karman's) and bounded for a steep slope, where the
// first-order 1/2 g^2 would ask for more than all of it.
double SlideFactor(double q, double* derivative) {
  const double r = std::sqrt(1.0 + q), d = r + r * r;
  *derivative = -(1.0 + 2.0 * r) / (2.0 * r * d * d);
  return 1.0 / d;
}

}  // namespace

IsometricUvField::IsometricUvField(const JetDeformationModel& model, int patch) {
  if (!model.can_split()) throw std::invalid_argument("IsometricUvField: the model has no compact uv field");
  std::vector<int> vertices;
  for (int i = 0; i < model.num_vertices(); ++i) {
    if (model.patch_of_vertex(i) == patch) vertices.push_back(i);
  }
  if (vertices.empty()) throw std::invalid_argument("IsometricUvField: patch " + std::to_string(patch) + " is empty");
  order_ = model.patch().order;
  const int num_alpha = NumJetCoefficients(order_);
  const int uv_order = model.uv_order();
  const int m = NumJetCoefficients(uv_order) - 1;  // the field's monomials without the constant
  const int n = static_cast<int>(vertices.size());
  alpha0_ = Eigen::Map<const Eigen::VectorXd>(model.patch().coefficients.data(), num_alpha);
  slope_u_.resize(n, num_alpha);
  slope_v_.resize(n, num_alpha);
  Eigen::MatrixXd strain = Eigen::MatrixXd::Zero(3 * n, 2 * m);
  double mono[kMaxJetCoefficients], mono_u[kMaxJetCoefficients], mono_v[kMaxJetCoefficients];
  for (int r = 0; r < n; ++r) {
    const double u = model.uv()(0, vertices[r]), v = model.uv()(1, vertices[r]);
    JetMonomialGradients(order_, u, v, mono, mono_u, mono_v);
    for (int k = 0; k < num_alpha; ++k) {
      slope_u_(r, k) = mono_u[k];
      slope_v_(r, k) = mono_v[k];
    }
    JetMonomialGradients(uv_order, u, v, mono, mono_u, mono_v);
    for (int k = 0; k < m; ++k) {
      strain(3 * r, k) = mono_u[k + 1];                      // du_u
      strain(3 * r + 1, k) = kRootHalf * mono_v[k + 1];      // sqrt2 (du_v + dv_u) / 2
      strain(3 * r + 1, m + k) = kRootHalf * mono_u[k + 1];
      strain(3 * r + 2, m + k) = mono_v[k + 1];              // dv_v
    }
  }
  // The turn du = -w v, dv = w u strains nothing: a null direction, and
  // too few vertices leave more; the pseudo-inverse sets them to zero.
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(strain, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  const double floor = 1e-9 * (s.size() > 0 ? s(0) : 0.0);
  Eigen::VectorXd inverse(s.size());
  for (int k = 0; k < s.size(); ++k) inverse(k) = s(k) > floor ? 1.0 / s(k) : 0.0;
  pseudo_inverse_ = svd.matrixV() * inverse.asDiagonal() * svd.matrixU().transpose();
}

void IsometricUvField::Evaluate(const double* block, double* coefficients, double* jacobian) const {
  const int num_alpha = static_cast<int>(alpha0_.size());
  const int nd = num_alpha - 3, nc = num_duv();
  double alpha[kMaxJetCoefficients];
  for (int k = 0; k < num_alpha; ++k) alpha[k] = alpha0_(k) + (k >= 3 ? block[k - 3] : 0.0);
  Eigen::Map<Eigen::VectorXd> c(coefficients, nc);
  c.setZero();
  using Rows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 3, kMaxDalpha>;
  Rows dt(3, nd);
  if (jacobian != nullptr) Eigen::Map<Eigen::MatrixXd>(jacobian, nc, nd).setZero();
  for (int r = 0; r < slope_u_.rows(); ++r) {
    double zu = 0.0, zv = 0.0, zu0 = 0.0, zv0 = 0.0;
    for (int k = 1; k < num_alpha; ++k) {
      zu += slope_u_(r, k) * alpha[k];
      zv += slope_v_(r, k) * alpha[k];
      zu0 += slope_u_(r, k) * alpha0_(k);
      zv0 += slope_v_(r, k) * alpha0_(k);
    }
    // t = -(f(g^2) grad z grad z^T - f(g0^2) grad z0 grad z0^T), its rows.
    double df, df0;
    const double f = SlideFactor(zu * zu + zv * zv, &df), f0 = SlideFactor(zu0 * zu0 + zv0 * zv0, &df0);
    const Eigen::Vector3d t(-(f * zu * zu - f0 * zu0 * zu0), -kRoot2 * (f * zu * zv - f0 * zu0 * zv0),
                            -(f * zv * zv - f0 * zv0 * zv0));
    const auto p = pseudo_inverse_.middleCols<3>(3 * r);
    c.noalias() += p * t;
    if (jacobian == nullptr) continue;
    for (int j = 0; j < nd; ++j) {
      const double su = slope_u_(r, j + 3), sv = slope_v_(r, j + 3);
      const double dq = 2.0 * (zu * su + zv * sv);  // d(g^2)
      dt(0, j) = -(df * dq * zu * zu + 2.0 * f * zu * su);
      dt(1, j) = -kRoot2 * (df * dq * zu * zv + f * (su * zv + zu * sv));
      dt(2, j) = -(df * dq * zv * zv + 2.0 * f * zv * sv);
    }
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jacobian, nc, nd).noalias() +=
        p * dt;
  }
}

std::vector<IsometricUvField> IsometricUvFields(const JetDeformationModel& model) {
  std::vector<IsometricUvField> fields;
  if (!model.can_split()) return fields;
  fields.reserve(model.num_patches());
  for (int p = 0; p < model.num_patches(); ++p) fields.emplace_back(model, p);
  return fields;
}

}  // namespace polyfit
