#include "drape/simulate/network_relaxation.h"

#include <algorithm>
#include <limits>

#include "drape/eval/cloth_energy.h"

namespace polyfit {

NetworkRelaxation::NetworkRelaxation(const SkinnedBody& body, const TriangleMesh& garment_rest,
                                     const NetworkRelaxationOptions& options)
    : options_(options),
      contacts_(body, garment_rest.vertices, options.contact_reach),
      limiter_(PrepareClothRest(garment_rest)) {
  if (options.suspect_depth < std::numeric_limits<double>::infinity()) {
    samples_ = std::make_unique<PosedBodySamples>(body);
  }
  if (options.passes > 0) {
    const long edges = std::max(1, limiter_.num_edges());
    passes_ = static_cast<int>(std::clamp<long>(options.max_edge_updates / edges, 1, options.passes));
  }
}

void NetworkRelaxation::Apply(const std::vector<Eigen::Isometry3d>& rest_to_posed, Eigen::Matrix3Xd* positions,
                              const PosedBodySamples* posed) const {
  if (passes_ == 0) return;
  contacts_.Pose(rest_to_posed, &posed_);
  if (samples_) ReplaceSuspectPlanes(rest_to_posed, *positions, posed);
  limiter_.Apply(posed_, passes_, options_.offset, positions, options_.max_move);
}

void NetworkRelaxation::ReplaceSuspectPlanes(const std::vector<Eigen::Isometry3d>& rest_to_posed,
                                             const Eigen::Matrix3Xd& positions, const PosedBodySamples* posed) const {
  const PosedBodySamples* samples = posed;
  for (BodyContact& c : posed_) {
    if (!(c.normal.dot(positions.col(c.vertex) - c.point) < -options_.suspect_depth)) continue;
    if (samples == nullptr) {
      samples_->Pose(rest_to_posed);
      samples = samples_.get();
    }
    // Only where the body there says the prediction is outside: deep
    // inside it, the bound plane is right (the network's error).
    const SignedDistanceResult r = samples->Query(positions.col(c.vertex));
    if (r.face < 0 || !(r.distance >= 0.0)) continue;
    c.point = r.closest;
    c.normal = r.normal;
  }
}

}  // namespace polyfit
