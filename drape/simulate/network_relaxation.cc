#include "drape/simulate/network_relaxation.h"

#include <algorithm>

#include "drape/eval/cloth_energy.h"

namespace polyfit {

NetworkRelaxation::NetworkRelaxation(const SkinnedBody& body, const TriangleMesh& garment_rest,
                                     const NetworkRelaxationOptions& options)
    : options_(options),
      contacts_(body, garment_rest.vertices, options.contact_reach),
      limiter_(PrepareClothRest(garment_rest)) {
  const long edges = std::max<long>(1, static_cast<long>(limiter_.num_edges()));
  passes_ = static_cast<int>(std::clamp<long>(options.max_edge_updates / edges, 1, std::max(options.passes, 1)));
  if (options.passes <= 0) passes_ = 0;
}

void NetworkRelaxation::Apply(const std::vector<Eigen::Isometry3d>& rest_to_posed,
                              Eigen::Matrix3Xd* positions) const {
  if (passes_ == 0) return;
  contacts_.Pose(rest_to_posed, &posed_);
  limiter_.Apply(posed_, passes_, options_.offset, positions, options_.max_move);
}

}  // namespace polyfit
