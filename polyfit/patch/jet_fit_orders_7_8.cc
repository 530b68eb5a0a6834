// Jet orders 7 and 8 of JetFitter (jet_fit_kernel.h says why they are apart).
#include "polyfit/patch/jet_fit_kernel.h"

namespace polyfit {
namespace internal {

std::unique_ptr<JetOrderKernel> MakeJetOrderKernel7To8(int order) {
  switch (order) {
    case 7: return std::make_unique<JetOrderKernelImpl<36>>();
    case 8: return std::make_unique<JetOrderKernelImpl<45>>();
    default: return nullptr;
  }
}

}  // namespace internal
}  // namespace polyfit
