// OneFit's loss weights, the paper's values as defaults. The draping terms
// are the cost functors of cost_functions/ (collision_residual.h,
// metric_inextensibility_residual.h, patch_boundary_residual.h,
// edge_inextensibility.h, gravity_inertia_residuals.h); a residual weight is
// sqrt of the term's weight (Ceres minimises half the squared residuals).
#ifndef POLYFIT_DRAPE_LOSSES_DRAPING_WEIGHTS_H_
#define POLYFIT_DRAPE_LOSSES_DRAPING_WEIGHTS_H_

#include <algorithm>

namespace polyfit {

struct DrapingWeights {
  double boundary = 5e3;           // k_b, patch boundary continuity (eq. 5)
  double inextensibility = 2.0;    // k_mi, metric tensor (eq. 4) and edges (eq. 1)
  double gravity = 1.0;            // k_g (eq. 7)
  double collision = 1.0;          // k_c (eq. 3)
  double inertia = 0.5;            // k_i (eq. 8)
  double collision_margin = 4e-3;  // eps, metres
};

// k_ext (eq. 4): the rest metric a point is held to is scaled by
//   k_ext = 1 + min(d_c, max_depth) min(epoch, max_epoch)
// with d_c the point's penetration depth (m, 0 outside the body): as
// training goes on, a point caught inside the body may stretch (up to
// twice its rest metric with the paper's 0.01 m and 100 epochs) to get
// out. Epochs are the reference drape's frames and, in training, a
// fraction of the budget (OneFitTrainerOptions::kext_final_epoch).
struct KextOptions {
  double max_depth = 0.01;
  double max_epoch = 100.0;

  double operator()(double penetration_depth, double epoch) const {
    const double depth = penetration_depth > 0.0 ? std::min(penetration_depth, max_depth) : 0.0;
    return 1.0 + depth * std::clamp(epoch, 0.0, max_epoch);
  }
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_LOSSES_DRAPING_WEIGHTS_H_
