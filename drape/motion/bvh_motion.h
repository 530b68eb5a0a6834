// Skeletal motion from BVH files: a joint hierarchy with per-frame local
// rotations and a root translation, forward kinematics, resampling to a
// frame rate, and the root's velocity (OneFit's dynamic terms).
#ifndef POLYFIT_DRAPE_MOTION_BVH_MOTION_H_
#define POLYFIT_DRAPE_MOTION_BVH_MOTION_H_

#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "polyfit/util/status.h"

namespace polyfit {

class BvhError : public Error {
 public:
  explicit BvhError(const std::string& message, ErrorKind kind = ErrorKind::kInput) : Error(kind, message) {}
};

struct MotionJoint {
  std::string name;
  int parent = -1;  // -1 for the root; parents precede their children
  // From the parent's joint to this one, in the parent's frame, metres.
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
};

struct MotionFrame {
  // The root joint's position (metres) and every joint's rotation relative
  // to its parent (the BVH channels composed in their listed order).
  Eigen::Vector3d root_translation = Eigen::Vector3d::Zero();
  std::vector<Eigen::Quaterniond> local_rotations;
};

struct MotionClip {
  std::vector<MotionJoint> joints;
  std::vector<MotionFrame> frames;
  double fps = 0.0;

  int num_joints() const { return static_cast<int>(joints.size()); }
  int num_frames() const { return static_cast<int>(frames.size()); }
  // Index of the joint with this name, or -1.
  int FindJoint(const std::string& name) const;

  // Joint transforms in the world (joint frame to world) for frame f,
  // #joints of them.
  std::vector<Eigen::Isometry3d> GlobalTransforms(int f) const;
  // The clip at `fps` frames per second over the same duration: root
  // positions interpolated linearly, rotations by slerp.
  MotionClip Resampled(double fps) const;
  // The root's velocity at frame f (metres per second; central differences,
  // one-sided at the ends; zero for a single frame).
  Eigen::Vector3d RootVelocity(int f) const;
};

// Reads a BVH file (HIERARCHY with ROOT/JOINT/End Site, then MOTION with
// Frames, Frame Time and one line of channel values per frame). Offsets and
// positions are multiplied by `units_to_metres` (the CMU clips of
// ../shared/data/drape/motion: 0.056444). Throws BvhError naming the file
// and line: a missing section, an unknown channel, unbalanced braces, a
// frame with the wrong number of values, a non-finite value.
MotionClip ReadBvh(const std::string& path, double units_to_metres = 1.0);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_MOTION_BVH_MOTION_H_
