// Jet orders 5 and 6 of JetFitter (jet_fit_kernel.h says why they are apart).
#include "polyfit/patch/jet_fit_kernel.h"

namespace polyfit {
namespace internal {

std::unique_ptr<JetOrderKernel> MakeJetOrderKernel5To6(int order) {
  switch (order) {
    case 5: return std::make_unique<JetOrderKernelImpl<21>>();
    case 6: return std::make_unique<JetOrderKernelImpl<28>>();
    default: return nullptr;
  }
}

}  // namespace internal
}  // namespace polyfit
