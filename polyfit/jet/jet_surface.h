// Differential geometry of the height graph phi(u, v) = (u, v, z(u, v)) of an
// n-jet z (see jet_basis.h for the coefficient layout).
//
// All quantities are in the patch's own (u, v, z) coordinates. A patch placed
// in the world as p = s * R * phi(u, v) + T has the same unit normal rotated
// by R, a first fundamental form scaled by s^2 and a second one scaled by s.
#ifndef POLYFIT_JET_JET_SURFACE_H_
#define POLYFIT_JET_JET_SURFACE_H_

#include <cmath>

#include "polyfit/jet/jet_basis.h"

namespace polyfit {

template <typename T>
struct JetHeightDerivatives {
  T z, z_u, z_v;       // value and gradient
  T z_uu, z_uv, z_vv;  // Hessian
};

// z(u, v) for the coefficients alpha (NumJetCoefficients(order) values),
// by Horner's scheme: z = sum_b v^b p_b(u), p_b(u) = sum_a alpha_(a+b, b)
// u^a, each nested in turn (alpha_(d, b), of u^(d-b) v^b, at index
// d (d + 1) / 2 + b). No array of powers: with the order known at compile
// time the whole sum stays in registers (an array written a lane at a
// time and read as a vector stalled the store forwarding).
template <typename T>
inline T EvaluateJetHeight(int order, const T* alpha, const T& u, const T& v) {
  T z(0.0);
  for (int b = order; b >= 0; --b) {
    T p(0.0);
    for (int a = order - b; a >= 0; --a) {
      const int d = a + b;
      p = p * u + alpha[d * (d + 1) / 2 + b];
    }
    z = z * v + p;
  }
  return z;
}

// z and its partial derivatives up to second order.
template <typename T>
inline JetHeightDerivatives<T> EvaluateJetDerivatives(int order, const T* alpha, const T& u, const T& v) {
  T u_pow[kMaxJetOrder + 1];
  T v_pow[kMaxJetOrder + 1];
  JetPowers(order, u, v, u_pow, v_pow);
  JetHeightDerivatives<T> r{T(0.0), T(0.0), T(0.0), T(0.0), T(0.0), T(0.0)};
  int k = 0;
  for (int d = 0; d <= order; ++d) {
    for (int b = 0; b <= d; ++b, ++k) {
      const int a = d - b;
      const T& c = alpha[k];
      r.z += c * u_pow[a] * v_pow[b];
      if (a >= 1) r.z_u += c * double(a) * u_pow[a - 1] * v_pow[b];
      if (b >= 1) r.z_v += c * double(b) * u_pow[a] * v_pow[b - 1];
      if (a >= 2) r.z_uu += c * double(a * (a - 1)) * u_pow[a - 2] * v_pow[b];
      if (a >= 1 && b >= 1) r.z_uv += c * double(a * b) * u_pow[a - 1] * v_pow[b - 1];
      if (b >= 2) r.z_vv += c * double(b * (b - 1)) * u_pow[a] * v_pow[b - 2];
    }
  }
  return r;
}

// Unit normal (-z_u, -z_v, 1) / sqrt(1 + z_u^2 + z_v^2); normal[3].
template <typename T>
inline void JetNormal(const JetHeightDerivatives<T>& d, T* normal) {
  using std::sqrt;
  const T w = sqrt(T(1.0) + d.z_u * d.z_u + d.z_v * d.z_v);
  normal[0] = -d.z_u / w;
  normal[1] = -d.z_v / w;
  normal[2] = T(1.0) / w;
}

// First fundamental form [E F; F G] of phi: E = 1 + z_u^2, F = z_u z_v,
// G = 1 + z_v^2.
template <typename T>
struct FundamentalForm {
  T e, f, g;
};

template <typename T>
inline FundamentalForm<T> JetFirstFundamentalForm(const JetHeightDerivatives<T>& d) {
  return {T(1.0) + d.z_u * d.z_u, d.z_u * d.z_v, T(1.0) + d.z_v * d.z_v};
}

// Second fundamental form [L M; M N] against the normal of JetNormal:
// (z_uu, z_uv, z_vv) / sqrt(1 + z_u^2 + z_v^2).
template <typename T>
inline FundamentalForm<T> JetSecondFundamentalForm(const JetHeightDerivatives<T>& d) {
  using std::sqrt;
  const T w = sqrt(T(1.0) + d.z_u * d.z_u + d.z_v * d.z_v);
  return {d.z_uu / w, d.z_uv / w, d.z_vv / w};
}

// Gaussian curvature (LN - M^2) / (EG - F^2) and mean curvature
// (EN - 2FM + GL) / (2 (EG - F^2)).
template <typename T>
inline void JetCurvatures(const JetHeightDerivatives<T>& d, T* gaussian, T* mean) {
  const FundamentalForm<T> I = JetFirstFundamentalForm(d);
  const FundamentalForm<T> II = JetSecondFundamentalForm(d);
  const T det = I.e * I.g - I.f * I.f;
  *gaussian = (II.e * II.g - II.f * II.f) / det;
  *mean = (I.e * II.g - T(2.0) * I.f * II.f + I.g * II.e) / (T(2.0) * det);
}

}  // namespace polyfit

#endif  // POLYFIT_JET_JET_SURFACE_H_
