// Limb excursions, for augmentation: joint angles far from any recorded
// clip's (arms raised overhead, a leg lifted into a lunge, the back bent
// or twisted), which a handful of walks and runs never show and a dance
// does. Each excursion i turns one joint j about a fixed axis a_i of the
// body's rest frame, through its rest head h_j, by an angle that moves
// smoothly between seeded key angles:
//   theta_i(t) = k_m + (k_{m+1} - k_m) s((t - t_m) / (t_{m+1} - t_m)),
//   s(u) = 3u^2 - 2u^3   (zero rate at every key: C^1 in time),
// with key times t_{m+1} - t_m drawn in [hold_min, hold_max] seconds and
// key angles k_m uniform in [min_i, max_i]. On top of the recorded pose,
// as PosePerturbation does (with L_j = T_p(j)^-1 T_j),
//   T'_j = T'_p(j) L_j E_j(t),   E_j(t) = prod_i rot(a_i, theta_i(t)) about h_j,
// so bones stay connected, every other joint keeps its recorded rotation
// relative to its parent, and the root keeps its transform.
#ifndef POLYFIT_DRAPE_MOTION_LIMB_EXCURSION_H_
#define POLYFIT_DRAPE_MOTION_LIMB_EXCURSION_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"

namespace polyfit {

struct JointExcursion {
  std::string joint;
  Eigen::Vector3d axis;         // in the body's rest frame (normalised on use)
  double min_angle, max_angle;  // radians, min <= max
};

// The excursions used with the MakeHuman/CMU rig and the procedural body
// (Y up, the character facing +Z, its left at +X): each arm raised
// sideways (0-110 deg) and forwards (-20-100 deg), each hip flexed (-15-60
// deg) and spread (0-30 deg), each knee bent (0-60 deg), the spine bent
// forwards (-10-30 deg), sideways (+-15 deg) and twisted (+-30 deg).
// Relative to the recorded angles, which already hold the arms down and
// swing the legs: a walk's arm raised by 110 deg is about horizontal.
std::vector<JointExcursion> DefaultLimbExcursions();

class LimbExcursion {
 public:
  // Keys cover [0, duration_s] (the angles hold their last key after it).
  // Throws std::invalid_argument naming a joint the rig lacks, a zero
  // axis, min > max, a non-finite value, or a bad hold range or duration.
  LimbExcursion(const Skeleton& skeleton, const std::vector<JointExcursion>& excursions, double duration_s,
                std::uint64_t seed, double hold_min_s = 0.6, double hold_max_s = 1.6);

  int num_excursions() const { return static_cast<int>(tracks_.size()); }
  // theta_i(t) (radians).
  double Angle(int excursion, double time_s) const;

  // The excursed pose at time t (one rest-to-posed transform per joint).
  std::vector<Eigen::Isometry3d> Apply(const std::vector<Eigen::Isometry3d>& rest_to_posed, double time_s) const;

 private:
  struct Track {
    int joint;
    Eigen::Vector3d axis;
    std::vector<double> times, angles;  // the keys, times increasing from 0
  };
  std::vector<int> parents_;
  Eigen::Matrix3Xd heads_;
  std::vector<Track> tracks_;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_MOTION_LIMB_EXCURSION_H_
