#include "drape/motion/perturb_pose.h"

#include <cmath>
#include <random>
#include <stdexcept>

namespace polyfit {

PosePerturbation::PosePerturbation(const Skeleton& skeleton, double amplitude, std::uint64_t seed)
    : parents_(skeleton.parents), heads_(skeleton.rest_heads), amplitude_(amplitude) {
  if (!(amplitude >= 0.0) || !std::isfinite(amplitude)) {
    throw std::invalid_argument("PosePerturbation: the amplitude must be finite and >= 0");
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> frequency(0.2, 1.0), phase(0.0, 2.0 * M_PI), weight(0.0, 1.0);
  waves_.resize(static_cast<size_t>(skeleton.num_joints()) * 3 * kWaves);
  for (size_t i = 0; i < waves_.size(); i += kWaves) {
    // Weights summing to 1 per axis: |delta| <= A.
    double total = 0.0;
    for (int k = 0; k < kWaves; ++k) {
      waves_[i + k] = {frequency(rng), phase(rng), weight(rng) + 1e-3};
      total += waves_[i + k].weight;
    }
    for (int k = 0; k < kWaves; ++k) waves_[i + k].weight /= total;
  }
}

Eigen::Vector3d PosePerturbation::Angles(int joint, double time_s) const {
  Eigen::Vector3d delta;
  for (int axis = 0; axis < 3; ++axis) {
    const Wave* w = waves_.data() + (static_cast<size_t>(joint) * 3 + axis) * kWaves;
    double sum = 0.0;
    for (int k = 0; k < kWaves; ++k) sum += w[k].weight * std::sin(2.0 * M_PI * w[k].frequency * time_s + w[k].phase);
    delta[axis] = amplitude_ * sum;
  }
  return delta;
}

std::vector<Eigen::Isometry3d> TurnJointsInRest(const std::vector<int>& parents, const Eigen::Matrix3Xd& heads,
                                                const std::vector<Eigen::Isometry3d>& rest_to_posed,
                                                const std::vector<Eigen::Matrix3d>& turns) {
  if (rest_to_posed.size() != parents.size() || turns.size() != parents.size() ||
      static_cast<size_t>(heads.cols()) != parents.size()) {
    throw std::invalid_argument("TurnJointsInRest: one transform, turn and head per joint is needed");
  }
  std::vector<Eigen::Isometry3d> out(rest_to_posed.size());
  for (size_t j = 0; j < out.size(); ++j) {
    const int p = parents[j];
    if (p < 0) {
      out[j] = rest_to_posed[j];
      continue;
    }
    Eigen::Isometry3d about_head = Eigen::Isometry3d::Identity();
    about_head.linear() = turns[j];
    about_head.translation() = heads.col(j) - turns[j] * heads.col(j);
    out[j] = out[p] * (rest_to_posed[p].inverse() * rest_to_posed[j]) * about_head;
  }
  return out;
}

std::vector<Eigen::Isometry3d> PosePerturbation::Apply(const std::vector<Eigen::Isometry3d>& rest_to_posed,
                                                       double time_s) const {
  if (rest_to_posed.size() != parents_.size()) {
    throw std::invalid_argument("PosePerturbation: one transform per joint is needed");
  }
  std::vector<Eigen::Matrix3d> turns(parents_.size(), Eigen::Matrix3d::Identity());
  for (size_t j = 0; j < turns.size(); ++j) {
    if (parents_[j] < 0) continue;
    const Eigen::Vector3d delta = Angles(static_cast<int>(j), time_s);
    const double angle = delta.norm();
    if (angle > 0.0) turns[j] = Eigen::AngleAxisd(angle, delta / angle).toRotationMatrix();
  }
  return TurnJointsInRest(parents_, heads_, rest_to_posed, turns);
}

}  // namespace polyfit
