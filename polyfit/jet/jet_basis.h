// Monomial basis of an n-jet height function
//
//   z(u, v) = sum_{d=0..n} sum_{b=0..d} alpha_{d-b,b} u^(d-b) v^b,
//
// with coefficients stored by total degree d, then by the power b of v:
// alpha_{a,b} sits at index d(d+1)/2 + b with d = a + b. An n-jet has
// (n+1)(n+2)/2 coefficients (15 for n = 4, 45 for n = 8).
//
// Templated on the scalar so that ceres::Jet flows through the same code.
#ifndef POLYFIT_JET_JET_BASIS_H_
#define POLYFIT_JET_JET_BASIS_H_

namespace polyfit {

constexpr int kMaxJetOrder = 8;

constexpr int NumJetCoefficients(int order) { return (order + 1) * (order + 2) / 2; }

constexpr int kMaxJetCoefficients = NumJetCoefficients(kMaxJetOrder);

// Index of alpha_{a,b}, the coefficient of u^a v^b.
constexpr int JetCoefficientIndex(int a, int b) { return (a + b) * (a + b + 1) / 2 + b; }

// Powers u^0..u^order and v^0..v^order by recurrence (no pow()).
template <typename T>
inline void JetPowers(int order, const T& u, const T& v, T* u_pow, T* v_pow) {
  u_pow[0] = T(1.0);
  v_pow[0] = T(1.0);
  for (int i = 1; i <= order; ++i) {
    u_pow[i] = u_pow[i - 1] * u;
    v_pow[i] = v_pow[i - 1] * v;
  }
}

// monomials: NumJetCoefficients(order) values u^a v^b in coefficient order.
template <typename T>
inline void JetMonomials(int order, const T& u, const T& v, T* monomials) {
  T u_pow[kMaxJetOrder + 1];
  T v_pow[kMaxJetOrder + 1];
  JetPowers(order, u, v, u_pow, v_pow);
  int k = 0;
  for (int d = 0; d <= order; ++d) {
    for (int b = 0; b <= d; ++b) monomials[k++] = u_pow[d - b] * v_pow[b];
  }
}

// The monomials m_k = u^a v^b and their partial derivatives
// m_k,u = a u^(a-1) v^b and m_k,v = b u^a v^(b-1), each NumJetCoefficients
// values in coefficient order: z = alpha . m, z_u = alpha . m_u,
// z_v = alpha . m_v, and d(z, z_u, z_v)/d alpha = (m, m_u, m_v).
template <typename T>
inline void JetMonomialGradients(int order, const T& u, const T& v, T* monomials, T* monomials_u, T* monomials_v) {
  T u_pow[kMaxJetOrder + 1];
  T v_pow[kMaxJetOrder + 1];
  JetPowers(order, u, v, u_pow, v_pow);
  int k = 0;
  for (int d = 0; d <= order; ++d) {
    for (int b = 0; b <= d; ++b, ++k) {
      const int a = d - b;
      monomials[k] = u_pow[a] * v_pow[b];
      monomials_u[k] = a >= 1 ? T(double(a)) * u_pow[a - 1] * v_pow[b] : T(0.0);
      monomials_v[k] = b >= 1 ? T(double(b)) * u_pow[a] * v_pow[b - 1] : T(0.0);
    }
  }
}

}  // namespace polyfit

#endif  // POLYFIT_JET_JET_BASIS_H_
