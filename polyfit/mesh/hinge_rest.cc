#include "polyfit/mesh/hinge_rest.h"

#include <cmath>

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

std::vector<double> HingeTurnsDeg(const std::vector<MeshHinge>& hinges, const Eigen::Matrix3Xd& now,
                                  const Eigen::Matrix3Xd& before) {
  std::vector<double> turns;
  turns.reserve(hinges.size());
  for (const MeshHinge& hinge : hinges) {
    const auto& [i, j, k, l] = hinge.vertices;
    const double turn =
        SignedDihedralAngle(now.col(i).data(), now.col(j).data(), now.col(k).data(), now.col(l).data()) -
        SignedDihedralAngle(before.col(i).data(), before.col(j).data(), before.col(k).data(), before.col(l).data());
    turns.push_back(std::abs(std::remainder(turn, 2.0 * M_PI)) * 180.0 / M_PI);
  }
  return turns;
}

}  // namespace polyfit
