#include "drape/network/onefit_draper.h"

#include <string>

#include "polyfit/jet/jet_basis.h"

namespace polyfit {

void PatchLikeModel(const OneFitModel& model, DrapeSolverOptions* options) {
  options->slide.warp_order = model.network.warp_order();
  options->patching.align_frames = model.aligned_frames;
  options->patching.patch_area = model.patch_area;
  options->patching.max_fit_error = model.max_fit_error;
  options->patching.curved_faces = model.curved_faces;
  options->patching.jet_order = model.jet_order;
}

PatchOutputMap MakePatchOutputMap(const DrapeSolver& solver, int jet_order, int warp_order, bool area_units,
                                  double warp_slide_bound) {
  PatchOutputMap map;
  map.rest = solver.RestPatchParameters();
  const PolyFitModel& model = solver.model();
  const int stride = solver.num_patch_parameters(), k = NumJetCoefficients(jet_order);
  const std::vector<double> areas = solver.PatchRestAreas();
  map.units.resize(stride, model.num_patches());
  map.warp_slide_bound = warp_slide_bound;
  for (int p = 0; p < model.num_patches(); ++p) {
    map.frames.push_back(model.patches[p].frame.rotation);
    map.units.col(p) =
        PatchOutputUnits(jet_order, warp_order, map.rest[p * stride + k], areas[p], solver.WarpRadii()[p], area_units);
  }
  return map;
}

OneFitDraper::OneFitDraper(const OneFitModel& model, const DrapeSolver& solver, const SkinWeights& weights,
                           const Skeleton& skeleton, const SkinnedBody* body, InferencePrecision precision)
    : model_(model), precision_(precision), skeleton_(skeleton) {
  if (skeleton.num_joints() != model.num_joints) {
    throw OneFitModelError("the model was trained for a rig of " + std::to_string(model.num_joints) +
                               " joints, the body has " + std::to_string(skeleton.num_joints()),
                           ErrorKind::kInvalidArgument);
  }
  if (solver.num_patch_parameters() != model.network.num_outputs()) {
    throw OneFitModelError("the model predicts jets or warps of another order than the drape's",
                           ErrorKind::kInvalidArgument);
  }
  map_ =
      MakePatchOutputMap(solver, model.jet_order, model.network.warp_order(), model.area_units, model.warp_slide_bound);
  const Eigen::MatrixXd features = model.patch_normalizer.Apply(
      PatchFeatures(solver.model(), map_.rest, map_.units, model.jet_order, weights, skeleton));
  garment_half_ = model.network.GarmentHalf(model.weights.data(), features);
  joint_weights_ = PatchJointWeights(solver.model(), weights, skeleton.num_joints());
  body_mask_ = BodyFeatureMask(weights, skeleton, model.joint_mask_reach);
  if (model.network.body_proximity()) {
    if (body == nullptr || body->skeleton.num_joints() != skeleton.num_joints()) {
      throw OneFitModelError("the model reads where the garment meets the body: the body is needed",
                             ErrorKind::kInvalidArgument);
    }
    probes_ =
        MakePatchProbes(solver.model(), solver.PatchRestAreas(), joint_weights_, model.network.proximity_probes());
    posed_body_ = std::make_unique<PosedBodySamples>(*body);
  }
  if (model.network.feedback()) {
    feedback_half_ = model.network.FeedbackGarmentHalf(model.weights.data(), features);
    output_proximity_ = std::make_unique<OutputProximity>(map_, probes_, model.jet_order);
  }
  if (precision_ == InferencePrecision::kFloat) {
    weights_f_.assign(model.weights.begin(), model.weights.end());
    garment_half_f_ = garment_half_.cast<float>();
    feedback_half_f_ = feedback_half_.cast<float>();
  }
}

// The network's outputs (num_outputs by #patches, double) from the
// frame's normalised body features, in T.
template <typename T>
Eigen::MatrixXd OneFitDraper::Outputs(const T* weights, const MatrixX<T>& garment_half, const MatrixX<T>& feedback_half,
                                      const JointTransforms& now, const Eigen::VectorXd& body) const {
  MatrixX<T> outputs, refined, patch_inputs;
  VectorX<T> z_b;
  model_.network.ForwardWithGarmentHalf<T>(weights, garment_half, body, &joint_weights_, &proximity_, &outputs, &z_b,
                                           &patch_inputs);
  for (int pass = 0; pass < model_.network.feedback_passes(); ++pass) {
    const Eigen::MatrixXd& output_proximity =
        output_proximity_->Evaluate(outputs.template cast<double>(), now, *posed_body_, false);
    model_.network.FeedbackWithGarmentHalf<T>(weights, feedback_half, z_b, patch_inputs, outputs, output_proximity,
                                              &refined);
    outputs.swap(refined);
  }
  return outputs.template cast<double>();
}

std::vector<double> OneFitDraper::Predict(const JointTransforms& before_previous, const JointTransforms& previous,
                                          const JointTransforms& now, double fps, const BodyShape& shape) const {
  const Eigen::VectorXd body =
      model_.body_normalizer
          .Apply(BodyFeatures(skeleton_, before_previous, previous, now, fps, shape, model_.root_rotation))
          .cwiseProduct(body_mask_);
  if (posed_body_) {
    posed_body_->Pose(now);
    BodyProximityFeatures(probes_, now, *posed_body_, &proximity_, &proximity_hints_);
  }
  const Eigen::MatrixXd outputs =
      precision_ == InferencePrecision::kFloat
          ? Outputs<float>(weights_f_.data(), garment_half_f_, feedback_half_f_, now, body)
          : Outputs<double>(model_.weights.data(), garment_half_, feedback_half_, now, body);
  return PatchParametersFromOutputs(map_, outputs, model_.network.num_coefficients());
}

}  // namespace polyfit
