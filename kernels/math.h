// kernels/math.h — small POD vectors and rotations for per-index kernels.
//
// Conventions (used everywhere in manyrods):
//   * A frame Q is a 3×3 matrix whose ROWS are the directors d1, d2, d3.
//     Q maps lab components to material components: a_material = Q a_lab.
//   * Angular velocity ω is stored in material components. With
//     ḋ_k = ω_lab × d_k one gets  Q̇ = −[ω]× Q, so a step of length h is
//     Q ← exp(−[hω]×) Q  (exact for constant ω).
//   * rotation_log(R) returns ψ with R = exp([ψ]×), |ψ| ∈ [0, π].
//
// Every function here is MANYRODS_HD inline: it compiles as host code and as
// CUDA device code. No STL, no exceptions, no allocation.
//
// reads: arguments only  writes: return value only
#pragma once

#include <cmath>

// Kernels are always inlined into the launch loops on the host: a call that
// is not inlined stops the loop from vectorizing.
#if defined(__CUDACC__)
#define MANYRODS_HD __host__ __device__
#elif defined(__GNUC__)
#define MANYRODS_HD __attribute__((always_inline))
#else
#define MANYRODS_HD
#endif

// Fully unroll the short fixed loops inside kernels, so that a host launcher's
// `omp simd` loop over indices vectorizes across indices (otherwise GCC
// vectorizes the 3- or 9-long inner loop, or nothing).
#if defined(__CUDACC__)
#define MANYRODS_UNROLL _Pragma("unroll")
#elif defined(__clang__)
#define MANYRODS_UNROLL _Pragma("clang loop unroll(full)")
#elif defined(__GNUC__)
#define MANYRODS_UNROLL _Pragma("GCC unroll 16")
#else
#define MANYRODS_UNROLL
#endif

namespace manyrods {

template <class T>
struct vec3 {
  T x, y, z;
};

// Row-major 3×3: m[3*i + j] is row i, column j.
template <class T>
struct mat3 {
  T m[9];
};

template <class T>
MANYRODS_HD inline vec3<T> operator+(vec3<T> a, vec3<T> b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
MANYRODS_HD inline vec3<T> operator-(vec3<T> a, vec3<T> b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
MANYRODS_HD inline vec3<T> operator-(vec3<T> a) {
  return {-a.x, -a.y, -a.z};
}
template <class T>
MANYRODS_HD inline vec3<T> operator*(T s, vec3<T> a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <class T>
MANYRODS_HD inline vec3<T> hadamard(vec3<T> a, vec3<T> b) {
  return {a.x * b.x, a.y * b.y, a.z * b.z};
}
template <class T>
MANYRODS_HD inline T dot(vec3<T> a, vec3<T> b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
MANYRODS_HD inline vec3<T> cross(vec3<T> a, vec3<T> b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
MANYRODS_HD inline T norm(vec3<T> a) {
  using std::sqrt;  // unqualified: lets a counting number type (bench/flop_count.cpp) supply its own
  return sqrt(dot(a, a));
}

// Q a
template <class T>
MANYRODS_HD inline vec3<T> mul(const mat3<T>& q, vec3<T> a) {
  return {q.m[0] * a.x + q.m[1] * a.y + q.m[2] * a.z,
          q.m[3] * a.x + q.m[4] * a.y + q.m[5] * a.z,
          q.m[6] * a.x + q.m[7] * a.y + q.m[8] * a.z};
}
// t + Q a, summed from t (the order in which a rigid motion p ↦ R p + c is
// applied to a point; host/core/step/root_motion.h)
template <class T>
MANYRODS_HD inline vec3<T> mul_add(const mat3<T>& q, vec3<T> a, vec3<T> t) {
  return {t.x + q.m[0] * a.x + q.m[1] * a.y + q.m[2] * a.z,
          t.y + q.m[3] * a.x + q.m[4] * a.y + q.m[5] * a.z,
          t.z + q.m[6] * a.x + q.m[7] * a.y + q.m[8] * a.z};
}
// Qᵀ a
template <class T>
MANYRODS_HD inline vec3<T> mul_transpose(const mat3<T>& q, vec3<T> a) {
  return {q.m[0] * a.x + q.m[3] * a.y + q.m[6] * a.z,
          q.m[1] * a.x + q.m[4] * a.y + q.m[7] * a.z,
          q.m[2] * a.x + q.m[5] * a.y + q.m[8] * a.z};
}
// A B
template <class T>
MANYRODS_HD inline mat3<T> mul(const mat3<T>& a, const mat3<T>& b) {
  mat3<T> c;
  MANYRODS_UNROLL
  for (int i = 0; i < 3; ++i)
    MANYRODS_UNROLL
    for (int j = 0; j < 3; ++j)
      c.m[3 * i + j] = a.m[3 * i] * b.m[j] + a.m[3 * i + 1] * b.m[3 + j] +
                       a.m[3 * i + 2] * b.m[6 + j];
  return c;
}
// A Bᵀ
template <class T>
MANYRODS_HD inline mat3<T> mul_transpose(const mat3<T>& a, const mat3<T>& b) {
  mat3<T> c;
  MANYRODS_UNROLL
  for (int i = 0; i < 3; ++i)
    MANYRODS_UNROLL
    for (int j = 0; j < 3; ++j)
      c.m[3 * i + j] = a.m[3 * i] * b.m[3 * j] + a.m[3 * i + 1] * b.m[3 * j + 1] +
                       a.m[3 * i + 2] * b.m[3 * j + 2];
  return c;
}

// Small rotations, θ ≤ ½ rad (θ² ≤ ¼), are computed by polynomials with no
// branch and no transcendental call, so that kernels vectorize; the general
// functions below use the same polynomials in that range and exact formulas
// outside it. Launchers run the small-angle kernels in SIMD loops and redo
// the rare larger rotations with the general kernels (host/core/step/launch.h).
inline constexpr double kSmallRotation2 = 0.25;             // θ² bound of the small paths
inline constexpr double kSmallRotationCos = 0.8775825618903728;  // cos ½

// a = sin θ/θ, b = (1 − cos θ)/θ² by Taylor series in t2 = θ² ≤ ¼; the first
// omitted terms (t2⁸/17!, t2⁸/18!) are below 1e-19.
template <class T>
MANYRODS_HD inline void exp_coefficients_small(T t2, T& a, T& b) {
  a = T(1) + t2 * (T(-1.0 / 6) + t2 * (T(1.0 / 120) + t2 * (T(-1.0 / 5040) + t2 * (T(1.0 / 362880) +
      t2 * (T(-1.0 / 39916800) + t2 * (T(1.0 / 6227020800.0) + t2 * T(-1.0 / 1307674368000.0)))))));
  b = T(0.5) + t2 * (T(-1.0 / 24) + t2 * (T(1.0 / 720) + t2 * (T(-1.0 / 40320) + t2 * (T(1.0 / 3628800) +
      t2 * (T(-1.0 / 479001600) + t2 * (T(1.0 / 87178291200.0) + t2 * T(-1.0 / 20922789888000.0)))))));
}

// Coefficients of exp([w]×) = I + a [w]× + b [w]×², θ = |w|.
template <class T>
MANYRODS_HD inline void exp_coefficients(T theta2, T& a, T& b) {
  if (theta2 <= T(kSmallRotation2)) {
    exp_coefficients_small(theta2, a, b);
  } else {
    using std::cos, std::sin, std::sqrt;  // unqualified: see norm
    const T theta = sqrt(theta2);
    a = sin(theta) / theta;
    b = (T(1) - cos(theta)) / theta2;
  }
}

template <class T>
MANYRODS_HD inline mat3<T> rodrigues(vec3<T> w, T a, T b) {
  const T xx = w.x * w.x, yy = w.y * w.y, zz = w.z * w.z;
  const T xy = w.x * w.y, xz = w.x * w.z, yz = w.y * w.z;
  mat3<T> r;
  r.m[0] = T(1) - b * (yy + zz);
  r.m[1] = -a * w.z + b * xy;
  r.m[2] = a * w.y + b * xz;
  r.m[3] = a * w.z + b * xy;
  r.m[4] = T(1) - b * (xx + zz);
  r.m[5] = -a * w.x + b * yz;
  r.m[6] = -a * w.y + b * xz;
  r.m[7] = a * w.x + b * yz;
  r.m[8] = T(1) - b * (xx + yy);
  return r;
}

// exp([w]×) for |w|² ≤ kSmallRotation2 (no branch).
template <class T>
MANYRODS_HD inline mat3<T> rotation_exp_small(vec3<T> w) {
  T a, b;
  exp_coefficients_small(dot(w, w), a, b);
  return rodrigues(w, a, b);
}

// exp([w]×), Rodrigues' formula, any angle.
template <class T>
MANYRODS_HD inline mat3<T> rotation_exp(vec3<T> w) {
  T a, b;
  exp_coefficients(dot(w, w), a, b);
  return rodrigues(w, a, b);
}

// The skew (axial) part of R, sin θ · u, and cos θ from the trace.
template <class T>
MANYRODS_HD inline vec3<T> rotation_axial(const mat3<T>& r, T& s, T& c) {
  const vec3<T> axial = {T(0.5) * (r.m[7] - r.m[5]), T(0.5) * (r.m[2] - r.m[6]),
                         T(0.5) * (r.m[3] - r.m[1])};
  s = norm(axial);
  c = T(0.5) * (r.m[0] + r.m[4] + r.m[8] - T(1));
  return axial;
}

// ψ = log(R) for θ ≤ ½ (c ≥ cos ½), no branch: with t = s/(1 + c) = tan(θ/2)
// ≤ 0.2554, θ = 2 atan t = 2t·P(t²), P(z) = Σ (−z)^k/(2k+1), k ≤ 14 (the
// first omitted term is < 1e-18), and θ/s = 2P/(1 + c) (no 0/0 at θ = 0).
// Outside its range the result is finite and wrong; callers check c.
template <class T>
MANYRODS_HD inline vec3<T> rotation_log_small(const mat3<T>& r, T& theta, T& s, T& c) {
  const vec3<T> axial = rotation_axial(r, s, c);
  const T inv = T(1) / (T(1) + c);
  const T t = s * inv, z = t * t;
  T p = T(1.0 / 29);
  p = T(1.0 / 27) - z * p;
  p = T(1.0 / 25) - z * p;
  p = T(1.0 / 23) - z * p;
  p = T(1.0 / 21) - z * p;
  p = T(1.0 / 19) - z * p;
  p = T(1.0 / 17) - z * p;
  p = T(1.0 / 15) - z * p;
  p = T(1.0 / 13) - z * p;
  p = T(1.0 / 11) - z * p;
  p = T(1.0 / 9) - z * p;
  p = T(1.0 / 7) - z * p;
  p = T(1.0 / 5) - z * p;
  p = T(1.0 / 3) - z * p;
  p = T(1) - z * p;
  theta = T(2) * t * p;
  return (T(2) * p * inv) * axial;
}

// ψ = log(R) as a rotation vector, R = exp([ψ]×), robust on all of SO(3).
// θ ≤ ½: rotation_log_small. Otherwise θ = atan2(sin θ, cos θ) from the skew
// and trace parts (no acos, which loses half the digits near 0 and π); near
// θ = π the skew part vanishes and the axis comes from the symmetric part
// R + Rᵀ = 2cosθ I + 2(1 − cosθ) u uᵀ. Also returns θ, sin θ, cos θ.
template <class T>
MANYRODS_HD inline vec3<T> rotation_log(const mat3<T>& r, T& theta, T& s, T& c) {
  const vec3<T> axial = rotation_axial(r, s, c);
  if (c >= T(kSmallRotationCos)) return rotation_log_small(r, theta, s, c);
  using std::atan2, std::sqrt;  // unqualified: see norm
  theta = atan2(s, c);
  if (c > T(-0.9)) return (theta / s) * axial;  // θ > ½: no 0/0
  // θ > ~2.69 rad: axis from the symmetric part, sign from the skew part.
  const T omc = T(1) - c;
  const T d0 = (r.m[0] - c) / omc, d1 = (r.m[4] - c) / omc, d2 = (r.m[8] - c) / omc;  // u_i²
  vec3<T> u;
  if (d0 >= d1 && d0 >= d2) {
    const T ux = sqrt(d0 > T(0) ? d0 : T(0));
    u = {ux, T(0.5) * (r.m[1] + r.m[3]) / (omc * ux), T(0.5) * (r.m[2] + r.m[6]) / (omc * ux)};
  } else if (d1 >= d2) {
    const T uy = sqrt(d1 > T(0) ? d1 : T(0));
    u = {T(0.5) * (r.m[1] + r.m[3]) / (omc * uy), uy, T(0.5) * (r.m[5] + r.m[7]) / (omc * uy)};
  } else {
    const T uz = sqrt(d2 > T(0) ? d2 : T(0));
    u = {T(0.5) * (r.m[2] + r.m[6]) / (omc * uz), T(0.5) * (r.m[5] + r.m[7]) / (omc * uz), uz};
  }
  const T un = norm(u);
  u = (T(1) / un) * u;
  if (dot(u, axial) < T(0)) u = -u;
  return theta * u;
}

// J_r(ψ)⁻¹ v, the inverse right Jacobian of exp on SO(3):
//   J_r⁻¹ = I + ½[ψ]× + γ(θ)[ψ]×²,  γ = 1/θ² − (1 + cos θ)/(2 θ sin θ).
// If R(t) = exp([ψ(t)]×) then Rᵀ Ṙ = [J_r(ψ) ψ̇]×, so ψ̇ = J_r⁻¹ (Rᵀ Ṙ)^∨.
// γ = Σ_{k≥1} |B_2k| θ^(2k−2)/(2k)! = 1/12 + θ²/720 + θ⁴/30240 + θ⁶/1209600
//     + θ⁸/47900160 + 691θ¹⁰/1307674368000 + θ¹²/74724249600 + O(θ¹⁴)
// (series of (1 − (θ/2)cot(θ/2))/θ²) is used for θ ≤ ½, where the first
// omitted term is < 3e-17 relative: it must run to θ¹² to reach double
// round-off at θ = ½. Above, the form 1/θ² − sin θ/(2θ(1 − cos θ)) stays
// finite up to θ = π; with c from the trace its cancellation costs about
// 2u/θ²·|v| ≤ 8u·|v|.
template <class T>
MANYRODS_HD inline T inverse_right_jacobian_gamma_small(T t2) {
  return T(1) / T(12) +
         t2 * (T(1) / T(720) +
               t2 * (T(1) / T(30240) +
                     t2 * (T(1) / T(1209600) +
                           t2 * (T(1) / T(47900160) +
                                 t2 * (T(691) / T(1307674368000.0) + t2 / T(74724249600.0))))));
}

template <class T>
MANYRODS_HD inline T inverse_right_jacobian_gamma(T theta, T s, T c) {
  const T t2 = theta * theta;
  if (t2 <= T(kSmallRotation2)) return inverse_right_jacobian_gamma_small(t2);
  return T(1) / t2 - s / (T(2) * theta * (T(1) - c));
}

// J_r⁻¹ v given γ(θ).
template <class T>
MANYRODS_HD inline vec3<T> inverse_right_jacobian_apply(vec3<T> psi, T gamma, vec3<T> v) {
  const vec3<T> pv = cross(psi, v);
  return v + T(0.5) * pv + gamma * cross(psi, pv);
}

// [a]×, the cross-product matrix: [a]× b = a × b.
template <class T>
MANYRODS_HD inline mat3<T> skew(vec3<T> a) {
  return {{T(0), -a.z, a.y, a.z, T(0), -a.x, -a.y, a.x, T(0)}};
}

template <class T>
MANYRODS_HD inline mat3<T> transpose(const mat3<T>& a) {
  return {{a.m[0], a.m[3], a.m[6], a.m[1], a.m[4], a.m[7], a.m[2], a.m[5], a.m[8]}};
}

// J_r(ψ)⁻¹ as a matrix (see inverse_right_jacobian_apply).
template <class T>
MANYRODS_HD inline mat3<T> inverse_right_jacobian(vec3<T> psi, T gamma) {
  mat3<T> j;
  const vec3<T> ex = {T(1), T(0), T(0)}, ey = {T(0), T(1), T(0)}, ez = {T(0), T(0), T(1)};
  const vec3<T> cx = inverse_right_jacobian_apply(psi, gamma, ex);
  const vec3<T> cy = inverse_right_jacobian_apply(psi, gamma, ey);
  const vec3<T> cz = inverse_right_jacobian_apply(psi, gamma, ez);
  j.m[0] = cx.x, j.m[1] = cy.x, j.m[2] = cz.x;
  j.m[3] = cx.y, j.m[4] = cy.y, j.m[5] = cz.y;
  j.m[6] = cx.z, j.m[7] = cy.z, j.m[8] = cz.z;
  return j;
}

}  // namespace manyrods
