#include "drape/simulate/strain_limit.h"

namespace polyfit {

void LimitStrain(const ClothRest& rest, const std::vector<BodyContact>& contacts, int passes, double offset,
                 Eigen::Matrix3Xd* positions) {
  Eigen::Matrix3Xd& x = *positions;
  for (int pass = 0; pass < passes; ++pass) {
    for (size_t e = 0; e < rest.edges.size(); ++e) {
      const int i = rest.edges[e][0], j = rest.edges[e][1];
      const Eigen::Vector3d d = x.col(j) - x.col(i);
      const double length = d.norm();
      if (!(length > 0.0)) continue;
      const Eigen::Vector3d move = (0.5 * (length - rest.edge_length[e]) / length) * d;
      x.col(i) += move;
      x.col(j) -= move;
    }
    for (const BodyContact& c : contacts) {
      const double below = offset - c.normal.dot(x.col(c.vertex) - c.point);
      if (below > 0.0) x.col(c.vertex) += below * c.normal;
    }
  }
}

}  // namespace polyfit
