#include "polyfit/model/orient_patches.h"

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

}  // namespace polyfit
