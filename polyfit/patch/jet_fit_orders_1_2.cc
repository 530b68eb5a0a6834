// Jet orders 1 and 2 of JetFitter (jet_fit_kernel.h says why they are apart).
#include "polyfit/patch/jet_fit_kernel.h"

namespace polyfit {
namespace internal {

POLYFIT_DEFINE_JET_ORDER_KERNELS(1, 2)

}  // namespace internal
}  // namespace polyfit
