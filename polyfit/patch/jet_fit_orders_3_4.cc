// Jet orders 3 and 4 of JetFitter (jet_fit_kernel.h says why they are apart).
#include "polyfit/patch/jet_fit_kernel.h"

namespace polyfit {
namespace internal {

std::unique_ptr<JetOrderKernel> MakeJetOrderKernel3To4(int order) {
  switch (order) {
    case 3: return std::make_unique<JetOrderKernelImpl<10>>();
    case 4: return std::make_unique<JetOrderKernelImpl<15>>();
    default: return nullptr;
  }
}

}  // namespace internal
}  // namespace polyfit
