#include "drape/network/output_proximity.h"

#include <stdexcept>

#include "polyfit/jet/jet_basis.h"

namespace polyfit {

OutputProximity::OutputProximity(const PatchOutputMap& map, const PatchProbes& probes, int jet_order)
    : map_(map), probes_(probes), jet_order_(jet_order) {}

const Eigen::MatrixXd& OutputProximity::Evaluate(const Eigen::MatrixXd& outputs, const JointTransforms& pose,
                                                 const PosedBodySamples& body, bool for_chain) {
  chainable_ = for_chain;
  if (for_chain) outputs_ = outputs;
  // The probes sit at fixed (u, v): the warps do not move them.
  parameters_ = PatchParametersFromOutputs(map_, outputs, NumJetCoefficients(jet_order_), false);
  PlaceProbes(probes_, parameters_, jet_order_, static_cast<int>(map_.units.rows()), &points_);
  BodyProximityFeatures(probes_, points_, pose, body, &features_, for_chain ? &distance_gradients_ : nullptr,
                        &hints_);
  return features_;
}

Eigen::MatrixXd OutputProximity::Chain(const Eigen::MatrixXd& d_features) const {
  if (!chainable_) throw std::logic_error("OutputProximity::Chain after an Evaluate without for_chain");
  std::vector<double> d_parameters(parameters_.size(), 0.0);
  ChainProbesToPatchParameters(probes_, parameters_, jet_order_, static_cast<int>(map_.units.rows()),
                               distance_gradients_, d_features, &d_parameters);
  return ChainPatchParameterGradient(map_, outputs_, NumJetCoefficients(jet_order_), d_parameters);
}

}  // namespace polyfit
