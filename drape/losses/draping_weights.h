// OneFit's loss weights, the paper's values as defaults. The draping terms
// are the cost functors of cost_functions/ (collision_residual.h,
// metric_inextensibility_residual.h, patch_boundary_residual.h,
// edge_inextensibility.h, gravity_inertia_residuals.h); a residual weight is
// sqrt of the term's weight (Ceres minimises half the squared residuals).
#ifndef POLYFIT_DRAPE_LOSSES_DRAPING_WEIGHTS_H_
#define POLYFIT_DRAPE_LOSSES_DRAPING_WEIGHTS_H_

namespace polyfit {

struct DrapingWeights {
  double boundary = 5e3;         // k_b, patch boundary continuity (eq. 5)
  double inextensibility = 2.0;  // k_mi, metric tensor (eq. 4) and edges (eq. 1)
  double gravity = 1.0;          // k_g (eq. 7)
  double collision = 1.0;        // k_c (eq. 3)
  double inertia = 0.5;          // k_i (eq. 8)
  double collision_margin = 4e-3;  // eps, metres
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_LOSSES_DRAPING_WEIGHTS_H_
