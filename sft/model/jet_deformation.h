// The paper's deformation model: the template is one PolyFit patch (frame
// O = (s, R_O, T_O) and an n-jet alpha), each vertex has parameters
// (u_i, v_i) on it, and a deformed mesh is
//   X_i = s R_O (R_c phi(u_i + du_i, v_i + dv_i; alpha + dalpha) + T_c) + T_O,
//   phi(u, v; alpha) = (u, v, z(u, v; alpha) + e_i).
// e_i, the template's detail, is what the jet misses of vertex i at rest
// (its height above the fitted jet, in the frame; 0 with keep_detail
// off): the model is the template exactly at zero parameters however
// far the template is from one n-jet (a sag between pins, a real scan's
// wrinkles), and the detail is carried in the frame as the jet deforms.
// The uv displacement is either a compact field (du, dv each an m-jet in
// (u, v): 2 (NumJetCoefficients(m) - 1) numbers; the constant is T_c's) or
// per vertex (2 #V numbers). dalpha covers orders 2..n (orders 0 and 1 are
// the rigid motion's). Parameters, in this order:
//   [dalpha | du, dv | omega (R_c = exp(omega), angle-axis) | T_c].
//
// The atlas: the template's vertices are split among patches, each with
// its own parameter block (the layout above) and its own centre c_k (in the
// frame's (u, v, z); the whole template's is 0), about which it turns:
//   X_i = s R_O (R_k (phi(u_i + du_k, v_i + dv_k; alpha + dalpha_k) - c_k) + c_k + T_k) + T_O.
// Every patch keeps the template's frame, jet and (u, v), so a patch split
// in children that inherit its block (InheritParameters) leaves the surface
// exactly where it was: refinement adds freedom, never a jump. theta is the
// blocks in patch order. One patch, the paper's model, until SplitPatch.
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

#include <ceres/rotation.h>
#include <Eigen/Core>

#include "polyfit/jet/jet_surface.h"
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
  // Keep what the jet misses of the template as per-vertex detail e_i.
  bool keep_detail = true;

  std::string Validate() const;
};

// What SplitPatch did: patch `patch` became itself and the patches
// first_new .. first_new + num_children - 2.
struct PatchSplit {
  int patch = 0;
  int first_new = 0;
  int num_children = 0;
  Eigen::Vector3d parent_centre = Eigen::Vector3d::Zero();
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
  // One patch's parameters: [dalpha | du, dv | omega | T].
  int block_size() const { return num_dalpha_ + num_duv_ + 6; }
  int num_patches() const { return static_cast<int>(centres_.size()); }
  int num_parameters() const { return num_patches() * block_size(); }
  int num_dalpha() const { return num_dalpha_; }
  int num_duv() const { return num_duv_; }
  int rotation_offset() const { return num_dalpha_ + num_duv_; }
  int translation_offset() const { return num_dalpha_ + num_duv_ + 3; }
  const JetPatch& patch() const { return patch_; }
  // 2 by #V template parameters.
  const Eigen::Matrix2Xd& uv() const { return uv_; }
  // RMS distance between the template and its jet (what the detail holds;
  // the model at zero parameters is that far from the template without
  // keep_detail, and exact with it).
  double template_rms_error() const { return template_rms_error_; }

  // The atlas. #V patch indices.
  const std::vector<int>& vertex_patches() const { return vertex_patch_; }
  int patch_of_vertex(int i) const { return vertex_patch_[i]; }
  // Patch p's centre c_p, about which it turns (frame coordinates).
  const Eigen::Vector3d& centre(int p) const { return centres_[p]; }
  // Vertices per patch.
  std::vector<int> PatchSizes() const;
  // Only the patch jet with a compact uv field splits (per-vertex uv and
  // the texture-space field keep one patch).
  bool can_split() const { return !texture_space_ && options_.uv_displacement == UvDisplacement::kCompactField; }
  // child_of_vertex (#V): for the vertices of `patch`, which of its
  // num_children children takes them (0 keeps the patch's index; the others
  // are appended); other entries are ignored. Throws std::invalid_argument
  // when the model cannot split or a child would be empty.
  PatchSplit SplitPatch(int patch, const std::vector<int>& child_of_vertex);
  // theta from before `split`, extended so that every child carries on
  // exactly as its parent: same jet and uv field, and the same rigid motion
  // about its own centre.
  std::vector<double> InheritParameters(const PatchSplit& split, const std::vector<double>& theta) const;

  // Vertices (3 by #V) for parameters theta, and optionally their Jacobian
  // (3 #V by num_parameters, row 3 i + k is coordinate k of vertex i; for
  // per-vertex uv only the vertex's own two columns are non-zero).
  void Evaluate(const double* theta, Eigen::Matrix3Xd* vertices, Eigen::MatrixXd* jacobian = nullptr) const;
  // The same with each vertex's Jacobian against its own patch's block only
  // (3 #V by block_size(); rows 3 i .. 3 i + 2 are d X_i / d theta_p,
  // p = patch_of_vertex(i)): the rest of its row is zero.
  void EvaluateLocal(const double* theta, Eigen::Matrix3Xd* vertices, Eigen::MatrixXd* local_jacobian) const;
  // Vertex i where patch p (its own or not) puts it, from p's block;
  // jacobian (3 by block_size(), row-major) may be null.
  void EvaluateVertex(int i, int p, const double* block, double* x, double* jacobian) const;

  // Vertex i where patch p puts it, and p's unit normal there: the
  // definition EvaluateVertex differentiates by hand (patch jet only), for
  // automatic differentiation.
  template <typename T>
  void VertexOnPatch(int i, int p, const T* block, T* x, T* normal) const {
    PointOnPatch(uv_(0, i), uv_(1, i), uv_monomials_.rows() > 0 ? uv_monomials_.col(i).data() : nullptr, detail_[i],
                 p, block, x, normal);
  }
  // The midpoint of the template's edge (i, j) where patch p puts it, and
  // p's normal there: the point half-way in (u, v) and in detail, so that
  // two patches meeting at an angle along the edge's middle agree on it.
  template <typename T>
  void EdgeMidpointOnPatch(int i, int j, int p, const T* block, T* x, T* normal) const;
  // The same point and normal, with their Jacobian against p's block
  // (jacobian: 6 by block_size(), row-major, the point's rows then the
  // normal's; null: none) differentiated by one jet over the few
  // quantities the block moves (u, v, z, z_u, z_v, the rotation, the
  // translation) and chained by hand: a seam's cost, once per edge
  // instead of a jet pass per eight parameters.
  void EdgeMidpointJacobian(int i, int j, int p, const double* block, double* x, double* normal,
                            double* jacobian) const;

 private:
  // The surface point at template (u0, v0) with detail e where patch p
  // puts it: uv_monomials are the uv field's monomials at (u0, v0) without
  // the constant (null without a compact field).
  template <typename T>
  void PointOnPatch(double u0, double v0, const double* uv_monomials, double detail, int p, const T* block, T* x,
                    T* normal) const;
  // Its two stages: the point's (u, v) moved by the block's uv field and
  // the jet's coefficients with the block's offsets (alpha:
  // NumJetCoefficients(order)); then the height graph's point and normal
  // there (d) placed by the patch's rigid motion and frame.
  template <typename T>
  void ShiftedJet(double u0, double v0, const double* uv_monomials, const T* block, T* u, T* v, T* alpha) const;
  template <typename T>
  void PlaceOnPatch(const T& u, const T& v, const JetHeightDerivatives<T>& d, double detail, int p, const T* rotation,
                    const T* translation, T* x, T* normal) const;

  void EvaluateTextureSpace(int i, const double* block, double* x, double* jacobian) const;
  void EvaluatePatchJet(int i, int p, const double* block, double* x, double* jacobian) const;
  JetDeformationOptions options_;
  JetPatch patch_;
  Eigen::Matrix2Xd uv_;
  // Monomials of the uv field at each vertex's template (u, v), without the
  // constant: (NumJetCoefficients(m) - 1) by #V.
  Eigen::MatrixXd uv_monomials_;
  int num_dalpha_ = 0;
  int num_duv_ = 0;
  double template_rms_error_ = 0.0;
  Eigen::VectorXd detail_;  // #V heights e_i (zero without keep_detail; empty in texture space)
  // The atlas: each vertex's patch, each patch's centre (frame coordinates).
  std::vector<int> vertex_patch_;
  std::vector<Eigen::Vector3d> centres_;
  // The texture-space fallback.
  bool texture_space_ = false;
  Eigen::Matrix3Xd template_;
  Eigen::Vector3d centroid_ = Eigen::Vector3d::Zero();
  // Monomials of (s, t) at each vertex without the constant: (K - 1) by #V.
  Eigen::MatrixXd st_monomials_;
};

template <typename T>
void JetDeformationModel::EdgeMidpointOnPatch(int i, int j, int p, const T* block, T* x, T* normal) const {
  const double u0 = 0.5 * (uv_(0, i) + uv_(0, j)), v0 = 0.5 * (uv_(1, i) + uv_(1, j));
  double monomials[kMaxJetCoefficients];
  const bool compact = uv_monomials_.rows() > 0;
  if (compact) JetMonomials(options_.uv_order, u0, v0, monomials);
  PointOnPatch(u0, v0, compact ? monomials + 1 : nullptr, 0.5 * (detail_[i] + detail_[j]), p, block, x, normal);
}

template <typename T>
void JetDeformationModel::PointOnPatch(double u0, double v0, const double* uv_monomials, double detail, int p,
                                       const T* block, T* x, T* normal) const {
  T u, v, alpha[kMaxJetCoefficients];
  ShiftedJet(u0, v0, uv_monomials, block, &u, &v, alpha);
  PlaceOnPatch(u, v, EvaluateJetDerivatives(patch_.order, alpha, u, v), detail, p, block + rotation_offset(),
               block + translation_offset(), x, normal);
}

template <typename T>
void JetDeformationModel::ShiftedJet(double u0, double v0, const double* uv_monomials, const T* block, T* u, T* v,
                                     T* alpha) const {
  const int num_alpha = NumJetCoefficients(patch_.order);
  for (int k = 0; k < num_alpha; ++k) alpha[k] = T(patch_.coefficients[k]) + (k >= 3 ? block[k - 3] : T(0.0));
  const int m = static_cast<int>(uv_monomials_.rows());
  T du(0.0), dv(0.0);
  for (int k = 0; k < m; ++k) {
    du += block[num_dalpha_ + k] * uv_monomials[k];
    dv += block[num_dalpha_ + m + k] * uv_monomials[k];
  }
  *u = T(u0) + du;
  *v = T(v0) + dv;
}

template <typename T>
void JetDeformationModel::PlaceOnPatch(const T& u, const T& v, const JetHeightDerivatives<T>& d, double detail, int p,
                                       const T* rotation, const T* translation, T* x, T* normal) const {
  const Eigen::Vector3d& c = centres_[p];
  const T phi[3] = {u - c.x(), v - c.y(), d.z + detail - c.z()};
  T local_normal[3], moved[3], turned[3];
  JetNormal(d, local_normal);
  ceres::AngleAxisRotatePoint(rotation, phi, moved);
  ceres::AngleAxisRotatePoint(rotation, local_normal, turned);
  for (int k = 0; k < 3; ++k) moved[k] += c[k] + translation[k];
  const Eigen::Matrix3d& frame = patch_.frame.rotation;
  for (int r = 0; r < 3; ++r) {
    x[r] = T(patch_.frame.translation[r]);
    normal[r] = T(0.0);
    for (int k = 0; k < 3; ++k) {
      x[r] += T(patch_.frame.scale * frame(r, k)) * moved[k];
      normal[r] += T(frame(r, k)) * turned[k];
    }
  }
}

// Per-vertex texture coordinates (2 by #V) from per-corner ones: the mean
// of each vertex's corners (vertices on a texture seam get a compromise).
Eigen::Matrix2Xd VertexTexcoords(const Eigen::Matrix3Xi& faces, const Eigen::Matrix2Xd& corner_texcoords,
                                 int num_vertices);

}  // namespace polyfit

#endif  // POLYFIT_SFT_MODEL_JET_DEFORMATION_H_
