// The paper's deformation model: the template is one PolyFit patch (frame
// O = (s, R_O, T_O) and an n-jet alpha), each vertex has parameters
// (u_i, v_i) on it, and a deformed mesh is
//   X_i = s R_O (R_c phi(u_i + du_i, v_i + dv_i; alpha + dalpha) + T_c) + T_O,
//   phi(u, v; alpha) = (u, v, z(u, v; alpha)).
// The uv displacement is either a compact field (du, dv each an m-jet in
// (u, v): 2 (NumJetCoefficients(m) - 1) numbers; the constant is T_c's) or
// per vertex (2 #V numbers). dalpha covers orders 2..n (orders 0 and 1 are
// the rigid motion's). Parameters, in this order:
//   [dalpha | du, dv | omega (R_c = exp(omega), angle-axis) | T_c].
//
// Templates that are no height field over one plane (a cylinder, a folded
// cloth) fall back to a texture-space field: the template's texture
// coordinates (s, t) parameterise it whatever its shape, and
//   X_i = R_c (X0_i - c) + c + T_c + D(s_i, t_i),
// D = (D_x, D_y, D_z) three n-jets in (s, t) without constants (c: the
// template's centroid). Parameters: [D_x, D_y, D_z | omega | T_c].
#ifndef POLYFIT_SFT_MODEL_JET_DEFORMATION_H_
#define POLYFIT_SFT_MODEL_JET_DEFORMATION_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/patch/jet_patch.h"

namespace polyfit {

enum class UvDisplacement {
  // du and dv are m-jets in (u, v): few parameters, smooth, fast.
  kCompactField,
  // One (du, dv) per vertex, as in the paper.
  kPerVertex,
};

struct JetDeformationOptions {
  int jet_order = 4;
  UvDisplacement uv_displacement = UvDisplacement::kCompactField;
  int uv_order = 3;
  // Use the texture-space field even for a height-field template.
  bool texture_space = false;

  std::string Validate() const;
};

class JetDeformationModel {
 public:
  // Fits the template (3 by #V, camera frame) with one patch. When it is no
  // height field over its PCA plane and vertex_texcoords (2 by #V) are
  // given, uses the texture-space field instead; without them, throws
  // std::invalid_argument (also on invalid options or a degenerate
  // template).
  JetDeformationModel(const JetDeformationOptions& options, const Eigen::Matrix3Xd& template_vertices,
                      const Eigen::Matrix2Xd* vertex_texcoords = nullptr);

  // True when the texture-space fallback is in use.
  bool texture_space() const { return texture_space_; }

  int num_vertices() const { return static_cast<int>(uv_.cols()); }
  int num_parameters() const { return num_dalpha_ + num_duv_ + 6; }
  int num_dalpha() const { return num_dalpha_; }
  int num_duv() const { return num_duv_; }
  int rotation_offset() const { return num_dalpha_ + num_duv_; }
  int translation_offset() const { return num_dalpha_ + num_duv_ + 3; }
  const JetPatch& patch() const { return patch_; }
  // 2 by #V template parameters.
  const Eigen::Matrix2Xd& uv() const { return uv_; }
  // RMS distance between the template and the model at zero parameters.
  double template_rms_error() const { return template_rms_error_; }

  // Vertices (3 by #V) for parameters theta, and optionally their Jacobian
  // (3 #V by num_parameters, row 3 i + k is coordinate k of vertex i; for
  // per-vertex uv only the vertex's own two columns are non-zero).
  void Evaluate(const double* theta, Eigen::Matrix3Xd* vertices, Eigen::MatrixXd* jacobian = nullptr) const;

 private:
  void EvaluateTextureSpace(const double* theta, Eigen::Matrix3Xd* vertices, Eigen::MatrixXd* jacobian) const;
  void EvaluatePatchJet(const double* theta, Eigen::Matrix3Xd* vertices, Eigen::MatrixXd* jacobian) const;
  JetDeformationOptions options_;
  JetPatch patch_;
  Eigen::Matrix2Xd uv_;
  // Monomials of the uv field at each vertex's template (u, v), without the
  // constant: (NumJetCoefficients(m) - 1) by #V.
  Eigen::MatrixXd uv_monomials_;
  int num_dalpha_ = 0;
  int num_duv_ = 0;
  double template_rms_error_ = 0.0;
  // The texture-space fallback.
  bool texture_space_ = false;
  Eigen::Matrix3Xd template_;
  Eigen::Vector3d centroid_ = Eigen::Vector3d::Zero();
  // Monomials of (s, t) at each vertex without the constant: (K - 1) by #V.
  Eigen::MatrixXd st_monomials_;
};

// Per-vertex texture coordinates (2 by #V) from per-corner ones: the mean
// of each vertex's corners (vertices on a texture seam get a compromise).
Eigen::Matrix2Xd VertexTexcoords(const Eigen::Matrix3Xi& faces, const Eigen::Matrix2Xd& corner_texcoords,
                                 int num_vertices);

}  // namespace polyfit

#endif  // POLYFIT_SFT_MODEL_JET_DEFORMATION_H_
