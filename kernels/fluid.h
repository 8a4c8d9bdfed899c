// kernels/fluid.h — drag, buoyancy and wind on the nodes: the fluid's part of
// the kick as an exact per-node flow at fixed positions (include/manyrods/fluid.h
// has the force law; docs/model.md "Drag, buoyancy and wind").
//
// Node k carries the drag of the half elements on either side of it, lumped:
// its coefficients are the per-length ones times ℓ_k = (l̂_{k−1} + l̂_k)/2, its
// tangent the length-weighted mean of the two elements' d3. Over a kick of
// length h at fixed positions and frames, with w = v − U the velocity
// relative to the fluid split into w∥ = (w·t̂)t̂ and w⊥, and a the kick's
// acceleration (elastic, gravity, loads: what the kick adds, divided by h)
// plus buoyancy, the node moves by
//   ẇ⊥ = −λ⊥ w⊥ + a⊥,   ẇ∥ = −λ∥ w∥ + a∥,
//   λ⊥ = m⁻¹(c⊥ℓ + ½ρ C⊥ d ℓ |w⊥|),  λ∥ = m⁻¹(c∥ℓ + ½ρ C∥ π d ℓ |w∥|),
//   a_buoyancy = −m⁻¹ ρ_f A ℓ g,
// with a and the quadratic rates frozen at the start of the kick. The kick
// is its exact solution (an exponential integrator),
//   w⁺ = e^{−λh} w + φ(λ, h) a,   φ = (1 − e^{−λh})/λ  (→ h as λ → 0):
// the plain kick w + h a when λh → 0, a decay for any λh (no limit on the
// step, however large the drag), and the terminal velocity U + a/λ as its
// exact fixed point. For constant λ the map is time-reversible (its inverse
// is the map with −h), so Position Verlet stays symmetric and second order
// with linear drag; the frozen quadratic rate makes that part first order.
// The host saves v before the kick (fluid_save) and applies the update after
// the kick and the implicit solve (fluid_node), recovering h a = v_after −
// v_before, exactly the increment they rounded (for damped and stiff rods a
// then includes the solve's viscous and stiff forces: after the solve, so
// that a stiff rod's unresolved modes, which the solve removes, are never
// scaled by the decay). Held nodes (m⁻¹ = 0) keep their velocity.
//
// The fluid velocity U(x, t) = Ū(t) + Σ_m a_m sin(k_m·x + c_m(t)): the host
// gives Ū and each mode's k, a and phase c_m(t) = −k_m·X(t) + ω_m t + φ_m,
// X(t) = ∫₀ᵗ Ū dt, for the time of the kick; with turbulence it sums the
// field at the nodes first (fluid_mean, then fluid_mode once per mode).
//
// reads: node_x, node_v, elem_Q (elements k−1, k), node_inv_mass, the fluid
// arrays  writes: node_v (node k), the saved velocity
#pragma once

#include <cstdint>
#include <cstring>

#include "kernels/views.h"

namespace manyrods {

// Which parts of the fluid a stage includes (compile-time: a batch compiles
// only the ones its rods and fluid use).
struct FluidTerms {
  bool linear = false;      // c⊥, c∥
  bool quadratic = false;   // C⊥, C∥ with ρ_f
  bool buoyancy = false;    // ρ_f A g
  bool turbulence = false;  // the random Fourier modes
};

// Per node, lumped (ℓ_k included): the linear and quadratic coefficients
// (N·s/m and kg/m), the displaced fluid mass (kg), and the half lengths of
// the elements on either side (m; 0 on a rod's outer side and for ghosts).
template <class T>
struct FluidView {
  const T *cn, *ct, *qn, *qt, *buoyancy, *half_left, *half_right;
  T* saved[3];      // v before the kick
  T* wind[3];       // U at the nodes, with the turbulent part (fluid_mean, fluid_mode)
  vec3<T> mean;     // Ū at the kick's time, m/s
  vec3<T> gravity;  // g (0 when the step has no gravity), m/s²
};

// sin x without a library call, so that the modes' loop vectorizes:
// reduced to [−π, π] by a multiple of 2π, folded to [−π/2, π/2]
// (sin(π − r) = sin r), then the odd Taylor polynomial to r¹⁹ (truncation
// |r|²¹/21! < 3e-16 there). Agrees with std::sin to a few ulp of 1 for
// |x| up to ~1e6 (the reduction's rounding grows with |x|). Fluid::velocity_at
// evaluates the field with the same function.
template <class T>
MANYRODS_HD inline T fluid_sin(T x) {
  using std::rint;
  const T two_pi = T(6.283185307179586477), pi = T(3.141592653589793238), half_pi = T(1.570796326794896619);
  T r = x - two_pi * rint(x * T(0.15915494309189533577));
  r = r > half_pi ? pi - r : r;
  r = r < -half_pi ? -pi - r : r;
  const T r2 = r * r;
  return r * (T(1) - r2 * (T(1.0 / 6) - r2 * (T(1.0 / 120) - r2 * (T(1.0 / 5040) - r2 * (T(1.0 / 362880) -
         r2 * (T(1.0 / 39916800) - r2 * (T(1.0 / 6227020800) - r2 * (T(1.0 / 1307674368000) -
         r2 * (T(1.0 / 355687428096000) - r2 * T(1.0 / 121645100408832000))))))))));
}

// One turbulent mode added to the fluid velocity at node k (the host
// launches this once per mode, so that each launch is a plain vectorizable
// loop over the nodes): u += a sin(k·x + c), p = the mode's 7 values.
template <class T>
MANYRODS_HD inline void fluid_mode(int k, const T* p, const FluidView<T>& f, const StateView<T>& s) {
  const T w = fluid_sin(p[0] * s.node_x[0][k] + p[1] * s.node_x[1][k] + p[2] * s.node_x[2][k] + p[6]);
  for (int d = 0; d < 3; ++d) f.wind[d][k] += w * p[3 + d];
}
template <class T>
MANYRODS_HD inline void fluid_mean(int k, const FluidView<T>& f) {
  f.wind[0][k] = f.mean.x;
  f.wind[1][k] = f.mean.y;
  f.wind[2][k] = f.mean.z;
}

// e^{−z} for z ≥ 0 without a library call (so that the node loop
// vectorizes): z = k ln 2 + r, |r| ≤ ½ ln 2, e^{−r} by its Taylor series
// (to r¹² in double, truncation < 2e-16; to r⁷ in float, < 4e-8), times
// 2^{−k} built in the exponent bits (adding 1.5·2^52 rounds z/ln 2 to the
// integer k in the low mantissa bits: integer lane operations only). z is capped where e^{−z} is below
// the smallest normal number; returns 0 beyond.
MANYRODS_HD inline double exp_neg(double z) {
  const double zc = z < 700.0 ? z : 700.0;
  const double shifter = 6755399441055744.0;  // 1.5·2^52: adding it rounds to an integer in the low bits
  const double kd = zc * 1.4426950408889634 + shifter;
  const double k = kd - shifter;
  const double r = (zc - k * 0.6931471803691238) - k * 1.9082149292705877e-10;  // ln 2, hi + lo
  double p = 1.0 / 479001600.0;  // 1/12!
  const double c[12] = {1.0 / 39916800.0, 1.0 / 3628800.0, 1.0 / 362880.0, 1.0 / 40320.0, 1.0 / 5040.0, 1.0 / 720.0,
                        1.0 / 120.0,      1.0 / 24.0,      1.0 / 6.0,     0.5,           1.0,          1.0};
  for (int i = 0; i < 12; ++i) p = p * (-r) + c[i];  // Σ (−r)^j / j!
  std::uint64_t kb;
  std::memcpy(&kb, &kd, 8);
  const std::uint64_t bits = (std::uint64_t(1023) - (kb & 0x7ffull)) << 52;  // 2^{−k}, k ≤ 1010
  double scale;
  std::memcpy(&scale, &bits, 8);
  return z < 700.0 ? p * scale : 0.0;
}
MANYRODS_HD inline float exp_neg(float z) {
  const float zc = z < 80.f ? z : 80.f;
  const float shifter = 12582912.f;  // 1.5·2^23
  const float kd = zc * 1.44269504f + shifter;
  const float k = kd - shifter;
  const float r = (zc - k * 0.693145752f) - k * 1.42860677e-6f;
  float p = 1.f / 5040.f;
  const float c[7] = {1.f / 720.f, 1.f / 120.f, 1.f / 24.f, 1.f / 6.f, 0.5f, 1.f, 1.f};
  for (int i = 0; i < 7; ++i) p = p * (-r) + c[i];
  std::uint32_t kb;
  std::memcpy(&kb, &kd, 4);
  const std::uint32_t bits = (std::uint32_t(127) - (kb & 0x7fu)) << 23;  // 2^{−k}, k ≤ 116
  float scale;
  std::memcpy(&scale, &bits, 4);
  return z < 80.f ? p * scale : 0.f;
}

// exp(−λτ) and φ(λ, τ) = (1 − e^{−λτ})/λ; for λτ < 1e-3 φ by its series
// (truncation (λτ)⁴/120 < 1e-14 relative), so that no expm1 is needed.
template <class T>
MANYRODS_HD inline void decay(T lambda, T tau, T& e, T& phi) {
  const T z = lambda * tau;
  e = exp_neg(z);
  const T series = tau * (T(1) - z * (T(0.5) - z * (T(1.0 / 6.0) - z * T(1.0 / 24.0))));
  phi = z > T(1e-3) ? (T(1) - e) / lambda : series;
}

template <class T>
MANYRODS_HD inline void fluid_save(int k, const FluidView<T>& f, const StateView<T>& s) {
  for (int d = 0; d < 3; ++d) f.saved[d][k] = s.node_v[d][k];
}

template <FluidTerms kF, class T>
MANYRODS_HD inline void fluid_node(int k, T h, const FluidView<T>& f, const ModelView<T>& m, const StateView<T>& s) {
  const T im = m.node_inv_mass[k];
  const vec3<T> vk = load3(s.node_v, k);  // after the kick
  const vec3<T> v{f.saved[0][k], f.saved[1][k], f.saved[2][k]};
  vec3<T> a = (T(1) / h) * (vk - v);
  if constexpr (kF.buoyancy) a = a + (-im * f.buoyancy[k]) * f.gravity;
  const vec3<T> u = kF.turbulence ? vec3<T>{f.wind[0][k], f.wind[1][k], f.wind[2][k]} : f.mean;
  // tangent: the half elements' d3, weighted by length
  const vec3<T> d3l{s.elem_Q[6][k - 1], s.elem_Q[7][k - 1], s.elem_Q[8][k - 1]};
  const vec3<T> d3r{s.elem_Q[6][k], s.elem_Q[7][k], s.elem_Q[8][k]};
  vec3<T> t = f.half_left[k] * d3l + f.half_right[k] * d3r;
  const T tn = norm(t);
  t = tn > T(0) ? (T(1) / tn) * t : vec3<T>{T(0), T(0), T(1)};
  const vec3<T> w = v - u;
  const T wt = dot(w, t), at = dot(a, t);
  const vec3<T> wn = w - wt * t, an = a - at * t;
  T ln = T(0), lt = T(0);
  if constexpr (kF.linear) {
    ln = f.cn[k];
    lt = f.ct[k];
  }
  if constexpr (kF.quadratic) {
    using std::abs;
    ln += f.qn[k] * norm(wn);
    lt += f.qt[k] * abs(wt);
  }
  ln *= im;
  lt *= im;
  T en, pn, et, pt;
  decay(ln, h, en, pn);
  decay(lt, h, et, pt);
  const vec3<T> v1 = u + en * wn + pn * an + (et * wt + pt * at) * t;
  const bool held = im == T(0);
  store3(s.node_v, k, held ? vk : v1);
}

}  // namespace manyrods
