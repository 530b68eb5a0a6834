// A post-process for a drape that the network predicted: position-based
// passes (strain limiting as in Provot 1995, projections as in Mueller et
// al. 2007's position-based dynamics) that move every edge toward its rest
// length and keep the vertices that touch the body on its outer side.
//
// Each pass, Gauss-Seidel over the edges in a fixed order (deterministic):
//   d = x_j - x_i,  c = (|d| - L) / |d|,  x_i += c d / 2,  x_j -= c d / 2
// then, per contact (a vertex, the body's closest point p and outward
// normal n, found once from the exact signed distance):
//   x += max(0, offset - n . (x - p)) n
// The body's surface is linearised at each contact once: a pass costs
// #E + #contacts small updates, no distance query.
#ifndef POLYFIT_DRAPE_SIMULATE_STRAIN_LIMIT_H_
#define POLYFIT_DRAPE_SIMULATE_STRAIN_LIMIT_H_

#include <vector>

#include <Eigen/Core>

#include "drape/eval/cloth_energy.h"

namespace polyfit {

// A vertex near the body: the tangent plane it must stay above.
struct BodyContact {
  int vertex = 0;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // closest body point
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // outward, unit
};

// positions: 3 by #V, moved in place; rest.edges and rest.edge_length are
// used. offset (m): how far above its plane a contact is put.
void LimitStrain(const ClothRest& rest, const std::vector<BodyContact>& contacts, int passes, double offset,
                 Eigen::Matrix3Xd* positions);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_STRAIN_LIMIT_H_
