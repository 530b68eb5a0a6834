// DispatchJetCoefficients(order, who, make): calls make with
// std::integral_constant<int, NumJetCoefficients(order)>, so that a functor's
// Create(order, ...) can pick the AutoDiffCostFunction with a compile-time
// coefficient count. Throws std::invalid_argument naming `who` for an order
// outside [1, 8].
#ifndef COST_FUNCTIONS_JET_ORDER_DISPATCH_H_
#define COST_FUNCTIONS_JET_ORDER_DISPATCH_H_

#include <stdexcept>
#include <string>
#include <type_traits>

#include "polyfit/jet/jet_basis.h"

namespace polyfit {

template <typename Make>
auto DispatchJetCoefficients(int order, const char* who, Make&& make) {
  switch (order) {
    case 1: return make(std::integral_constant<int, NumJetCoefficients(1)>{});
    case 2: return make(std::integral_constant<int, NumJetCoefficients(2)>{});
    case 3: return make(std::integral_constant<int, NumJetCoefficients(3)>{});
    case 4: return make(std::integral_constant<int, NumJetCoefficients(4)>{});
    case 5: return make(std::integral_constant<int, NumJetCoefficients(5)>{});
    case 6: return make(std::integral_constant<int, NumJetCoefficients(6)>{});
    case 7: return make(std::integral_constant<int, NumJetCoefficients(7)>{});
    case 8: return make(std::integral_constant<int, NumJetCoefficients(8)>{});
    default: throw std::invalid_argument(std::string(who) + ": order must be in [1, 8], got " + std::to_string(order));
  }
}

}  // namespace polyfit

#endif  // COST_FUNCTIONS_JET_ORDER_DISPATCH_H_
