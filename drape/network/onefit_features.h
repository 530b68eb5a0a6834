// The inputs of OneFit's network (the paper's Sec. 4 and supplement 7.5),
// computed on a CPU.
//
// Per garment patch k (once per garment, not per frame), from its rest
// PolyFit description and its binding to the body:
//   alpha_k                     the rest jet's coefficients (NumJetCoefficients),
//                               over their output units (PatchOutputMap)
//   log L_k                     its scale s_k, or with area units its area's
//                               radius sqrt(A_k / pi)
//   r1, r2                      the first two columns of its frame R_k (6D)
//   gamma(T_k)                  its centre T_k and a positional encoding of it
//   w_k                         its members' mean skinning weight per joint (#J)
//   gamma(sum_j w_kj (T_k - h_j))  its offset from the joints it follows,
//                               skinning-weighted, and its encoding
// with gamma(p) = (p, sin(2^l pi p), cos(2^l pi p)), l = 0 .. L-1.
//
// Per frame (shared by every patch), from the pose and its two
// predecessors (the dynamic part, a window rather than a GRU):
//   the 6D local rotation of every joint relative to its parent, at t, and
//   its changes t - (t-1) and (t-1) - (t-2) (the root: RootRotation
//   below); gravity's direction and the
//   root's velocity (m/s), both in the root's frame, at t and t-1; the
//   body's five macro shape values.
#ifndef POLYFIT_DRAPE_NETWORK_ONEFIT_FEATURES_H_
#define POLYFIT_DRAPE_NETWORK_ONEFIT_FEATURES_H_

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "drape/body/body_shape.h"
#include "drape/body/makehuman_body.h"
#include "drape/garment/skin_transfer.h"
#include "polyfit/model/polyfit_model.h"

namespace polyfit {

// Per patch and frame, optionally (OneFitNetworkOptions::local_pose): the
// normalised body features of the joints the patch follows, weighted by
// its members' mean skinning weights w_kj,
//   x_k = sum_j w_kj [r_j(t); r_j(t) - r_j(t-1); r_j(t-1) - r_j(t-2)]
// (18 values: the 6D local rotations as BodyFeatures has them). A sleeve's
// patch then reads its shoulder and elbow directly, rather than through a
// body embedding in which every joint is mixed with every other: an
// unseen combination of joint angles (a dance's arms over a walk's legs)
// leaves each patch's own inputs within what training covered.
inline constexpr int kLocalPoseSize = 18;

// Frequencies of the positional encoding.
inline constexpr int kPositionalFrequencies = 4;

int PatchFeatureSize(int jet_order, int num_joints);
int BodyFeatureSize(int num_joints);

// #features by #patches. rest_parameters: per patch alpha
// (NumJetCoefficients(jet_order)), s, T (and any warp, not read) as
// DrapeSolver::RestPatchParameters gives them; units: the network's output
// units per patch (PatchOutputMap::units): alpha_c and log s are read as
// alpha_c / u_c and log L, the jet in the units the network moves it in;
// model: the patches' frames and memberships; weights: the garment's
// skinning weights.
Eigen::MatrixXd PatchFeatures(const PolyFitModel& model, const std::vector<double>& rest_parameters,
                              const Eigen::MatrixXd& units, int jet_order, const SkinWeights& weights,
                              const Skeleton& skeleton);

// #joints by #patches: each patch's members' mean skinning weight per
// joint (a column sums to 1 where the garment's weights do).
Eigen::MatrixXd PatchJointWeights(const PolyFitModel& model, const SkinWeights& weights, int num_joints);

// kLocalPoseSize by #patches: x_k above. body_features: one frame's,
// normalised (BodyFeatureSize(#joints)); joint_weights: PatchJointWeights.
Eigen::MatrixXd LocalPoseFeatures(const Eigen::VectorXd& body_features, const Eigen::MatrixXd& joint_weights);

// Per joint, the most that any vertex of the garment is moved by it: the
// largest, over the vertices, of the weight on the joint and its
// descendants (a joint's rotation carries its whole subtree). #joints.
Eigen::VectorXd JointReach(const SkinWeights& weights, const Skeleton& skeleton);

// BodyFeatureSize(#joints) values, 0 on the rotations of the joints whose
// JointReach is below min_reach and 1 elsewhere (gravity, the root's
// velocity and the shape are kept): the body features a garment is drawn
// from, multiplied into the normalised ones. A suit does not follow the
// toes or the fingers, and an unseen motion's out-of-range feet (the
// held-out dance's, 4-5 standard deviations) then cannot reach it through
// the body embedding. min_reach <= 0: all ones.
Eigen::VectorXd BodyFeatureMask(const SkinWeights& weights, const Skeleton& skeleton, double min_reach);

// A frame's pose: the rest-to-posed transform of every joint.
using JointTransforms = std::vector<Eigen::Isometry3d>;

// What the root's three 6D blocks hold (the root has no parent).
//   kAbsolute     its rotation R_t in the world and the changes
//                 6D(R_t) - 6D(R_t-1), 6D(R_t-1) - 6D(R_t-2): they depend
//                 on which way the body faces, which no physics does, so
//                 a clip that turns (the dance) leaves what walks in one
//                 direction taught (models before file version 6).
//   kHeadingFree  R_t with its heading about the vertical taken out,
//                 Y(-psi_t) R_t (HeadingAngle), and the turns in the
//                 root's own frame, 6D(R_t-1^T R_t) - 6D(I) and
//                 6D(R_t-2^T R_t-1) - 6D(I): unchanged when the whole
//                 motion is turned about the vertical.
enum class RootRotation { kAbsolute, kHeadingFree };

// psi: the heading of a rotation about the vertical (y), the direction
// square to its lateral axis l = R e_x on the ground,
// psi = atan2(-l_z, l_x): bending forward or back and leaning sideways
// (turns about l and about the level forward axis) leave it alone. Where
// l is within about 6 degrees of the vertical (lying on one's side), the
// forward axis R e_z is used instead. Turning R by Y(a) turns psi by a.
double HeadingAngle(const Eigen::Matrix3d& rotation);

// #features. poses: frames t - 2, t - 1, t (the first two may repeat t at
// a clip's start); fps: frames per second (for the root's velocity).
Eigen::VectorXd BodyFeatures(const Skeleton& skeleton, const JointTransforms& before_previous,
                             const JointTransforms& previous, const JointTransforms& now, double fps,
                             const BodyShape& shape, RootRotation root);

// Per-feature mean and inverse spread, from training samples (columns),
// applied as clamp((x - mean) * inv_std, +-kFeatureClamp). The spread is
// floored at kMinFeatureSpread: a feature that barely varies in training
// (a joint the clips hardly move, a per-frame change of a slow joint) had
// inverse spreads up to 2e4, so that an unseen motion or garment moved it
// by hundreds of units, far outside anything the network saw (the held-out
// dance stretched the suit by 33%). The clamp bounds what is left. A
// feature constant in training gets inv_std 0 (ignored).
inline constexpr double kMinFeatureSpread = 0.05;
inline constexpr double kFeatureClamp = 6.0;

struct FeatureNormalizer {
  Eigen::VectorXd mean;
  Eigen::VectorXd inv_std;

  static FeatureNormalizer Fit(const Eigen::MatrixXd& samples);
  Eigen::MatrixXd Apply(const Eigen::MatrixXd& x) const;
  bool empty() const { return mean.size() == 0; }
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_ONEFIT_FEATURES_H_
