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

  std::string Validate() const;
};

class JetDeformationModel {
 public:
  // Fits the template (3 by #V, camera frame) with one patch. Throws
  // std::invalid_argument on invalid options or a template that is no
  // height field over its PCA plane (flagged by the fit).
  JetDeformationModel(const JetDeformationOptions& options, const Eigen::Matrix3Xd& template_vertices);

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
  JetDeformationOptions options_;
  JetPatch patch_;
  Eigen::Matrix2Xd uv_;
  // Monomials of the uv field at each vertex's template (u, v), without the
  // constant: (NumJetCoefficients(m) - 1) by #V.
  Eigen::MatrixXd uv_monomials_;
  int num_dalpha_ = 0;
  int num_duv_ = 0;
  double template_rms_error_ = 0.0;
};

}  // namespace polyfit

#endif  // POLYFIT_SFT_MODEL_JET_DEFORMATION_H_
