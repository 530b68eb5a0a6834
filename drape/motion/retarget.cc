#include "drape/motion/retarget.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

namespace polyfit {
namespace {

// The turn about +Y that takes the horizontal part of `from` onto that of `to`.
Eigen::Quaterniond YawBetween(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  const double a = std::atan2(from.x(), from.z());
  const double b = std::atan2(to.x(), to.z());
  return Eigen::Quaterniond(Eigen::AngleAxisd(b - a, Eigen::Vector3d::UnitY()));
}

}  // namespace

MotionRetargeter::MotionRetargeter(const MotionClip& clip, const Skeleton& skeleton)
    : clip_(clip), skeleton_(skeleton) {
  if (clip_.num_frames() == 0) throw BvhError("MotionRetargeter: the clip has no frame");
  MatchJoints();
  // The clip's rest pose: every rotation identity, root at the origin.
  std::vector<Eigen::Vector3d> clip_rest(clip_.num_joints());
  for (int k = 0; k < clip_.num_joints(); ++k) {
    const int parent = clip_.joints[k].parent;
    clip_rest[k] = parent < 0 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(clip_rest[parent] + clip_.joints[k].offset);
  }
  AlignHeadings(clip_rest);
  ComputeScale(clip_rest);
  FindFloors();
  AlignRestBones(clip_rest);
}

// Rig joints to clip joints by name.
void MotionRetargeter::MatchJoints() {
  const int n = skeleton_.num_joints();
  clip_joint_.assign(n, -1);
  for (int j = 0; j < n; ++j) {
    clip_joint_[j] = clip_.FindJoint(skeleton_.names[j]);
    // MPFB2's CMU rig renames the index finger.
    if (clip_joint_[j] < 0 && skeleton_.names[j] == "LeftHandFinger1")
      clip_joint_[j] = clip_.FindJoint("LeftHandIndex1");
    if (clip_joint_[j] < 0 && skeleton_.names[j] == "RightHandFinger1")
      clip_joint_[j] = clip_.FindJoint("RightHandIndex1");
    if (clip_joint_[j] >= 0) ++num_matched_;
  }
  if (num_matched_ == 0) throw BvhError("MotionRetargeter: no rig joint is named in the clip");
  if (clip_joint_[0] < 0)
    throw BvhError("MotionRetargeter: the clip has no joint named '" + skeleton_.names[0] + "' (the rig's root)");
}

void MotionRetargeter::AlignHeadings(const std::vector<Eigen::Vector3d>& clip_rest) {
  const auto rig_head = [&](int j) -> Eigen::Vector3d { return skeleton_.rest_heads.col(j); };
  // C_rest: the clip's left (from the right hip to the left) onto the rig's.
  Eigen::Quaterniond rest_turn = Eigen::Quaterniond::Identity();
  Eigen::Vector3d clip_left = Eigen::Vector3d::UnitX();
  for (const auto& [left, right] :
       {std::pair<const char*, const char*>{"LeftUpLeg", "RightUpLeg"}, {"LeftArm", "RightArm"}}) {
    const int rl = skeleton_.Find(left), rr = skeleton_.Find(right);
    const int cl = clip_.FindJoint(left), cr = clip_.FindJoint(right);
    if (rl < 0 || rr < 0 || cl < 0 || cr < 0) continue;
    clip_left = clip_rest[cl] - clip_rest[cr];
    const Eigen::Vector3d rig_left = rig_head(rl) - rig_head(rr);
    // YawBetween measures angles from +Z; turn the left vectors into forwards.
    rest_turn = YawBetween(clip_left.cross(Eigen::Vector3d::UnitY()), rig_left.cross(Eigen::Vector3d::UnitY()));
    break;
  }
  // H: cancel the clip's heading at frame 0.
  const Eigen::Vector3d clip_forward = clip_left.cross(Eigen::Vector3d::UnitY());  // left x up
  const Eigen::Quaterniond root0(clip_.frames[0].local_rotations[clip_joint_[0]]);
  const Eigen::Quaterniond heading = YawBetween(root0 * clip_forward, clip_forward);
  clip_to_rig_ = rest_turn * heading;
  rest_turn_ = rest_turn;
}

void MotionRetargeter::ComputeScale(const std::vector<Eigen::Vector3d>& clip_rest) {
  const int n = skeleton_.num_joints();
  const auto rig_head = [&](int j) -> Eigen::Vector3d { return skeleton_.rest_heads.col(j); };
  // Scale: the legs' lengths (hip to ankle) when both have them, else every
  // matched bone's. The clips' spines are much shorter than MakeHuman's, so
  // heights would mislead.
  const auto chain_length = [&](bool rig, const char* const* chain, int count) {
    double length = 0.0;
    for (int k = 1; k < count; ++k) {
      const int a = skeleton_.Find(chain[k - 1]), b = skeleton_.Find(chain[k]);
      const int ca = clip_.FindJoint(chain[k - 1]), cb = clip_.FindJoint(chain[k]);
      if (a < 0 || b < 0 || ca < 0 || cb < 0) return 0.0;
      length += rig ? (rig_head(b) - rig_head(a)).norm() : (clip_rest[cb] - clip_rest[ca]).norm();
    }
    return length;
  };
  double rig_length = 0.0, clip_length = 0.0;
  for (const char* side : {"Left", "Right"}) {
    const std::string up = std::string(side) + "UpLeg", leg = std::string(side) + "Leg",
                      foot = std::string(side) + "Foot";
    const char* chain[] = {up.c_str(), leg.c_str(), foot.c_str()};
    rig_length += chain_length(true, chain, 3);
    clip_length += chain_length(false, chain, 3);
  }
  if (!(rig_length > 0.0 && clip_length > 0.0)) {
    rig_length = clip_length = 0.0;
    for (int j = 0; j < n; ++j) {
      const int p = skeleton_.parents[j];
      if (p < 0 || clip_joint_[j] < 0 || clip_joint_[p] < 0) continue;
      rig_length += (rig_head(j) - rig_head(p)).norm();
      clip_length += (clip_rest[clip_joint_[j]] - clip_rest[clip_joint_[p]]).norm();
    }
  }
  scale_ = (rig_length > 1e-9 && clip_length > 1e-9) ? rig_length / clip_length : 1.0;
}

void MotionRetargeter::FindFloors() {
  const int n = skeleton_.num_joints();
  const auto rig_head = [&](int j) -> Eigen::Vector3d { return skeleton_.rest_heads.col(j); };
  // Floors: the rig's lowest matched joint at rest; the clip's lowest joint
  // over the whole clip (a toe on the ground). Per frame, the clip's lowest
  // joint above its floor.
  rig_floor_ = 1e300;
  for (int j = 0; j < n; ++j) {
    if (clip_joint_[j] >= 0) rig_floor_ = std::min(rig_floor_, rig_head(j).y());
  }
  clip_lowest_.assign(clip_.num_frames(), 1e300);
  for (int f = 0; f < clip_.num_frames(); ++f) {
    const std::vector<Eigen::Isometry3d> global = clip_.GlobalTransforms(f);
    for (int j = 0; j < n; ++j) {
      if (clip_joint_[j] >= 0) clip_lowest_[f] = std::min(clip_lowest_[f], global[clip_joint_[j]].translation().y());
    }
  }
  clip_floor_ = *std::min_element(clip_lowest_.begin(), clip_lowest_.end());
}

void MotionRetargeter::AlignRestBones(const std::vector<Eigen::Vector3d>& clip_rest) {
  const int n = skeleton_.num_joints();
  const auto rig_head = [&](int j) -> Eigen::Vector3d { return skeleton_.rest_heads.col(j); };
  const Eigen::Quaterniond rest_turn = rest_turn_;
  // A_j: rig rest bone vectors onto the clip's (turned into the rig's frame).
  rest_alignment_.assign(n, Eigen::Quaterniond::Identity());
  for (int j = 0; j < n; ++j) {
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> pairs;
    if (clip_joint_[j] >= 0) {
      for (int c = 0; c < n; ++c) {
        if (skeleton_.parents[c] != j || clip_joint_[c] < 0) continue;
        const Eigen::Vector3d rig_bone = rig_head(c) - rig_head(j);
        const Eigen::Vector3d clip_bone = rest_turn * (clip_rest[clip_joint_[c]] - clip_rest[clip_joint_[j]]);
        if (rig_bone.norm() > 1e-6 && clip_bone.norm() > 1e-9) pairs.emplace_back(rig_bone, clip_bone);
      }
    }
    const int parent = skeleton_.parents[j];
    if (pairs.empty()) {
      rest_alignment_[j] = parent < 0 ? Eigen::Quaterniond::Identity() : rest_alignment_[parent];
    } else if (pairs.size() == 1) {
      rest_alignment_[j] = Eigen::Quaterniond::FromTwoVectors(pairs[0].first, pairs[0].second);
    } else {
      // Kabsch on unit vectors weighted by the rig bone's length.
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (const auto& [a, b] : pairs) cov += a.norm() * a.normalized() * b.normalized().transpose();
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
      d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
      rest_alignment_[j] = Eigen::Quaterniond(svd.matrixV() * d * svd.matrixU().transpose()).normalized();
    }
  }
}

std::vector<Eigen::Isometry3d> MotionRetargeter::Pose(int f, double blend) const {
  const int n = skeleton_.num_joints();
  const std::vector<Eigen::Isometry3d> clip_global = clip_.GlobalTransforms(f);
  const Eigen::Quaterniond rest_turn_inverse = rest_turn_.conjugate();
  std::vector<Eigen::Quaterniond> rotation(n);
  std::vector<Eigen::Vector3d> head(n);
  double lowest = 1e300;
  for (int j = 0; j < n; ++j) {
    const int parent = skeleton_.parents[j];
    if (clip_joint_[j] >= 0) {
      const Eigen::Quaterniond g(clip_global[clip_joint_[j]].linear());
      rotation[j] = (clip_to_rig_ * g * rest_turn_inverse * rest_alignment_[j]).normalized();
      rotation[j] = Eigen::Quaterniond::Identity().slerp(blend, rotation[j]);
    } else {
      rotation[j] = parent < 0 ? Eigen::Quaterniond::Identity() : rotation[parent];
    }
    if (parent < 0) {
      // Horizontally the clip's path from frame 0, scaled; the height is set below.
      Eigen::Vector3d path = clip_to_rig_ * (clip_.frames[f].root_translation - clip_.frames[0].root_translation);
      path.y() = 0.0;
      head[j] = skeleton_.rest_heads.col(j) + blend * scale_ * path;
    } else {
      head[j] = head[parent] + rotation[parent] * (skeleton_.rest_heads.col(j) - skeleton_.rest_heads.col(parent));
    }
    if (clip_joint_[j] >= 0) lowest = std::min(lowest, head[j].y());
  }
  // Height: the lowest joint as far above the rig's floor as the clip's is
  // above its own (scaled), so feet stay on the ground and hops leave it.
  const double lift = blend * (rig_floor_ + scale_ * (clip_lowest_[f] - clip_floor_) - lowest);
  std::vector<Eigen::Isometry3d> out(n);
  for (int j = 0; j < n; ++j) {
    out[j].linear() = rotation[j].toRotationMatrix();
    out[j].translation() = head[j] + Eigen::Vector3d(0.0, lift, 0.0) - out[j].linear() * skeleton_.rest_heads.col(j);
  }
  return out;
}

Eigen::Vector3d MotionRetargeter::RootVelocity(int f) const { return scale_ * (clip_to_rig_ * clip_.RootVelocity(f)); }

}  // namespace polyfit
