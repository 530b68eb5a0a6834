// The uv field a patch's bending asks for: the in-plane slide that keeps the
// template's lengths as the patch's jet bends. A slope g = |grad z|
// lengthens the surface along grad z by sqrt(1 + g^2) per unit of (u, v),
// so the uv that keeps lengths shortens along it by 1 - 1/sqrt(1 + g^2) =
// f(g^2) g^2, f(q) = 1 / (sqrt(1 + q) (1 + sqrt(1 + q))) (1/2 at q = 0:
// von Karman's membrane strain, bounded where that one asks for more than
// all of it). With duv = (du, dv) the model's compact field (coefficients
// c, monomials of the template's (u, v) without the constant), z the
// patch's jet (template's plus its offsets dalpha) and z0 the template's,
// the strain
//   eps = sym(grad duv) + f(|grad z|^2) grad z grad z^T - f(|grad z0|^2) grad z0 grad z0^T
// vanishes where the patch bends as a cylinder does. Over the patch's
// template vertices, in least squares (the shear counted twice, as in the
// strain's Frobenius norm),
//   c_iso(dalpha) = P t(dalpha),   t = -(eps's bending terms), per vertex,
// P the pseudo-inverse of the strain's linear map in c: the in-plane turn,
// which strains nothing, is left at zero. A cone or a saddle has no
// isometric field; c_iso is then the least-strained one.
//
// Why: neighbouring patches' uv fields tied alike (SharedUvCost) also tie
// how far each one's material slides as it bends, so that a fold inside
// one patch pulls its neighbours' fields with it; tied after c_iso is
// taken off, they share the slide their bending does not explain.
#ifndef POLYFIT_SFT_MODEL_ISOMETRIC_UV_H_
#define POLYFIT_SFT_MODEL_ISOMETRIC_UV_H_

#include <vector>

#include <Eigen/Core>

#include "sft/model/jet_deformation.h"

namespace polyfit {

class IsometricUvField {
 public:
  // Patch `patch` of `model` (a compact uv field; throws
  // std::invalid_argument otherwise or for an empty patch).
  IsometricUvField(const JetDeformationModel& model, int patch);

  // c_iso (num_duv values) for the patch's block (its dalpha, the
  // block's first num_dalpha values), and optionally its Jacobian against
  // them (num_duv by num_dalpha, row-major; null: none).
  void Evaluate(const double* block, double* coefficients, double* jacobian) const;

  int num_duv() const { return static_cast<int>(pseudo_inverse_.rows()); }
  int num_dalpha() const { return static_cast<int>(slope_u_.cols()) - 3; }

 private:
  int order_ = 0;
  // #P by NumJetCoefficients(order): the jet's monomials' u and v
  // derivatives at the patch's vertices (z_u = slope_u alpha).
  Eigen::MatrixXd slope_u_, slope_v_;
  Eigen::VectorXd alpha0_;  // the template's jet
  // num_duv by 3 #P: P, over the rows (uu, uv, vv) of each vertex.
  Eigen::MatrixXd pseudo_inverse_;
};

// One per patch of `model` (empty when the model cannot split).
std::vector<IsometricUvField> IsometricUvFields(const JetDeformationModel& model);

}  // namespace polyfit

#endif  // POLYFIT_SFT_MODEL_ISOMETRIC_UV_H_
