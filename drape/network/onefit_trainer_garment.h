// The trainer's per-garment data, shared by its translation units
// (onefit_trainer.cc, onefit_polish.cc); not part of the library's API.
#ifndef POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINER_GARMENT_H_
#define POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINER_GARMENT_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

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
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_NETWORK_ONEFIT_TRAINER_GARMENT_H_
