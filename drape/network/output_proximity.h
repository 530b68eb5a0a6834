// Where the patches that a OneFit network's outputs give meet the posed
// body: the feedback decoder's input (OneFitNetworkOptions::feedback), and
// its gradient back to those outputs. The probes (body_proximity.h) are
// placed on the patches the outputs give (PlaceProbes), posed by the
// garment's skinning and measured against the body's samples.
#ifndef POLYFIT_DRAPE_NETWORK_OUTPUT_PROXIMITY_H_
#define POLYFIT_DRAPE_NETWORK_OUTPUT_PROXIMITY_H_

#include <vector>

#include <Eigen/Core>

#include "drape/network/body_proximity.h"
#include "drape/network/onefit_network.h"

namespace polyfit {

class OutputProximity {
 public:
  // map, probes: one garment's (kept by reference); jet_order: its jets'.
  OutputProximity(const PatchOutputMap& map, const PatchProbes& probes, int jet_order);

  // The features (ProximitySize by #patches) of the patches `outputs`
  // (num_outputs by #patches) give, on `body` posed by `pose`. Without
  // for_chain (inference), Chain cannot follow.
  const Eigen::MatrixXd& Evaluate(const Eigen::MatrixXd& outputs, const JointTransforms& pose,
                                  const PosedBodySamples& body, bool for_chain = true);
  // dL/doutputs at the last Evaluate's outputs given dL/dfeatures, through
  // the probes' distances (the nearest samples held). Throws
  // std::logic_error after an Evaluate without for_chain.
  Eigen::MatrixXd Chain(const Eigen::MatrixXd& d_features) const;

 private:
  const PatchOutputMap& map_;
  const PatchProbes& probes_;
  int jet_order_ = 0;
  Eigen::MatrixXd outputs_, features_;
  std::vector<double> parameters_;
  Eigen::Matrix3Xd points_, distance_gradients_;
  bool chainable_ = false;
  std::vector<int> hints_;  // per probe, from the last Evaluate
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_OUTPUT_PROXIMITY_H_
