// Jet orders 1 and 2 of JetFitter (jet_fit_kernel.h says why they are apart).
#include "polyfit/patch/jet_fit_kernel.h"

namespace polyfit {
namespace internal {

std::unique_ptr<JetOrderKernel> MakeJetOrderKernel1To2(int order) {
  switch (order) {
    case 1: return std::make_unique<JetOrderKernelImpl<3>>();
    case 2: return std::make_unique<JetOrderKernelImpl<6>>();
    default: return nullptr;
  }
}

}  // namespace internal
}  // namespace polyfit
