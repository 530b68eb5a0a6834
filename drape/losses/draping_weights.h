// OneFit's loss weights, the paper's values as defaults. The draping terms
// are the cost functors of cost_functions/ (collision_residual.h,
// metric_inextensibility_residual.h, patch_boundary_residual.h,
// edge_inextensibility.h, gravity_inertia_residuals.h); a residual weight is
// sqrt of the term's weight (Ceres minimises half the squared residuals).
#ifndef POLYFIT_DRAPE_LOSSES_DRAPING_WEIGHTS_H_
#define POLYFIT_DRAPE_LOSSES_DRAPING_WEIGHTS_H_

namespace polyfit {

struct DrapingWeights {
  double boundary = 5e3;           // k_b, patch boundary continuity (eq. 5)
  double inextensibility = 2.0;    // k_mi, metric tensor (eq. 4) and edges (eq. 1)
  double gravity = 1.0;            // k_g (eq. 7)
  double collision = 1.0;          // k_c (eq. 3)
  double inertia = 0.5;            // k_i (eq. 8)
  double collision_margin = 4e-3;  // eps, metres
};

// k_ext: the metric-tensor term (eq. 4) is ramped in, from `start` times
// its weight to the full weight over `ramp_steps` steps (frames of the
// reference drape, optimiser steps of training), so that a garment first
// settles against the body under a soft metric and is then held to its
// rest metric.
struct KextSchedule {
  double start = 0.1;
  int ramp_steps = 10;

  double operator()(int step) const {
    if (ramp_steps <= 0 || step >= ramp_steps) return 1.0;
    if (step <= 0) return start;
    return start + (1.0 - start) * static_cast<double>(step) / ramp_steps;
  }
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_LOSSES_DRAPING_WEIGHTS_H_
