// Jet orders 3 and 4 of JetFitter (jet_fit_kernel.h says why they are apart).
#include "polyfit/patch/jet_fit_kernel.h"

namespace polyfit {
namespace internal {

POLYFIT_DEFINE_JET_ORDER_KERNELS(3, 4)

}  // namespace internal
}  // namespace polyfit
