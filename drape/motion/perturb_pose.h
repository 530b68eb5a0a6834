// Perturbed joint angles, for augmentation: every joint's rotation
// relative to its parent is turned further by a small rotation that varies
// smoothly in time,
//   T'_j = T'_p(j) L_j P_j(t),   L_j = T_p(j)^-1 T_j,
//   P_j(t) = rotation by delta_j(t) about the joint's rest head h_j,
// delta_j(t) (per axis) = A sum_k w_k sin(2 pi f_jk t + phi_jk) with
// seeded frequencies f in [0.2, 1] Hz, phases and weights (|delta_j| <= A per
// axis), so that each joint wanders within A of its recorded angle and the
// motion stays as smooth as the clip. The root keeps its own transform;
// bones stay connected (P_j fixes h_j). Joint limits are not known for the
// rig: keep A small (a few degrees to about 15).
#ifndef POLYFIT_DRAPE_MOTION_PERTURB_POSE_H_
#define POLYFIT_DRAPE_MOTION_PERTURB_POSE_H_

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"

namespace polyfit {

// Each joint's rotation relative to its parent turned further in the rest
// frame: T'_j = T'_p(j) L_j R_j with L_j = T_p(j)^-1 T_j and R_j the
// rotation turns[j] about the joint's rest head h_j (bones stay connected;
// the root keeps its transform). parents: #joints, parents first; heads:
// 3 by #joints; rest_to_posed and turns: #joints each. Throws
// std::invalid_argument on sizes that disagree. Shared by
// PosePerturbation and LimbExcursion.
std::vector<Eigen::Isometry3d> TurnJointsInRest(const std::vector<int>& parents, const Eigen::Matrix3Xd& heads,
                                                const std::vector<Eigen::Isometry3d>& rest_to_posed,
                                                const std::vector<Eigen::Matrix3d>& turns);

class PosePerturbation {
 public:
  // amplitude: A (radians, >= 0); throws std::invalid_argument otherwise.
  PosePerturbation(const Skeleton& skeleton, double amplitude, std::uint64_t seed);

  // delta_j(t) (3, radians) of joint j at time t (s).
  Eigen::Vector3d Angles(int joint, double time_s) const;

  // The perturbed pose at time t (one rest-to-posed transform per joint).
  std::vector<Eigen::Isometry3d> Apply(const std::vector<Eigen::Isometry3d>& rest_to_posed, double time_s) const;

 private:
  static constexpr int kWaves = 2;
  struct Wave {
    double frequency, phase, weight;
  };
  std::vector<int> parents_;
  Eigen::Matrix3Xd heads_;
  double amplitude_;
  std::vector<Wave> waves_;  // per joint, axis, wave
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_MOTION_PERTURB_POSE_H_
