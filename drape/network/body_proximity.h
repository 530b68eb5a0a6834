// Where each garment patch, posed by skinning alone, meets the posed body:
// a per-patch, per-frame input of OneFit's decoder
// (OneFitNetworkOptions::body_proximity). The network's outputs move each
// patch from its skinned rest (onefit_network.h); what they must undo is
// how far skinning left it inside the body or away from it, which the
// joint rotations give only through a function of the whole pose that an
// unseen pose or body shape leaves. Here it is measured directly, so that
// "push out along the body's normal by about the depth" holds for any
// pose, shape or garment.
//
// Probes: each patch's rest jet at its centre and at (+-a, 0), (0, +-a) in
// its frame, a = kProbeReach rho (rho = sqrt(A / pi), A its rest area), a
// fixed count per patch whatever its meshing; the rim layout
// (kRimProximityProbes) adds (+-b, +-b), b = rho / sqrt(2), on the rim of
// the disc of the patch's area, where a body part that skinning carries
// into the patch's edge shows first. A probe x is posed by the
// patch's members' mean skinning weights w_kj (PatchJointWeights),
// x' = sum_j w_kj T_j x. Per probe, from the nearest point of the posed
// body's samples (PosedBodySamples): the signed distance d as clamp(d / kProximityScale,
// +-kProximityClamp), and the body's normal n there in the patch's posed
// frame F_k^T n, F_k the columns of B_k = (sum_j w_kj R_j) R_0 made
// orthonormal (Gram-Schmidt from the first): the frame the network's
// centre and jet outputs are posed in.
#ifndef POLYFIT_DRAPE_NETWORK_BODY_PROXIMITY_H_
#define POLYFIT_DRAPE_NETWORK_BODY_PROXIMITY_H_

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "drape/body/makehuman_body.h"
#include "drape/collision/signed_distance.h"
#include "drape/network/onefit_features.h"
#include "polyfit/eval/refit_point_tree.h"
#include "polyfit/model/polyfit_model.h"

namespace polyfit {

// Probes per patch: the default layout and the rim layout (the first five
// of which are the default's).
inline constexpr int kProximityProbes = 5;
inline constexpr int kRimProximityProbes = 9;
inline constexpr bool IsProximityLayout(int probes) {
  return probes == kProximityProbes || probes == kRimProximityProbes;
}
// The values per patch: [d, F^T n] per probe.
inline constexpr int kProximityValuesPerProbe = 4;
inline constexpr int ProximitySize(int probes) { return kProximityValuesPerProbe * probes; }
inline constexpr int kProximitySize = ProximitySize(kProximityProbes);
inline constexpr double kProbeReach = 0.5;
inline constexpr double kProximityScale = 0.01;  // m
inline constexpr double kProximityClamp = 4.0;

// One garment's probes, from its rest patches (once per garment).
struct PatchProbes {
  int probes_per_patch = kProximityProbes;
  Eigen::Matrix3Xd rest_points;         // 3 by probes_per_patch #patches, patch-major
  Eigen::Matrix2Xd uv;                  // their (u, v) in their patches' frame units, alike
  std::vector<Eigen::Matrix3d> frames;  // R_0 per patch
  // The patches' joint weights (PatchJointWeights, #joints by #patches) as
  // posing reads them: the rig's joint count, and per patch its non-zero
  // entries (joints ascending), [joint_begin[p], joint_begin[p + 1]) of
  // joint and weight.
  int num_joints = 0;
  std::vector<int> joint_begin, joint;
  std::vector<double> weight;

  // Sets the above from #joints by #patches weights.
  void SetJointWeights(const Eigen::MatrixXd& weights);

  int num_patches() const { return static_cast<int>(frames.size()); }
};

// model: the garment's rest patches; areas: their rest areas (m^2, one per
// patch); joint_weights: PatchJointWeights; probes_per_patch: a layout
// (IsProximityLayout). Throws std::invalid_argument on mismatched sizes or
// another count of probes.
PatchProbes MakePatchProbes(const PolyFitModel& model, const std::vector<double>& areas,
                            const Eigen::MatrixXd& joint_weights, int probes_per_patch = kProximityProbes);

// The body as about two thousand of its vertices (the one nearest each
// occupied cell's centre on a grid of `spacing`) with their normals, posed
// frame by frame by linear blend skinning (normals by the blended
// rotation), and a tree over them built once and refitted per pose
// (RefitPointTree). A query answers with the nearest sample and the
// distance to its tangent plane, d = (p - x_v) . n_v (NaN for a point
// with a NaN): the
// nearest-vertex approximation of SNUG and GAPS (NearestVertexDistance),
// within the spacing's sag of the exact distance near the body, at about a
// tenth of the exact one's cost per frame (refitting a tree over the whole
// body's faces costs more than the network).
class PosedBodySamples {
 public:
  explicit PosedBodySamples(const SkinnedBody& body, double spacing = kBodySampleSpacing);
  // Throws std::invalid_argument when `pose` is not one transform per joint.
  void Pose(const JointTransforms& pose);
  // closest: the nearest sample; normal: its normal; face: its index.
  // hint: a sample likely nearest (a nearby query's face), or -1; the
  // answer is the same either way.
  SignedDistanceResult Query(const Eigen::Vector3d& point, int hint = -1) const;
  // Query for each of a group of points close together (3 by at most
  // RefitPointTree::kMaxGroup), in one walk of the tree (NearestGroup):
  // results[i] as Query(points.col(i), hints[i]); hints may be null.
  void QueryGroup(const Eigen::Matrix3Xd& points, const int* hints, SignedDistanceResult* results) const;
  int num_samples() const { return static_cast<int>(rest_points_.cols()); }
  const Eigen::Matrix3Xd& points() const { return points_; }

  static constexpr double kBodySampleSpacing = 0.03;  // m

 private:
  int num_joints_ = 0;
  Eigen::Matrix3Xd rest_points_, rest_normals_, points_, normals_;
  // Sample s's bones: joint_[offset_[s] .. offset_[s + 1]), weights weight_.
  std::vector<int> offset_, joint_;
  std::vector<double> weight_;
  std::unique_ptr<RefitPointTree> tree_;  // built once, refitted per pose

  // The answer for point given its nearest sample (-1: none).
  SignedDistanceResult Result(const Eigen::Vector3d& point, int nearest) const;
};

// ProximitySize(probes.probes_per_patch) by #patches into *features
// (resized): per patch, per
// probe [d, F^T n] as above. pose: one rest-to-posed transform per joint;
// body: posed by the same pose.
// hints (may be null; one per probe, patch-major, -1 for none, resized):
// each probe's nearest sample as last found, which starts the next
// search's bound there (a probe moves little from frame to frame). A
// patch's probes are searched as one group (QueryGroup); a probe without
// a hint starts from the first of its patch's hints. The same answers
// (but for ties), found sooner.
void BodyProximityFeatures(const PatchProbes& probes, const JointTransforms& pose, const PosedBodySamples& body,
                           Eigen::MatrixXd* features, std::vector<int>* hints = nullptr);
// The same at other places of the probes (3 by probes_per_patch #patches,
// in the rest pose: PlaceProbes), and, when distance_gradients is not
// null, per probe the derivative of its feature d with respect to its
// rest-pose point (3 by probes_per_patch #patches; zero where d is
// clamped): n^T L / kProximityScale, L the patch's blended skinning, with
// the nearest sample held (the features are piecewise smooth in the
// points; the normals' features piecewise constant).
void BodyProximityFeatures(const PatchProbes& probes, const Eigen::Matrix3Xd& points, const JointTransforms& pose,
                           const PosedBodySamples& body, Eigen::MatrixXd* features,
                           Eigen::Matrix3Xd* distance_gradients = nullptr, std::vector<int>* hints = nullptr);

// The probes on other patch parameters (DrapeSolver's layout: alpha
// (NumJetCoefficients(jet_order)), s, T first of `stride` per patch):
// each probe's canonical point X = s R_0 [u, v, z(u, v)] + T
// (SkinnedPatchPoint::Canonical), at the probe's rest (u, v): the
// warp's slides move the material along the surface, not the surface,
// and are left out. At the rest parameters, the rest points. points:
// 3 by probes_per_patch #patches (resized).
void PlaceProbes(const PatchProbes& probes, const std::vector<double>& patch_parameters, int jet_order, int stride,
                 Eigen::Matrix3Xd* points);
// Adds to gradient (DrapeSolver's layout, as patch_parameters) dL/d(patch
// parameters) through the probes' distances, given dL/d(features)
// (ProximitySize by #patches) and the distance gradients at the placed
// probes (BodyProximityFeatures).
void ChainProbesToPatchParameters(const PatchProbes& probes, const std::vector<double>& patch_parameters, int jet_order,
                                  int stride, const Eigen::Matrix3Xd& distance_gradients,
                                  const Eigen::MatrixXd& d_features, std::vector<double>* gradient);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_BODY_PROXIMITY_H_
