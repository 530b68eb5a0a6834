#include "drape/simulate/strain_limit.h"

#include <cmath>
#include <limits>

namespace polyfit {

StrainLimiter::StrainLimiter(const ClothRest& rest) {
  // Edge e of run r is the edges' (r per + e)-th: each run keeps the
  // edges' order (neighbouring vertices, so that a pass carries a
  // correction across the garment), and runs far apart in it seldom share
  // a vertex.
  const size_t n = rest.edges.size(), per = (n + kRuns - 1) / kRuns;
  edges_.reserve(n);
  length_.reserve(n);
  for (size_t i = 0; i < per; ++i) {
    for (size_t e = i; e < n; e += per) {
      edges_.push_back(rest.edges[e]);
      length_.push_back(rest.edge_length[e]);
    }
  }
}

void StrainLimiter::Apply(const std::vector<BodyContact>& contacts, int passes, double offset,
                          Eigen::Matrix3Xd* positions, double max_move) const {
  Eigen::Matrix3Xd& x = *positions;
  const bool tethered = max_move < std::numeric_limits<double>::infinity();
  if (tethered) anchor_ = x;  // sized once for a garment
  for (int pass = 0; pass < passes; ++pass) {
    double* p = x.data();
    for (size_t e = 0; e < edges_.size(); ++e) {
      double* a = p + 3 * edges_[e][0];
      double* b = p + 3 * edges_[e][1];
      const double dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
      const double length = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (!(length > 0.0)) continue;
      const double k = 0.5 * (length - length_[e]) / length;
      a[0] += k * dx, a[1] += k * dy, a[2] += k * dz;
      b[0] -= k * dx, b[1] -= k * dy, b[2] -= k * dz;
    }
    if (tethered) {
      const double max_move2 = max_move * max_move;
      for (int v = 0; v < x.cols(); ++v) {
        const Eigen::Vector3d move = x.col(v) - anchor_.col(v);
        const double length2 = move.squaredNorm();
        if (length2 > max_move2) x.col(v) = anchor_.col(v) + (max_move / std::sqrt(length2)) * move;
      }
    }
    KeepAbovePlanes(contacts, offset, &x);
  }
}

void KeepAbovePlanes(const std::vector<BodyContact>& contacts, double offset, Eigen::Matrix3Xd* positions) {
  Eigen::Matrix3Xd& x = *positions;
  for (const BodyContact& c : contacts) {
    const double below = offset - c.normal.dot(x.col(c.vertex) - c.point);
    if (below > 0.0) x.col(c.vertex) += below * c.normal;
  }
}

void LimitStrain(const ClothRest& rest, const std::vector<BodyContact>& contacts, int passes, double offset,
                 Eigen::Matrix3Xd* positions) {
  StrainLimiter(rest).Apply(contacts, passes, offset, positions);
}

}  // namespace polyfit
