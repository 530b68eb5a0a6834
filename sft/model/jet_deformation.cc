#include "sft/model/jet_deformation.h"

#include <cmath>
#include <stdexcept>

#include <ceres/jet.h>
#include <ceres/rotation.h>

#include "polyfit/jet/jet_surface.h"
#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/patch/jet_fit.h"

namespace polyfit {

std::string JetDeformationOptions::Validate() const {
  if (jet_order < 2 || jet_order > kMaxJetOrder) return "jet_order must be in [2, 8]";
  if (uv_displacement == UvDisplacement::kCompactField && (uv_order < 1 || uv_order > kMaxJetOrder)) {
    return "uv_order must be in [1, 8]";
  }
  return {};
}

Eigen::Matrix2Xd VertexTexcoords(const Eigen::Matrix3Xi& faces, const Eigen::Matrix2Xd& corner_texcoords,
                                 int num_vertices) {
  Eigen::Matrix2Xd sum = Eigen::Matrix2Xd::Zero(2, num_vertices);
  Eigen::VectorXd count = Eigen::VectorXd::Zero(num_vertices);
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    for (int c = 0; c < 3; ++c) {
      sum.col(faces(c, f)) += corner_texcoords.col(3 * f + c);
      count[faces(c, f)] += 1.0;
    }
  }
  for (int v = 0; v < num_vertices; ++v) {
    if (count[v] > 0.0) sum.col(v) /= count[v];
  }
  return sum;
}

JetDeformationModel::JetDeformationModel(const JetDeformationOptions& options,
                                         const Eigen::Matrix3Xd& template_vertices,
                                         const Eigen::Matrix2Xd* vertex_texcoords)
    : options_(options) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("JetDeformationOptions: " + problem);
  }
  JetFitOptions fit;
  fit.order = options.jet_order;
  fit.refine_orientation = true;
  fit.refinement.max_iterations = 10;
  JetFitter fitter(fit);
  patch_ = fitter.Fit(template_vertices);
  if (patch_.flags & (kJetFitDegenerate | kJetFitRankDeficient)) {
    throw std::invalid_argument("JetDeformationModel: the template is degenerate (" +
                                JetFitFlagsToString(patch_.flags) + ")");
  }
  const int num_vertices = static_cast<int>(template_vertices.cols());
  if ((patch_.flags & kJetFitNotHeightField) || options.texture_space) {
    if (vertex_texcoords == nullptr || vertex_texcoords->cols() != num_vertices) {
      throw std::invalid_argument(
          "JetDeformationModel: the template is not a height field over one plane (it folds over), and without "
          "texture coordinates there is no texture-space fallback");
    }
    // The texture-space field, with (s, t) mapped to [-1, 1]^2.
    texture_space_ = true;
    template_ = template_vertices;
    centroid_ = template_vertices.rowwise().mean();
    const Eigen::Vector2d lo = vertex_texcoords->rowwise().minCoeff(), hi = vertex_texcoords->rowwise().maxCoeff();
    const Eigen::Vector2d span = (hi - lo).cwiseMax(1e-12);
    const int k = NumJetCoefficients(options.jet_order);
    st_monomials_.resize(k - 1, num_vertices);
    double monomials[kMaxJetCoefficients];
    for (int i = 0; i < num_vertices; ++i) {
      const Eigen::Vector2d st = 2.0 * (vertex_texcoords->col(i) - lo).cwiseQuotient(span).array() - 1.0;
      JetMonomials(options.jet_order, st.x(), st.y(), monomials);
      for (int j = 1; j < k; ++j) st_monomials_(j - 1, i) = monomials[j];
    }
    // The field's units: the template's size, so parameters are O(1).
    st_monomials_ *= BoundingBoxDiagonal(template_vertices);
    num_dalpha_ = 3 * (k - 1);
    num_duv_ = 0;
    uv_.setZero(2, num_vertices);
    template_rms_error_ = 0.0;
    return;
  }
  uv_.resize(2, num_vertices);
  double sum2 = 0.0;
  for (int i = 0; i < num_vertices; ++i) {
    const Eigen::Vector3d p = patch_.frame.PointToPatch(template_vertices.col(i));
    uv_.col(i) = p.head<2>();
    sum2 += (patch_.PointInWorld(p.x(), p.y()) - template_vertices.col(i)).squaredNorm();
  }
  template_rms_error_ = std::sqrt(sum2 / num_vertices);
  num_dalpha_ = NumJetCoefficients(patch_.order) - 3;
  if (options.uv_displacement == UvDisplacement::kCompactField) {
    const int m = NumJetCoefficients(options.uv_order);
    num_duv_ = 2 * (m - 1);
    uv_monomials_.resize(m - 1, num_vertices);
    double monomials[kMaxJetCoefficients];
    for (int i = 0; i < num_vertices; ++i) {
      JetMonomials(options.uv_order, uv_(0, i), uv_(1, i), monomials);
      for (int k = 1; k < m; ++k) uv_monomials_(k - 1, i) = monomials[k];
    }
  } else {
    num_duv_ = 2 * num_vertices;
  }
}

void JetDeformationModel::Evaluate(const double* theta, Eigen::Matrix3Xd* vertices, Eigen::MatrixXd* jacobian) const {
  if (texture_space_) {
    EvaluateTextureSpace(theta, vertices, jacobian);
  } else {
    EvaluatePatchJet(theta, vertices, jacobian);
  }
}

void JetDeformationModel::EvaluateTextureSpace(const double* theta, Eigen::Matrix3Xd* vertices,
                                               Eigen::MatrixXd* jacobian) const {
  {
    const int n = num_vertices(), m = static_cast<int>(st_monomials_.rows());
    const double* omega = theta + rotation_offset();
    const Eigen::Map<const Eigen::Vector3d> translation(theta + translation_offset());
    vertices->resize(3, n);
    if (jacobian != nullptr) jacobian->setZero(3 * n, num_parameters());
    using J3 = ceres::Jet<double, 3>;
    const J3 w[3] = {J3(omega[0], 0), J3(omega[1], 1), J3(omega[2], 2)};
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p = template_.col(i) - centroid_;
      const J3 q[3] = {J3(p.x()), J3(p.y()), J3(p.z())};
      J3 rotated[3];
      ceres::AngleAxisRotatePoint(w, q, rotated);
      for (int k = 0; k < 3; ++k) {
        double field = 0.0;
        for (int j = 0; j < m; ++j) field += theta[k * m + j] * st_monomials_(j, i);
        (*vertices)(k, i) = rotated[k].a + centroid_[k] + translation[k] + field;
      }
      if (jacobian == nullptr) continue;
      auto rows = jacobian->middleRows(3 * i, 3);
      for (int k = 0; k < 3; ++k) {
        for (int j = 0; j < m; ++j) rows(k, k * m + j) = st_monomials_(j, i);
        rows.block<1, 3>(k, rotation_offset()) = rotated[k].v.transpose();
        rows(k, translation_offset() + k) = 1.0;
      }
    }
  }
}

void JetDeformationModel::EvaluatePatchJet(const double* theta, Eigen::Matrix3Xd* vertices,
                                           Eigen::MatrixXd* jacobian) const {
  const int n = num_vertices(), order = patch_.order;
  const int num_alpha = NumJetCoefficients(order);
  double alpha[kMaxJetCoefficients];
  for (int k = 0; k < num_alpha; ++k) alpha[k] = patch_.coefficients[k] + (k >= 3 ? theta[k - 3] : 0.0);
  const double* duv = theta + num_dalpha_;
  const double* omega = theta + rotation_offset();
  const Eigen::Map<const Eigen::Vector3d> translation(theta + translation_offset());
  double rotation_data[9];
  ceres::AngleAxisToRotationMatrix(omega, ceres::ColumnMajorAdapter3x3(rotation_data));
  const Eigen::Map<const Eigen::Matrix3d> rotation(rotation_data);
  const Eigen::Matrix3d to_world = patch_.frame.scale * patch_.frame.rotation;
  const Eigen::Matrix3d to_world_rotated = to_world * rotation;
  const bool compact = options_.uv_displacement == UvDisplacement::kCompactField;
  const int m = compact ? static_cast<int>(uv_monomials_.rows()) : 0;

  vertices->resize(3, n);
  const int P = num_parameters();
  if (jacobian != nullptr) jacobian->setZero(3 * n, P);
  double monomials[kMaxJetCoefficients];
  for (int i = 0; i < n; ++i) {
    double du, dv;
    if (compact) {
      du = uv_monomials_.col(i).dot(Eigen::Map<const Eigen::VectorXd>(duv, m));
      dv = uv_monomials_.col(i).dot(Eigen::Map<const Eigen::VectorXd>(duv + m, m));
    } else {
      du = duv[2 * i];
      dv = duv[2 * i + 1];
    }
    const double u = uv_(0, i) + du, v = uv_(1, i) + dv;
    const JetHeightDerivatives<double> d = EvaluateJetDerivatives(order, alpha, u, v);
    const Eigen::Vector3d phi(u, v, d.z);
    const Eigen::Vector3d moved = rotation * phi + translation;
    vertices->col(i) = to_world * moved + patch_.frame.translation;
    if (jacobian == nullptr) continue;
    auto rows = jacobian->middleRows(3 * i, 3);
    // dalpha: dphi = (0, 0, monomial_k(u, v)).
    JetMonomials(order, u, v, monomials);
    for (int k = 3; k < num_alpha; ++k) rows.col(k - 3) = to_world_rotated.col(2) * monomials[k];
    // uv: dphi/du = (1, 0, z_u), dphi/dv = (0, 1, z_v).
    const Eigen::Vector3d dphi_du = to_world_rotated * Eigen::Vector3d(1.0, 0.0, d.z_u);
    const Eigen::Vector3d dphi_dv = to_world_rotated * Eigen::Vector3d(0.0, 1.0, d.z_v);
    if (compact) {
      for (int k = 0; k < m; ++k) {
        rows.col(num_dalpha_ + k) = dphi_du * uv_monomials_(k, i);
        rows.col(num_dalpha_ + m + k) = dphi_dv * uv_monomials_(k, i);
      }
    } else {
      rows.col(num_dalpha_ + 2 * i) = dphi_du;
      rows.col(num_dalpha_ + 2 * i + 1) = dphi_dv;
    }
    // omega: d(R(omega) phi)/d omega by forward-mode differentiation.
    using J3 = ceres::Jet<double, 3>;
    const J3 w[3] = {J3(omega[0], 0), J3(omega[1], 1), J3(omega[2], 2)};
    const J3 p[3] = {J3(phi.x()), J3(phi.y()), J3(phi.z())};
    J3 rotated[3];
    ceres::AngleAxisRotatePoint(w, p, rotated);
    Eigen::Matrix3d d_rotated;
    for (int r = 0; r < 3; ++r) d_rotated.row(r) = rotated[r].v.transpose();
    rows.middleCols(rotation_offset(), 3) = to_world * d_rotated;
    rows.middleCols(translation_offset(), 3) = to_world;
  }
}

}  // namespace polyfit
