#include "polyfit/model/orient_patches.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "polyfit/mesh/per_face_normals.h"

namespace polyfit {

int OrientPatchesLikeFaces(const TriangleMesh& mesh, PolyFitModel* model) {
  const Eigen::Matrix3Xd normals = PerFaceNormals(mesh);
  const Eigen::VectorXd areas = FaceAreas(mesh);
  std::vector<Eigen::Vector3d> normal(model->num_patches(), Eigen::Vector3d::Zero());
  for (int f = 0; f < mesh.num_faces(); ++f) normal[model->face_patch[f]] += areas[f] * normals.col(f);
  std::vector<bool> flip(model->num_patches(), false);
  int turned = 0;
  for (int p = 0; p < model->num_patches(); ++p) {
    JetPatch& patch = model->patches[p];
    if (normal[p].dot(patch.frame.rotation.col(2)) >= 0.0) continue;
    flip[p] = true;
    ++turned;
    patch.frame.rotation.col(1) *= -1.0;
    patch.frame.rotation.col(2) *= -1.0;
    int k = 0;
    for (int d = 0; d <= patch.order; ++d) {
      for (int b = 0; b <= d; ++b, ++k) patch.coefficients[k] *= (b % 2 == 0) ? -1.0 : 1.0;
    }
  }
  for (int k = 0; k < model->num_memberships(); ++k) {
    if (flip[model->membership_patch[k]]) model->membership_uv(1, k) *= -1.0;
  }
  return turned;
}

void TurnPatchAboutNormal(double theta, JetPatch* patch) {
  const double c = std::cos(theta), s = std::sin(theta);
  const int n = patch->order;
  // Binomial coefficients and the powers of c, s and -s, up to the order.
  double binomial[kMaxJetOrder + 1][kMaxJetOrder + 1] = {};
  for (int a = 0; a <= n; ++a) {
    binomial[a][0] = 1.0;
    for (int i = 1; i <= a; ++i) binomial[a][i] = binomial[a - 1][i - 1] + (i < a ? binomial[a - 1][i] : 0.0);
  }
  double cp[kMaxJetOrder + 1], sp[kMaxJetOrder + 1], msp[kMaxJetOrder + 1];
  cp[0] = sp[0] = msp[0] = 1.0;
  for (int i = 1; i <= n; ++i) cp[i] = cp[i - 1] * c, sp[i] = sp[i - 1] * s, msp[i] = msp[i - 1] * -s;
  // u^a v^b = sum_i sum_j C(a,i) C(b,j) c^(a-i) (-s)^i s^(b-j) c^j u'^(a-i+b-j) v'^(i+j)
  std::array<double, kMaxJetCoefficients> turned{};
  for (int a = 0; a <= n; ++a) {
    for (int b = 0; a + b <= n; ++b) {
      const double alpha = patch->coefficients[JetCoefficientIndex(a, b)];
      if (alpha == 0.0) continue;
      for (int i = 0; i <= a; ++i) {
        for (int j = 0; j <= b; ++j) {
          turned[JetCoefficientIndex(a - i + b - j, i + j)] +=
              alpha * binomial[a][i] * binomial[b][j] * cp[a - i] * msp[i] * sp[b - j] * cp[j];
        }
      }
    }
  }
  patch->coefficients = turned;
  const Eigen::Vector3d u = patch->frame.rotation.col(0), v = patch->frame.rotation.col(1);
  patch->frame.rotation.col(0) = c * u + s * v;
  patch->frame.rotation.col(1) = -s * u + c * v;
}

double AlignPatchFrames(const Eigen::Vector3d& primary, const Eigen::Vector3d& secondary, PolyFitModel* model) {
  const double min_sine = std::sin(15.0 * M_PI / 180.0);
  std::vector<double> theta(model->num_patches(), 0.0);
  double largest = 0.0;
  for (int p = 0; p < model->num_patches(); ++p) {
    JetPatch& patch = model->patches[p];
    const Eigen::Matrix3d& r = patch.frame.rotation;
    Eigen::Vector3d target = primary - primary.dot(r.col(2)) * r.col(2);
    if (target.norm() < min_sine * primary.norm()) target = secondary - secondary.dot(r.col(2)) * r.col(2);
    if (!(target.norm() > 0.0)) continue;
    theta[p] = std::atan2(target.dot(r.col(1)), target.dot(r.col(0)));
    TurnPatchAboutNormal(theta[p], &patch);
    largest = std::max(largest, std::abs(theta[p]));
  }
  for (int k = 0; k < model->num_memberships(); ++k) {
    const double t = theta[model->membership_patch[k]];
    const double c = std::cos(t), s = std::sin(t), u = model->membership_uv(0, k), v = model->membership_uv(1, k);
    model->membership_uv(0, k) = c * u + s * v;
    model->membership_uv(1, k) = -s * u + c * v;
  }
  return largest;
}

}  // namespace polyfit
