#include "drape/motion/mix_pose.h"

#include <stdexcept>

namespace polyfit {

std::vector<int> JointGroups(const Skeleton& skeleton, const std::vector<std::string>& group_roots) {
  std::vector<int> groups(skeleton.num_joints(), -1);
  for (size_t g = 0; g < group_roots.size(); ++g) {
    const int root = skeleton.Find(group_roots[g]);
    if (root < 0) throw std::invalid_argument("JointGroups: the rig has no joint '" + group_roots[g] + "'");
    groups[root] = static_cast<int>(g);
  }
  // Parents come before their children: a joint joins its parent's group
  // unless it roots a group of its own.
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    const int p = skeleton.parents[j];
    if (p >= j) throw std::invalid_argument("JointGroups: a joint listed before its parent");
    if (groups[j] < 0 && p >= 0) groups[j] = groups[p];
  }
  return groups;
}

std::vector<std::string> DefaultMixGroups() { return {"LeftShoulder", "RightShoulder", "Neck", "LowerBack"}; }

std::vector<Eigen::Isometry3d> MixPoses(const Skeleton& skeleton, const std::vector<Eigen::Isometry3d>& base,
                                        const std::vector<const std::vector<Eigen::Isometry3d>*>& donors,
                                        const std::vector<int>& groups) {
  const size_t n = static_cast<size_t>(skeleton.num_joints());
  if (base.size() != n || groups.size() != n) throw std::invalid_argument("MixPoses: one transform per joint");
  for (const auto* donor : donors) {
    if (donor == nullptr || donor->size() != n) throw std::invalid_argument("MixPoses: one transform per joint");
  }
  std::vector<Eigen::Isometry3d> out(n);
  for (size_t j = 0; j < n; ++j) {
    const int p = skeleton.parents[j];
    if (p < 0) {
      out[j] = base[j];
      continue;
    }
    if (groups[j] >= static_cast<int>(donors.size())) throw std::invalid_argument("MixPoses: a group with no donor");
    const std::vector<Eigen::Isometry3d>& source = groups[j] < 0 ? base : *donors[groups[j]];
    out[j] = out[p] * (source[p].inverse() * source[j]);
  }
  return out;
}

}  // namespace polyfit
