// Mirroring a pose across the body's sagittal plane (x = 0 in the rest
// pose), for augmentation: with M = diag(-1, 1, 1) and m(j) the joint's
// left/right partner (by name: "Left..." <-> "Right..."; unpaired joints
// are their own), the mirrored pose's rest-to-posed transform is
//   T'_j = M T_m(j) M,
// so a symmetric body posed by it is the mirror image of the original
// (a joint's posed head: T'_j h_j = M T_m(j) h_m(j), since h_m(j) = M h_j).
#ifndef POLYFIT_DRAPE_MOTION_MIRROR_POSE_H_
#define POLYFIT_DRAPE_MOTION_MIRROR_POSE_H_

#include <vector>

#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"

namespace polyfit {

// #joints: each joint's partner. Throws std::invalid_argument naming a
// "Left..." or "Right..." joint whose partner is missing.
std::vector<int> MirrorJointMap(const Skeleton& skeleton);

// The mirrored pose (one rest-to-posed transform per joint).
std::vector<Eigen::Isometry3d> MirrorPose(const std::vector<Eigen::Isometry3d>& rest_to_posed,
                                          const std::vector<int>& joint_map);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_MOTION_MIRROR_POSE_H_
