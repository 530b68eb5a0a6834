// The per-pixel robust loss of PolySfT's photometric residual.
#ifndef POLYFIT_SFT_SOLVER_ROBUST_LOSS_H_
#define POLYFIT_SFT_SOLVER_ROBUST_LOSS_H_

namespace polyfit {

enum class RobustLoss { kNone, kHuber, kCauchy };

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_ROBUST_LOSS_H_
