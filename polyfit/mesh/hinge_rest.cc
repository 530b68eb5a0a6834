#include "polyfit/mesh/hinge_rest.h"

#include "cost_functions/hinge_bending.h"

namespace polyfit {

HingeRest MeasureHingeRest(const TriangleMesh& rest) {
  HingeRest out;
  out.hinges = InteriorHinges(rest);
  const Eigen::VectorXd face_areas = FaceAreas(rest);
  for (const MeshHinge& hinge : out.hinges) {
    const auto& [i, j, k, l] = hinge.vertices;
    out.angles.push_back(SignedDihedralAngle(rest.vertices.col(i).data(), rest.vertices.col(j).data(),
                                             rest.vertices.col(k).data(), rest.vertices.col(l).data()));
    const double areas = face_areas[hinge.faces[0]] + face_areas[hinge.faces[1]];
    const double length = (rest.vertices.col(i) - rest.vertices.col(j)).norm();
    out.weights.push_back(areas > 0.0 ? 3.0 * length * length / areas : 0.0);
  }
  return out;
}

}  // namespace polyfit
