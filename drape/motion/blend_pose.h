// A pose blended from the rest pose, for leading a garment into a clip's
// first frame from rest: with R_j the rotation of joint j's rest-to-posed
// transform and h_j its rest head,
//   R'_j = slerp(I, R_j, b),
//   h'_root = h_root + b (T_root h_root - h_root),
//   h'_j = h'_p(j) + R'_p(j) (h_j - h_p(j)),
//   T'_j x = R'_j (x - h_j) + h'_j,
// so that bones stay connected at every b, b = 0 is the rest pose and
// b = 1 the pose itself (for a pose whose bones are connected).
#ifndef POLYFIT_DRAPE_MOTION_BLEND_POSE_H_
#define POLYFIT_DRAPE_MOTION_BLEND_POSE_H_

#include <vector>

#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"

namespace polyfit {

// rest_to_posed: one transform per joint; blend b in [0, 1]. Throws
// std::invalid_argument for a pose of another size or b outside [0, 1].
std::vector<Eigen::Isometry3d> BlendFromRest(const Skeleton& skeleton,
                                             const std::vector<Eigen::Isometry3d>& rest_to_posed, double blend);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_MOTION_BLEND_POSE_H_
