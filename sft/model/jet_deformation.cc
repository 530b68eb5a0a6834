#include "sft/model/jet_deformation.h"

#include <algorithm>
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
    vertex_patch_.assign(num_vertices, 0);
    centres_.assign(1, Eigen::Vector3d::Zero());
    return;
  }
  vertex_patch_.assign(num_vertices, 0);
  centres_.assign(1, Eigen::Vector3d::Zero());
  uv_.resize(2, num_vertices);
  double sum2 = 0.0;
  detail_.setZero(num_vertices);
  for (int i = 0; i < num_vertices; ++i) {
    const Eigen::Vector3d p = patch_.frame.PointToPatch(template_vertices.col(i));
    uv_.col(i) = p.head<2>();
    sum2 += (patch_.PointInWorld(p.x(), p.y()) - template_vertices.col(i)).squaredNorm();
    if (options.keep_detail)
      detail_[i] = p.z() - EvaluateJetHeight(patch_.order, patch_.coefficients.data(), p.x(), p.y());
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

std::vector<int> JetDeformationModel::PatchSizes() const {
  std::vector<int> sizes(num_patches(), 0);
  for (int p : vertex_patch_) ++sizes[p];
  return sizes;
}

PatchSplit JetDeformationModel::SplitPatch(int patch, const std::vector<int>& child_of_vertex) {
  if (!can_split())
    throw std::invalid_argument("JetDeformationModel: only the patch jet with a compact uv field splits");
  if (patch < 0 || patch >= num_patches() || static_cast<int>(child_of_vertex.size()) != num_vertices()) {
    throw std::invalid_argument("JetDeformationModel::SplitPatch: no such patch, or not one child per vertex");
  }
  PatchSplit split;
  split.patch = patch;
  split.first_new = num_patches();
  split.parent_centre = centres_[patch];
  for (int i = 0; i < num_vertices(); ++i) {
    if (vertex_patch_[i] == patch) split.num_children = std::max(split.num_children, child_of_vertex[i] + 1);
  }
  std::vector<Eigen::Vector3d> sum(split.num_children, Eigen::Vector3d::Zero());
  std::vector<int> count(split.num_children, 0);
  for (int i = 0; i < num_vertices(); ++i) {
    if (vertex_patch_[i] != patch) continue;
    const int c = child_of_vertex[i];
    if (c < 0) throw std::invalid_argument("JetDeformationModel::SplitPatch: negative child index");
    sum[c] += Eigen::Vector3d(uv_(0, i), uv_(1, i),
                              EvaluateJetHeight(patch_.order, patch_.coefficients.data(), uv_(0, i), uv_(1, i)));
    ++count[c];
  }
  for (int c = 0; c < split.num_children; ++c) {
    if (count[c] == 0) throw std::invalid_argument("JetDeformationModel::SplitPatch: a child has no vertex");
  }
  for (int i = 0; i < num_vertices(); ++i) {
    if (vertex_patch_[i] == patch && child_of_vertex[i] > 0)
      vertex_patch_[i] = split.first_new + child_of_vertex[i] - 1;
  }
  centres_[patch] = sum[0] / count[0];
  for (int c = 1; c < split.num_children; ++c) centres_.push_back(sum[c] / count[c]);
  return split;
}

std::vector<double> JetDeformationModel::InheritParameters(const PatchSplit& split,
                                                           const std::vector<double>& theta) const {
  const int b = block_size();
  std::vector<double> out(theta);
  out.resize(static_cast<size_t>(b) * (split.first_new + split.num_children - 1));
  const double* parent = theta.data() + static_cast<size_t>(b) * split.patch;
  double rotation_data[9];
  ceres::AngleAxisToRotationMatrix(parent + rotation_offset(), ceres::ColumnMajorAdapter3x3(rotation_data));
  const Eigen::Map<const Eigen::Matrix3d> rotation(rotation_data);
  const Eigen::Map<const Eigen::Vector3d> translation(parent + translation_offset());
  for (int c = 0; c < split.num_children; ++c) {
    const int child = c == 0 ? split.patch : split.first_new + c - 1;
    double* block = out.data() + static_cast<size_t>(b) * child;
    std::copy(parent, parent + b, block);
    // R (phi - c_p) + c_p + T = R (phi - c_k) + c_k + T_k.
    const Eigen::Vector3d shift = centres_[child] - split.parent_centre;
    Eigen::Map<Eigen::Vector3d> child_translation(block + translation_offset());
    child_translation = translation + rotation * shift - shift;
  }
  return out;
}

void JetDeformationModel::Evaluate(const double* theta, Eigen::Matrix3Xd* vertices, Eigen::MatrixXd* jacobian) const {
  const int n = num_vertices(), b = block_size();
  vertices->resize(3, n);
  if (jacobian != nullptr) jacobian->setZero(3 * n, num_parameters());
  Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> rows(3, b);
  for (int i = 0; i < n; ++i) {
    const int p = vertex_patch_[i];
    EvaluateVertex(i, p, theta + static_cast<size_t>(b) * p, vertices->col(i).data(),
                   jacobian != nullptr ? rows.data() : nullptr);
    if (jacobian != nullptr) jacobian->block(3 * i, static_cast<Eigen::Index>(b) * p, 3, b) = rows;
  }
}

void JetDeformationModel::EvaluateLocal(const double* theta, Eigen::Matrix3Xd* vertices,
                                        Eigen::MatrixXd* local_jacobian) const {
  const int n = num_vertices(), b = block_size();
  vertices->resize(3, n);
  local_jacobian->resize(3 * n, b);
  Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> rows(3, b);
  for (int i = 0; i < n; ++i) {
    const int p = vertex_patch_[i];
    EvaluateVertex(i, p, theta + static_cast<size_t>(b) * p, vertices->col(i).data(), rows.data());
    local_jacobian->middleRows(3 * i, 3) = rows;
  }
}

void JetDeformationModel::EvaluateVertex(int i, int p, const double* block, double* x, double* jacobian) const {
  if (texture_space_) {
    EvaluateTextureSpace(i, block, x, jacobian);
  } else {
    EvaluatePatchJet(i, p, block, x, jacobian);
  }
}

void JetDeformationModel::EvaluateTextureSpace(int i, const double* theta, double* x, double* jacobian) const {
  const int m = static_cast<int>(st_monomials_.rows()), b = block_size();
  const double* omega = theta + rotation_offset();
  const double* translation = theta + translation_offset();
  using J3 = ceres::Jet<double, 3>;
  const J3 w[3] = {J3(omega[0], 0), J3(omega[1], 1), J3(omega[2], 2)};
  const Eigen::Vector3d p = template_.col(i) - centroid_;
  const J3 q[3] = {J3(p.x()), J3(p.y()), J3(p.z())};
  J3 rotated[3];
  ceres::AngleAxisRotatePoint(w, q, rotated);
  for (int k = 0; k < 3; ++k) {
    double field = 0.0;
    for (int j = 0; j < m; ++j) field += theta[k * m + j] * st_monomials_(j, i);
    x[k] = rotated[k].a + centroid_[k] + translation[k] + field;
  }
  if (jacobian == nullptr) return;
  Eigen::Map<Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>> rows(jacobian, 3, b);
  rows.setZero();
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < m; ++j) rows(k, k * m + j) = st_monomials_(j, i);
    rows.block<1, 3>(k, rotation_offset()) = rotated[k].v.transpose();
    rows(k, translation_offset() + k) = 1.0;
  }
}

void JetDeformationModel::EdgeMidpointJacobian(int i, int j, int p, const double* block, double* x, double* normal,
                                               double* jacobian) const {
  if (jacobian == nullptr) {
    EdgeMidpointOnPatch(i, j, p, block, x, normal);
    return;
  }
  const double u0 = 0.5 * (uv_(0, i) + uv_(0, j)), v0 = 0.5 * (uv_(1, i) + uv_(1, j));
  const int m = static_cast<int>(uv_monomials_.rows());
  double uv_monomials[kMaxJetCoefficients];
  if (m > 0) JetMonomials(options_.uv_order, u0, v0, uv_monomials);
  double u, v, alpha[kMaxJetCoefficients];
  ShiftedJet(u0, v0, uv_monomials + 1, block, &u, &v, alpha);  // without the constant
  const int order = patch_.order, num_alpha = NumJetCoefficients(order);
  const JetHeightDerivatives<double> d = EvaluateJetDerivatives(order, alpha, u, v);
  // The jet's variables: 0 u, 1 v, 2..4 offsets of z, z_u, z_v, 5..7 the
  // rotation, 8..10 the translation.
  using J = ceres::Jet<double, 11>;
  JetHeightDerivatives<J> h{J(d.z), J(d.z_u), J(d.z_v), J(d.z_uu), J(d.z_uv), J(d.z_vv)};
  h.z.v[0] = d.z_u;
  h.z.v[1] = d.z_v;
  h.z.v[2] = 1.0;
  h.z_u.v[0] = d.z_uu;
  h.z_u.v[1] = d.z_uv;
  h.z_u.v[3] = 1.0;
  h.z_v.v[0] = d.z_uv;
  h.z_v.v[1] = d.z_vv;
  h.z_v.v[4] = 1.0;
  const double* r = block + rotation_offset();
  const double* t = block + translation_offset();
  const J rotation[3] = {J(r[0], 5), J(r[1], 6), J(r[2], 7)};
  const J translation[3] = {J(t[0], 8), J(t[1], 9), J(t[2], 10)};
  J out[6];
  PlaceOnPatch(J(u, 0), J(v, 1), h, 0.5 * (detail_[i] + detail_[j]), p, rotation, translation, out, out + 3);
  double m_z[kMaxJetCoefficients], m_u[kMaxJetCoefficients], m_v[kMaxJetCoefficients];
  JetMonomialGradients(order, u, v, m_z, m_u, m_v);
  const int b = block_size();
  for (int row = 0; row < 6; ++row) {
    const J& o = out[row];
    (row < 3 ? x : normal)[row % 3] = o.a;
    double* g = jacobian + static_cast<size_t>(row) * b;
    std::fill(g, g + b, 0.0);  // per-vertex uv: the midpoint does not move with it
    for (int a = 3; a < num_alpha; ++a) g[a - 3] = o.v[2] * m_z[a] + o.v[3] * m_u[a] + o.v[4] * m_v[a];
    for (int a = 0; a < m; ++a) {
      g[num_dalpha_ + a] = o.v[0] * uv_monomials[a + 1];
      g[num_dalpha_ + m + a] = o.v[1] * uv_monomials[a + 1];
    }
    for (int a = 0; a < 3; ++a) {
      g[rotation_offset() + a] = o.v[5 + a];
      g[translation_offset() + a] = o.v[8 + a];
    }
  }
}

void JetDeformationModel::EvaluatePatchJet(int i, int p, const double* theta, double* x, double* jacobian) const {
  const int order = patch_.order, num_alpha = NumJetCoefficients(order), b = block_size();
  double alpha[kMaxJetCoefficients];
  for (int k = 0; k < num_alpha; ++k) alpha[k] = patch_.coefficients[k] + (k >= 3 ? theta[k - 3] : 0.0);
  const double* duv = theta + num_dalpha_;
  const double* omega = theta + rotation_offset();
  const Eigen::Map<const Eigen::Vector3d> translation(theta + translation_offset());
  const bool compact = options_.uv_displacement == UvDisplacement::kCompactField;
  const int m = compact ? static_cast<int>(uv_monomials_.rows()) : 0;
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
  const Eigen::Vector3d& centre = centres_[p];
  const Eigen::Vector3d phi = Eigen::Vector3d(u, v, d.z + detail_[i]) - centre;
  // d(R(omega) phi)/d omega by forward-mode differentiation.
  using J3 = ceres::Jet<double, 3>;
  const J3 w[3] = {J3(omega[0], 0), J3(omega[1], 1), J3(omega[2], 2)};
  const J3 q[3] = {J3(phi.x()), J3(phi.y()), J3(phi.z())};
  J3 rotated[3];
  ceres::AngleAxisRotatePoint(w, q, rotated);
  const Eigen::Matrix3d to_world = patch_.frame.scale * patch_.frame.rotation;
  const Eigen::Vector3d moved = Eigen::Vector3d(rotated[0].a, rotated[1].a, rotated[2].a) + centre + translation;
  Eigen::Map<Eigen::Vector3d> position(x);
  position = to_world * moved + patch_.frame.translation;
  if (jacobian == nullptr) return;
  double rotation_data[9];
  ceres::AngleAxisToRotationMatrix(omega, ceres::ColumnMajorAdapter3x3(rotation_data));
  const Eigen::Matrix3d to_world_rotated = to_world * Eigen::Map<const Eigen::Matrix3d>(rotation_data);
  Eigen::Map<Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>> rows(jacobian, 3, b);
  if (!compact) rows.setZero();
  // dalpha: dphi = (0, 0, monomial_k(u, v)).
  double monomials[kMaxJetCoefficients];
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
  Eigen::Matrix3d d_rotated;
  for (int r = 0; r < 3; ++r) d_rotated.row(r) = rotated[r].v.transpose();
  rows.middleCols(rotation_offset(), 3) = to_world * d_rotated;
  rows.middleCols(translation_offset(), 3) = to_world;
}

}  // namespace polyfit
