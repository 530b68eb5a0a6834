// A post-process for a drape that the network predicted: position-based
// passes (strain limiting as in Provot 1995, projections as in Mueller et
// al. 2007's position-based dynamics) that move every edge toward its rest
// length and keep the vertices that touch the body on its outer side.
//
// Each pass, Gauss-Seidel over the edges in a fixed order (deterministic;
// StrainLimiter's):
//   d = x_j - x_i,  c = (|d| - L) / |d|,  x_i += c d / 2,  x_j -= c d / 2
// then, with a tether of length r, every vertex held within r of where it
// started (x0):
//   x = x0 + min(1, r / |x - x0|) (x - x0)
// then, per contact (a vertex, the body's closest point p and outward
// normal n: found once from the exact signed distance in the post-process,
// skinned from rest in the network's relaxation, skinned_contacts.h):
//   x += max(0, offset - n . (x - p)) n
// The body's surface is linearised at each contact once: a pass costs
// #E + #contacts small updates, no distance query.
#ifndef POLYFIT_DRAPE_SIMULATE_STRAIN_LIMIT_H_
#define POLYFIT_DRAPE_SIMULATE_STRAIN_LIMIT_H_

#include <array>
#include <limits>
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

// The passes over a garment's edges in an order fixed once: the edges'
// own order dealt into kRuns interleaved runs (edge 0 of each run, then
// edge 1, ...). Within a run a pass still sweeps neighbour after neighbour
// across the garment; consecutive updates, from different runs, seldom
// touch the same vertex, so that each need not wait for the one before it
// to be stored. On the suit (the network's drape, 10 passes, untethered):
// the edges' own order 0.53 ms, 4 runs 0.28 ms at 0.06 points more
// epsilon_e; 8 runs 0.06 ms less again, at 0.1-0.2 points more, which
// more passes take back sooner; a greedy edge colouring (no two updates
// of a colour share a vertex) was as fast as 4 runs but gave 0.6 points
// more: within a run a pass carries a correction across the garment.
class StrainLimiter {
 public:
  // rest.edges and rest.edge_length are used.
  explicit StrainLimiter(const ClothRest& rest);
  // positions: 3 by #V (the rest's vertices), moved in place. offset (m):
  // how far above its plane a contact is put. max_move (m): after each
  // pass's edges, a vertex further than this from where it started is put
  // back at this distance (a tether; the contacts come after it). Not
  // thread-safe with a tether (the start is kept in a buffer).
  void Apply(const std::vector<BodyContact>& contacts, int passes, double offset, Eigen::Matrix3Xd* positions,
             double max_move = std::numeric_limits<double>::infinity()) const;

  int num_edges() const { return static_cast<int>(edges_.size()); }

  static constexpr int kRuns = 8;

 private:
  std::vector<std::array<int, 2>> edges_;
  std::vector<double> length_;
  mutable Eigen::Matrix3Xd anchor_;  // the positions a tethered Apply started from
};

// Each contact's vertex (in positions, 3 by #V) put `offset` above its
// plane where it is below: the contacts' step of a pass.
void KeepAbovePlanes(const std::vector<BodyContact>& contacts, double offset, Eigen::Matrix3Xd* positions);

// StrainLimiter(rest).Apply(...): for a single use.
void LimitStrain(const ClothRest& rest, const std::vector<BodyContact>& contacts, int passes, double offset,
                 Eigen::Matrix3Xd* positions);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_STRAIN_LIMIT_H_
