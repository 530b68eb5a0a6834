#include "drape/motion/limb_excursion.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "drape/motion/perturb_pose.h"

namespace polyfit {
namespace {

constexpr double kDegree = M_PI / 180.0;

JointExcursion Excursion(const std::string& joint, const Eigen::Vector3d& axis, double min_deg, double max_deg) {
  return {joint, axis, min_deg * kDegree, max_deg * kDegree};
}

}  // namespace

std::vector<JointExcursion> DefaultLimbExcursions() {
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(), z = Eigen::Vector3d::UnitZ();
  // Raising a limb forwards turns it about -X (bending the spine, which
  // points up, forwards: about +X); sideways, about +Z on the
  // left (+X) side and -Z on the right.
  return {
      Excursion("LeftArm", z, 0.0, 110.0),      Excursion("LeftArm", -x, -20.0, 100.0),
      Excursion("RightArm", -z, 0.0, 110.0),    Excursion("RightArm", -x, -20.0, 100.0),
      Excursion("LeftUpLeg", -x, -15.0, 60.0),  Excursion("LeftUpLeg", z, 0.0, 30.0),
      Excursion("RightUpLeg", -x, -15.0, 60.0), Excursion("RightUpLeg", -z, 0.0, 30.0),
      Excursion("LeftLeg", x, 0.0, 60.0),       Excursion("RightLeg", x, 0.0, 60.0),
      Excursion("Spine", x, -10.0, 30.0),       Excursion("Spine", z, -15.0, 15.0),
      Excursion("Spine", y, -30.0, 30.0),
  };
}

LimbExcursion::LimbExcursion(const Skeleton& skeleton, const std::vector<JointExcursion>& excursions, double duration_s,
                             std::uint64_t seed, double hold_min_s, double hold_max_s)
    : parents_(skeleton.parents), heads_(skeleton.rest_heads) {
  if (!(duration_s >= 0.0) || !std::isfinite(duration_s)) {
    throw std::invalid_argument("LimbExcursion: the duration must be finite and >= 0");
  }
  if (!(hold_min_s > 0.0 && hold_max_s >= hold_min_s) || !std::isfinite(hold_max_s)) {
    throw std::invalid_argument("LimbExcursion: the hold times must satisfy 0 < min <= max");
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const JointExcursion& e : excursions) {
    const int joint = skeleton.Find(e.joint);
    if (joint < 0) throw std::invalid_argument("LimbExcursion: the rig has no joint '" + e.joint + "'");
    if (parents_[joint] < 0) throw std::invalid_argument("LimbExcursion: '" + e.joint + "' is the root");
    if (!e.axis.allFinite() || e.axis.norm() < 1e-12) {
      throw std::invalid_argument("LimbExcursion: the axis of '" + e.joint + "' must be finite and non-zero");
    }
    if (!std::isfinite(e.min_angle) || !std::isfinite(e.max_angle) || e.min_angle > e.max_angle) {
      throw std::invalid_argument("LimbExcursion: the range of '" + e.joint + "' must be finite, min <= max");
    }
    Track track{joint, e.axis.normalized(), {}, {}};
    double t = 0.0;
    while (true) {
      track.times.push_back(t);
      track.angles.push_back(e.min_angle + (e.max_angle - e.min_angle) * unit(rng));
      if (t >= duration_s) break;
      t += hold_min_s + (hold_max_s - hold_min_s) * unit(rng);
    }
    tracks_.push_back(std::move(track));
  }
}

double LimbExcursion::Angle(int excursion, double time_s) const {
  const Track& track = tracks_.at(static_cast<size_t>(excursion));
  if (!(time_s > 0.0)) return track.angles.front();
  const auto next = std::upper_bound(track.times.begin(), track.times.end(), time_s);
  if (next == track.times.end()) return track.angles.back();
  const size_t m = static_cast<size_t>(next - track.times.begin()) - 1;
  const double u = (time_s - track.times[m]) / (track.times[m + 1] - track.times[m]);
  const double s = u * u * (3.0 - 2.0 * u);
  return track.angles[m] + (track.angles[m + 1] - track.angles[m]) * s;
}

std::vector<Eigen::Isometry3d> LimbExcursion::Apply(const std::vector<Eigen::Isometry3d>& rest_to_posed,
                                                    double time_s) const {
  if (rest_to_posed.size() != parents_.size()) {
    throw std::invalid_argument("LimbExcursion: one transform per joint is needed");
  }
  std::vector<Eigen::Matrix3d> turn(parents_.size(), Eigen::Matrix3d::Identity());
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const Track& track = tracks_[i];
    turn[track.joint] = turn[track.joint] * Eigen::AngleAxisd(Angle(static_cast<int>(i), time_s), track.axis);
  }
  return TurnJointsInRest(parents_, heads_, rest_to_posed, turn);
}

}  // namespace polyfit
