// Mixed poses, for augmentation: a clip's limbs moved as another clip's,
// so that training sees combinations of joint angles no recorded clip has
// (a dance's arms over a walk's legs) while each limb keeps a recorded,
// smooth motion. With L_j = T_p(j)^-1 T_j the rotation of joint j relative
// to its parent (it fixes the joint's rest head, so any parent carries it
// and bones stay connected), the mixed pose is
//   T'_root = T_root of the base,
//   T'_j = T'_p(j) L_j of source s(j) (the base, or a donor).
#ifndef POLYFIT_DRAPE_MOTION_MIX_POSE_H_
#define POLYFIT_DRAPE_MOTION_MIX_POSE_H_

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"

namespace polyfit {

// #joints: the index of the group (0 .. #roots - 1) whose named root joint
// is the joint or its nearest grouped ancestor, -1 for joints in none
// (they stay with the base). Throws std::invalid_argument naming a root
// the rig lacks.
std::vector<int> JointGroups(const Skeleton& skeleton, const std::vector<std::string>& group_roots);

// The limb groups MixPoses is used with on the MakeHuman/CMU rig: each
// arm from the shoulder, the neck and head, the spine above the hips.
std::vector<std::string> DefaultMixGroups();

// The mixed pose: base's root and ungrouped joints, and for each group g
// the local rotations of donors[g]. groups: JointGroups; donors: one pose
// per group (one transform per joint each). Throws std::invalid_argument
// on sizes that disagree.
std::vector<Eigen::Isometry3d> MixPoses(const Skeleton& skeleton, const std::vector<Eigen::Isometry3d>& base,
                                        const std::vector<const std::vector<Eigen::Isometry3d>*>& donors,
                                        const std::vector<int>& groups);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_MOTION_MIX_POSE_H_
