#include "drape/motion/blend_pose.h"

#include <stdexcept>
#include <string>

namespace polyfit {

std::vector<Eigen::Isometry3d> BlendFromRest(const Skeleton& skeleton,
                                             const std::vector<Eigen::Isometry3d>& rest_to_posed, double blend) {
  const int n = skeleton.num_joints();
  if (static_cast<int>(rest_to_posed.size()) != n) {
    throw std::invalid_argument("BlendFromRest: " + std::to_string(rest_to_posed.size()) + " transforms for " +
                                std::to_string(n) + " joints");
  }
  if (!(blend >= 0.0 && blend <= 1.0)) throw std::invalid_argument("BlendFromRest: the blend must be in [0, 1]");
  std::vector<Eigen::Isometry3d> out(n);
  std::vector<Eigen::Quaterniond> rotation(n);
  std::vector<Eigen::Vector3d> head(n);
  for (int j = 0; j < n; ++j) {
    const int parent = skeleton.parents[j];
    const Eigen::Vector3d rest_head = skeleton.rest_heads.col(j);
    rotation[j] = Eigen::Quaterniond::Identity().slerp(blend, Eigen::Quaterniond(rest_to_posed[j].linear()));
    if (parent < 0) {
      head[j] = rest_head + blend * (rest_to_posed[j] * rest_head - rest_head);
    } else {
      head[j] = head[parent] + rotation[parent] * (rest_head - skeleton.rest_heads.col(parent));
    }
    out[j].linear() = rotation[j].toRotationMatrix();
    out[j].translation() = head[j] - out[j].linear() * rest_head;
  }
  return out;
}

}  // namespace polyfit
