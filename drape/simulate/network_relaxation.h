// The relaxation that follows the network's prediction within its
// inference (`onefit drape`, on by default): strain-limiting passes
// (StrainLimiter) against the body's planes under the garment, skinned
// from rest (SkinnedContacts: no distance query), every vertex tethered
// near the prediction; where the prediction lies deep below a bound
// plane, the plane is the nearest body sample's instead. A pass is linear
// in the garment's edges: past a budget of edge updates a frame, a finer
// garment gets fewer passes, so that the inference's time stays nearly
// flat in the garment's resolution, as the network's does.
#ifndef POLYFIT_DRAPE_SIMULATE_NETWORK_RELAXATION_H_
#define POLYFIT_DRAPE_SIMULATE_NETWORK_RELAXATION_H_

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"
#include "drape/network/body_proximity.h"
#include "drape/simulate/skinned_contacts.h"
#include "drape/simulate/strain_limit.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// The tether keeps the relaxation to what it is for, the strain between
// neighbours that the network's patches leave: untethered, a garment
// stretched as a whole contracts along its length, its vertices slide
// centimetres from where their planes were bound and through the body
// where it is not convex (the suit decimated to 547 vertices: 1.43% ->
// 1.88% inside). 2 cm is the reach over which the post-process trusts its
// planes (DrapeSolver::kStrainLimitContactReach). 12 passes keep the
// suit's frame (2,136 vertices) within 1 ms on one core here (15: 1.00
// ms; docs/benchmarks.md).
struct NetworkRelaxationOptions {
  int passes = 12;
  double contact_reach = 0.03;  // m: vertices this near the body at rest get a plane
  double offset = 2e-3;         // m: how far above its plane a vertex is kept
  double max_move = 0.02;       // m: the tether
  // At most this many edge updates a frame: passes times edges (12 passes
  // up to 12,500 edges, about 4,000 vertices); at least one pass.
  int max_edge_updates = 150000;
  // m: a prediction this far below its bound plane is taken to be over
  // another part of the body (a plane bound to a thigh that has swung
  // since): its plane is then the nearest body sample's
  // (PosedBodySamples: the body's vertices 3 cm apart, posed only in the
  // frames that need it). Infinite: the bound planes always.
  double suspect_depth = 0.01;
};

class NetworkRelaxation {
 public:
  // body: the body the garment is draped on (rest mesh, skinning weights);
  // garment_rest: the garment in the body's rest pose (what strain is
  // measured against).
  NetworkRelaxation(const SkinnedBody& body, const TriangleMesh& garment_rest,
                    const NetworkRelaxationOptions& options = {});

  // positions: 3 by #V, the network's drape at `rest_to_posed` (one
  // transform per joint), relaxed in place. posed (or null): the body's
  // samples already posed at rest_to_posed (OneFitDraper::posed_body(), at
  // the default spacing), which saves posing its own. Not thread-safe
  // (buffers, the posed samples).
  void Apply(const std::vector<Eigen::Isometry3d>& rest_to_posed, Eigen::Matrix3Xd* positions,
             const PosedBodySamples* posed = nullptr) const;

  // The passes this garment gets (options.passes within the budget).
  int passes() const { return passes_; }

 private:
  // posed_'s planes that the prediction (positions) lies suspect_depth
  // below, where the body's samples (posed, or samples_ posed here) say it
  // is outside, replaced by the nearest sample's.
  void ReplaceSuspectPlanes(const std::vector<Eigen::Isometry3d>& rest_to_posed, const Eigen::Matrix3Xd& positions,
                            const PosedBodySamples* posed) const;

  NetworkRelaxationOptions options_;
  SkinnedContacts contacts_;
  std::unique_ptr<PosedBodySamples> samples_;  // posed when a plane is suspect
  StrainLimiter limiter_;
  int passes_ = 0;
  mutable std::vector<BodyContact> posed_;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_NETWORK_RELAXATION_H_
