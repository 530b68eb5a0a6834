// The trainer's per-garment data, shared by its translation units
// (onefit_trainer.cc, onefit_polish.cc); not part of the library's API.
#ifndef POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINER_GARMENT_H_
#define POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINER_GARMENT_H_

#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "drape/network/body_proximity.h"
#include "drape/network/onefit_network.h"
#include "drape/network/onefit_trainer.h"
#include "drape/simulate/drape_solver.h"

namespace polyfit {

// Per garment (and body): one drape (the loss) per thread, and what the
// network reads.
struct OneFitTrainer::GarmentData {
  std::string name;
  int body = 0;
  std::vector<std::unique_ptr<DrapeSolver>> solvers;  // per thread
  PatchOutputMap map;                                 // rest parameters, frames, output units
  Eigen::MatrixXd raw_features, features;             // per patch: raw, normalised
  Eigen::MatrixXd joint_weights;                      // #joints by #patches
  Eigen::VectorXd body_mask;                          // BodyFeatureMask
  PatchProbes probes;                                 // with the body proximity
};

// Per thread: its copy of every body, posed as a frame needs, and the
// proximity features of the frames it computed last, by (garment, clip,
// frame): a batch's iterations revisit its samples' frames.
struct OneFitTrainer::ProximityCache {
  std::vector<std::unique_ptr<PosedBodySamples>> bodies;
  std::map<std::tuple<int, int, int>, Eigen::MatrixXd> features;
  std::vector<std::pair<int, int>> posed;  // per body: the (clip, frame) it is posed for, or (-1, -1)
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINER_GARMENT_H_
