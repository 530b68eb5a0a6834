#include "drape/motion/mirror_pose.h"

#include <stdexcept>
#include <string>

namespace polyfit {

std::vector<int> MirrorJointMap(const Skeleton& skeleton) {
  std::vector<int> map(skeleton.num_joints());
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    const std::string& name = skeleton.names[j];
    std::string partner;
    if (name.rfind("Left", 0) == 0) {
      partner = "Right" + name.substr(4);
    } else if (name.rfind("Right", 0) == 0) {
      partner = "Left" + name.substr(5);
    }
    map[j] = partner.empty() ? j : skeleton.Find(partner);
    if (map[j] < 0) throw std::invalid_argument("MirrorJointMap: joint '" + name + "' has no '" + partner + "'");
  }
  return map;
}

std::vector<Eigen::Isometry3d> MirrorPose(const std::vector<Eigen::Isometry3d>& rest_to_posed,
                                          const std::vector<int>& joint_map) {
  if (rest_to_posed.size() != joint_map.size()) {
    throw std::invalid_argument("MirrorPose: one transform per joint is needed");
  }
  const Eigen::Matrix3d m = Eigen::Vector3d(-1.0, 1.0, 1.0).asDiagonal();
  std::vector<Eigen::Isometry3d> mirrored(rest_to_posed.size());
  for (size_t j = 0; j < rest_to_posed.size(); ++j) {
    const Eigen::Isometry3d& t = rest_to_posed[joint_map[j]];
    mirrored[j].linear() = m * t.linear() * m;
    mirrored[j].translation() = m * t.translation();
    mirrored[j].makeAffine();
  }
  return mirrored;
}

}  // namespace polyfit
