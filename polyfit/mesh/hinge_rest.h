// A surface's bending rest state, hinge by hinge (discrete shells).
#ifndef POLYFIT_MESH_HINGE_REST_H_
#define POLYFIT_MESH_HINGE_REST_H_

#include <vector>

#include <Eigen/Core>

#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// Per interior hinge of the mesh (InteriorHinges, #H): its signed dihedral
// angle (SignedDihedralAngle, cost_functions/hinge_bending.h) and the
// discrete-shell weight 3 |e|^2 / (A_1 + A_2) that makes
// sum_h weight_h (theta_h - angle_h)^2 approximate the integral of the
// squared mean curvature (times 4) whatever the resolution (0 where both
// faces have no area).
struct HingeRest {
  std::vector<MeshHinge> hinges;
  std::vector<double> angles;
  std::vector<double> weights;
};

HingeRest MeasureHingeRest(const TriangleMesh& rest);

// Per hinge (#H), how far its signed dihedral angle turned from `before`
// to `now` (3 by #V each), in degrees, wrapped into [0, 180].
std::vector<double> HingeTurnsDeg(const std::vector<MeshHinge>& hinges, const Eigen::Matrix3Xd& now,
                                  const Eigen::Matrix3Xd& before);

}  // namespace polyfit

#endif  // POLYFIT_MESH_HINGE_REST_H_
