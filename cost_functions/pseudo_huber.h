// The pseudo-Huber penalty as a factor on a residual, so that a least-squares
// solver minimises it without a loss function: for a residual r of norm
// s = |r| and a scale b > 0,
//   |phi(s / b) r|^2 = 2 b^2 (sqrt(1 + (s/b)^2) - 1),
//   phi(x) = sqrt(2 / (1 + sqrt(1 + x^2))),
// s^2 well below b (phi -> 1), 2 b s well above. Templated for automatic
// differentiation.
#ifndef COST_FUNCTIONS_PSEUDO_HUBER_H_
#define COST_FUNCTIONS_PSEUDO_HUBER_H_

#include <cmath>

namespace polyfit {

template <typename T>
inline T PseudoHuberFactor(const T& x) {
  using std::sqrt;
  return sqrt(T(2.0) / (T(1.0) + sqrt(T(1.0) + x * x)));
}

}  // namespace polyfit

#endif  // COST_FUNCTIONS_PSEUDO_HUBER_H_
