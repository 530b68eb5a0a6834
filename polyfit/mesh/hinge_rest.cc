#include "polyfit/mesh/hinge_rest.h"

#include <Eigen/Geometry>

#include "cost_functions/hinge_bending.h"

namespace polyfit {

HingeRest MeasureHingeRest(const TriangleMesh& rest) {
  HingeRest out;
  out.hinges = InteriorHinges(rest);
  auto area = [&](int f) {
    const Eigen::Vector3d a = rest.vertices.col(rest.faces(0, f)), b = rest.vertices.col(rest.faces(1, f)),
                          c = rest.vertices.col(rest.faces(2, f));
    return 0.5 * (b - a).cross(c - a).norm();
  };
  for (const MeshHinge& hinge : out.hinges) {
    const auto& [i, j, k, l] = hinge.vertices;
    out.angles.push_back(SignedDihedralAngle(rest.vertices.col(i).data(), rest.vertices.col(j).data(),
                                             rest.vertices.col(k).data(), rest.vertices.col(l).data()));
    const double areas = area(hinge.faces[0]) + area(hinge.faces[1]);
    const double length = (rest.vertices.col(i) - rest.vertices.col(j)).norm();
    out.weights.push_back(areas > 0.0 ? 3.0 * length * length / areas : 0.0);
  }
  return out;
}

}  // namespace polyfit
