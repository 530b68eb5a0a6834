// A garment draped by a trained OneFit model: its patches (the reference
// drape's patching, so that the patches are the ones the loss saw) and
// their features are prepared once; per frame, the body's features, the
// network with the garment's half of the decoder's first layer
// precomputed (then, with a feedback decoder, the proximity at the
// decoder's patches and the feedback), and the patch parameters out.
#ifndef POLYFIT_DRAPE_NETWORK_ONEFIT_DRAPER_H_
#define POLYFIT_DRAPE_NETWORK_ONEFIT_DRAPER_H_

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "drape/network/body_proximity.h"
#include "drape/network/onefit_model.h"
#include "drape/network/output_proximity.h"
#include "drape/simulate/drape_solver.h"

namespace polyfit {

// Sets what in `options` must agree with `model` for its predictions to fit
// the garment's patches: the parameter layout (warp order) and the patching
// (frame alignment, patch area, fit error, curved faces, jet order) it was
// trained on.
void PatchLikeModel(const OneFitModel& model, DrapeSolverOptions* options);

// What the network's outputs are to the solver's patches (PatchOutputUnits,
// BoundWarpComponent). jet_order, warp_order: the solver's (GarmentPatchOptions,
// DrapeSlideOptions).
PatchOutputMap MakePatchOutputMap(const DrapeSolver& solver, int jet_order, int warp_order, bool area_units,
                                  double warp_slide_bound);

// What the network's per-frame half runs in: float by default (twice
// double's SIMD lanes; its outputs within about 1e-6 of the outputs'
// bounds of double's, far below what moves a vertex), double to match
// training's forward pass to rounding.
enum class InferencePrecision { kFloat, kDouble };

class OneFitDraper {
 public:
  // solver: the garment's drape (its patches); body: the body it is draped
  // on (its skeleton `skeleton`), needed by a model that reads the body
  // proximity (posed each frame, within the inference's time) and else
  // ignored. Throws OneFitModelError (kInvalidArgument) when the model does
  // not fit the rig or the jets, or needs a body that is not given.
  OneFitDraper(const OneFitModel& model, const DrapeSolver& solver, const SkinWeights& weights,
               const Skeleton& skeleton, const SkinnedBody* body = nullptr,
               InferencePrecision precision = InferencePrecision::kFloat);
  // Its parts refer to each other.
  OneFitDraper(const OneFitDraper&) = delete;
  OneFitDraper& operator=(const OneFitDraper&) = delete;

  // The patch parameters (DrapeSolver's layout) for frame `now`, its two
  // predecessors giving the motion. Not thread-safe (the posed body).
  std::vector<double> Predict(const JointTransforms& before_previous, const JointTransforms& previous,
                              const JointTransforms& now, double fps, const BodyShape& shape) const;

  // The body's samples posed at the last Predict's `now` (the body
  // proximity's), or null for a model without the body proximity.
  const PosedBodySamples* posed_body() const { return posed_body_.get(); }

 private:
  template <typename T>
  Eigen::MatrixXd Outputs(const T* weights, const MatrixX<T>& garment_half, const MatrixX<T>& feedback_half,
                          const JointTransforms& now, const Eigen::VectorXd& body) const;

  const OneFitModel& model_;
  InferencePrecision precision_;
  const Skeleton& skeleton_;
  PatchOutputMap map_;
  Eigen::MatrixXd garment_half_;
  // The float path's weights and garment halves (kFloat only).
  std::vector<float> weights_f_;
  Eigen::MatrixXf garment_half_f_, feedback_half_f_;
  Eigen::MatrixXd joint_weights_;  // #joints by #patches, for the local pose
  Eigen::VectorXd body_mask_;      // BodyFeatureMask by the model's reach
  // With the body proximity: the patches' probes, the body posed per frame
  // and the features (buffers reused from frame to frame).
  PatchProbes probes_;
  std::unique_ptr<PosedBodySamples> posed_body_;
  mutable Eigen::MatrixXd proximity_;
  mutable std::vector<int> proximity_hints_;  // BodyProximityFeatures' hints
  // With the feedback decoder: its garment half and the proximity at the
  // decoder's patches.
  Eigen::MatrixXd feedback_half_;
  std::unique_ptr<OutputProximity> output_proximity_;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_ONEFIT_DRAPER_H_
