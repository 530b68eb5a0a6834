// Retargeting a BVH clip onto a body's rig by joint name, for skinning.
//
// The clips (CMU, cgspeed conversion) rest in a T-pose with spread legs;
// the MakeHuman rig rests in an A-pose, with its own bone lengths. Each
// rig bone j gets a fixed rest alignment A_j: the rotation that takes its
// rest bone vectors (to its children's heads) onto the clip's rest bone
// vectors (the smallest rotation for one child, the least-squares one for
// several; a leaf takes its parent's). Posed, bone j turns by
//   W_j(f) = C G_j(f) C_rest^-1 A_j
// with G_j the clip joint's world rotation, C_rest the turn about the
// vertical that maps the clip's rest frame onto the rig's, and C = C_rest H
// with H cancelling the clip's heading at frame 0 (so that the body starts
// facing as it rests). The
// rig's own bone lengths are kept: heads follow by forward kinematics from
// the root. The root's horizontal path is the clip's from frame 0, scaled by
// the ratio of leg lengths (hip to ankle); its height puts the rig's lowest
// joint as far above the rig's rest floor as the clip's lowest joint is
// above the clip's floor (its lowest over the clip), so feet stay on the
// ground and hops leave it. The result is one rest-to-posed transform
// per rig joint: x -> W_j (x - h_j) + p_j(f).
#ifndef POLYFIT_DRAPE_MOTION_RETARGET_H_
#define POLYFIT_DRAPE_MOTION_RETARGET_H_

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"
#include "drape/motion/bvh_motion.h"

namespace polyfit {

class MotionRetargeter {
 public:
  // Throws BvhError when no rig joint is found in the clip (or the clip has
  // no frame). Rig joints missing from the clip follow their parent.
  MotionRetargeter(const MotionClip& clip, const Skeleton& skeleton);

  int num_frames() const { return clip_.num_frames(); }
  double fps() const { return clip_.fps; }
  // Rig joints that matched a clip joint by name.
  int num_matched_joints() const { return num_matched_; }

  // Rest-to-posed transforms (#rig joints) for frame f. `blend` in [0, 1]
  // goes from the rest pose (0) to the frame's pose (1): rotations by slerp,
  // the root linearly; used to lead a garment into a clip's first pose.
  std::vector<Eigen::Isometry3d> Pose(int f, double blend = 1.0) const;
  // The root's velocity in the rig's frame at frame f (m/s).
  Eigen::Vector3d RootVelocity(int f) const;

 private:
  // Construction, in order. clip_rest: the clip's joint positions with every
  // rotation identity and the root at the origin.
  void MatchJoints();
  void AlignHeadings(const std::vector<Eigen::Vector3d>& clip_rest);
  void ComputeScale(const std::vector<Eigen::Vector3d>& clip_rest);
  void FindFloors();
  void AlignRestBones(const std::vector<Eigen::Vector3d>& clip_rest);

  MotionClip clip_;
  Skeleton skeleton_;
  std::vector<int> clip_joint_;                                      // per rig joint, or -1
  std::vector<Eigen::Quaterniond> rest_alignment_;                   // A_j
  Eigen::Quaterniond clip_to_rig_ = Eigen::Quaterniond::Identity();  // C
  Eigen::Quaterniond rest_turn_ = Eigen::Quaterniond::Identity();    // C_rest
  double scale_ = 1.0;
  double rig_floor_ = 0.0, clip_floor_ = 0.0;
  std::vector<double> clip_lowest_;  // per frame, the clip's lowest joint height
  int num_matched_ = 0;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_MOTION_RETARGET_H_
