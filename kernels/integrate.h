// kernels/integrate.h — the two half-flows of the explicit symplectic
// splitting (Position Verlet, docs/model.md "Position Verlet"):
//   kinematic (drift), length h:  x ← x + h v,   Q ← exp(−[h ω]×) Q
//   dynamic (kick), length h:     v ← v + h m⁻¹ (F + m g + f_ext)
//                                 ω ← ω + h J⁻¹ (C + Q c_ext + (Jω̄) × ω̄)  (midpoint ω̄)
// The exponential is exact for constant ω and keeps Q orthonormal to
// round-off. Clamped and ghost entries have m⁻¹ = J⁻¹ = 0, so the kicks never
// move them (the clamp frame lives in a ghost element with ω = 0: exp(0) = I
// exactly); a driven root's node 0 and clamp frame carry the velocities the
// host gives them (host/core/step/root_motion.h apply_root_motion) and drift with them.
//
// reads/writes: node_x, node_v (node k), elem_Q, elem_w (element k)
// reads: node_mass, node_inv_mass, elem_inv_inertia, loads, scratch
#pragma once

#include "kernels/internal_forces.h"

namespace manyrods {

// In float, x += h v loses the part of h v below half an ulp of x: a hair
// tip at 0.2 m moving at 1 m/s with h = 2e-8 s advances by 2e-8 m, about one
// ulp (1.5e-8 m), so plain float positions drift or stall, an error that
// grows with the number of steps (bench/RESULTS.md "Design history (moved
// from the kernel headers)"). Float batches therefore keep the lost low part
// in node_xc and add it back on the next drift (Kahan's compensated
// summation): the positions then carry about twice float's precision in the
// sums, at one more array per coordinate.
template <class T>
MANYRODS_HD inline void kinematic_node(int k, T h, const StateView<T>& s) {
  if constexpr (sizeof(T) == 4) {
    MANYRODS_UNROLL
    for (int d = 0; d < 3; ++d) {
      const T x = s.node_x[d][k];
      const T y = h * s.node_v[d][k] - s.node_xc[d][k];
      const T t = x + y;
      s.node_xc[d][k] = (t - x) - y;
      s.node_x[d][k] = t;
    }
  } else {
    MANYRODS_UNROLL
    for (int d = 0; d < 3; ++d) s.node_x[d][k] += h * s.node_v[d][k];
  }
}

// Float frames drift away from orthonormal: each drift's product R Q rounds
// at ~6e-8, systematically, and nothing pulls Q back; with the stiff shear
// and stretch reading σ = Q e/l̂ − e3 the defect is a spurious strain (how
// large it grew: bench/RESULTS.md "Design history (moved from the kernel
// headers)"). One Newton–Schulz step, Q ← Q + ½(I − QQᵀ)Q,
// halves the digits of the defect (quadratic convergence to the orthonormal
// polar factor); the host applies it to float batches every
// kFloatFrameRenormalization steps (host/core/step/stages.h), so the defect stays at
// ~1e-6, for ~6 extra FLOP per element-step. Fixed frames (clamp, ghosts:
// zero inverse inertia) are left as they are.
inline constexpr int kFloatFrameRenormalization = 16;

template <class T>
MANYRODS_HD inline void orthonormalize_element(int k, const ModelView<T>& m, const StateView<T>& s) {
  const mat3<T> q = load_frame(s.elem_Q, k);
  T c[9];  // (I − QQᵀ)/2, symmetric
  MANYRODS_UNROLL
  for (int i = 0; i < 3; ++i)
    MANYRODS_UNROLL
    for (int j = 0; j < 3; ++j)
      c[3 * i + j] = T(0.5) * ((i == j ? T(1) : T(0)) -
                               (q.m[3 * i] * q.m[3 * j] + q.m[3 * i + 1] * q.m[3 * j + 1] + q.m[3 * i + 2] * q.m[3 * j + 2]));
  const bool fixed = m.elem_inv_inertia[0][k] == T(0);
  MANYRODS_UNROLL
  for (int i = 0; i < 3; ++i)
    MANYRODS_UNROLL
    for (int j = 0; j < 3; ++j) {
      const T v = q.m[3 * i + j] + c[3 * i] * q.m[j] + c[3 * i + 1] * q.m[3 + j] + c[3 * i + 2] * q.m[6 + j];
      s.elem_Q[3 * i + j][k] = fixed ? q.m[3 * i + j] : v;
    }
}

template <class T>
MANYRODS_HD inline void kinematic_element(int k, T h, const StateView<T>& s) {
  const vec3<T> w = load3(s.elem_w, k);
  const mat3<T> r = rotation_exp((-h) * w);
  store_frame(s.elem_Q, k, mul(r, load_frame(s.elem_Q, k)));
}

// Whether element k turns by more than ½ rad in a drift of length h (the
// bound of the branch-free path below).
template <class T>
MANYRODS_HD inline bool element_turn_is_large(int k, T h, const StateView<T>& s) {
  const vec3<T> w = (-h) * load3(s.elem_w, k);
  return !(dot(w, w) <= T(kSmallRotation2));
}

// The branch-free drift for |hω| ≤ ½ rad. For a larger turn it leaves Q
// unchanged (a select, so the loop still vectorizes) and returns true: the
// launcher then redoes element k with kinematic_element. kSelect = false:
// the caller knows no turn is large (element_turn_is_large), and Q is
// stored without the select (the same values).
template <bool kSelect = true, class T>
MANYRODS_HD inline bool kinematic_element_small(int k, T h, const StateView<T>& s) {
  const vec3<T> w = (-h) * load3(s.elem_w, k);
  const mat3<T> q = load_frame(s.elem_Q, k);
  const mat3<T> n = mul(rotation_exp_small(w), q);
  if constexpr (!kSelect) {
    store_frame(s.elem_Q, k, n);
    return false;
  } else {
    const bool big = element_turn_is_large(k, h, s);
    MANYRODS_UNROLL
    for (int i = 0; i < 9; ++i) s.elem_Q[i][k] = big ? q.m[i] : n.m[i];
    return big;
  }
}

template <Terms kT, class T>
MANYRODS_HD inline vec3<T> node_external_force(int k, const ModelView<T>& m, const LoadsView<T>& l) {
  vec3<T> f = {T(0), T(0), T(0)};
  if constexpr (kT.gravity) f = m.node_mass[k] * m.gravity;
  if constexpr (kT.loads) f = f + load3(l.node_force, k);
  return f;
}

template <Terms kT, class T>
MANYRODS_HD inline void dynamic_node(int k, T h, const ModelView<T>& m, const LoadsView<T>& l,
                                     const ConstScratchView<T>& sc, const StateView<T>& s) {
  const vec3<T> f = node_force(k, sc) + node_external_force<kT>(k, m, l);
  const T hm = h * m.node_inv_mass[k];
  s.node_v[0][k] += hm * f.x;
  s.node_v[1][k] += hm * f.y;
  s.node_v[2][k] += hm * f.z;
}

template <Terms kT, class T>
MANYRODS_HD inline vec3<T> element_external_couple(int k, const LoadsView<T>& l,
                                                   const mat3<T>& Q) {
  if constexpr (kT.loads) return mul(Q, load3(l.elem_couple, k));
  return {T(0), T(0), T(0)};
}

// The rotational part of a kick of length h with the couple c frozen:
// J ω̇ = c + (Jω) × ω by one implicit-midpoint step,
// J(ω⁺ − ω)/h = c + (Jω̄) × ω̄, ω̄ = (ω + ω⁺)/2. Since ω̄·((Jω̄) × ω̄) = 0 the
// rotational kinetic energy changes by exactly h ω̄·c: the term does no work,
// as in the continuum (an explicit (Jω) × ω would add O(h²) energy per step,
// an O(h) drift). Fixed-point iterations contract by ~h|ω| per sweep; three
// make the remaining error O((h|ω|)⁴) relative to the O(h²) increment.
template <class T>
MANYRODS_HD inline vec3<T> euler_midpoint(vec3<T> w0, vec3<T> c, vec3<T> inertia, vec3<T> inv, T h) {
  vec3<T> w1 = w0 + h * hadamard(inv, c + euler_couple(inertia, w0));
  MANYRODS_UNROLL
  for (int it = 0; it < 3; ++it) {
    const vec3<T> wb = T(0.5) * (w0 + w1);
    w1 = w0 + h * hadamard(inv, c + euler_couple(inertia, wb));
  }
  return w1;
}

// kEulerOrder selects how the rigid-body term is integrated inside the kick:
//   2: one implicit-midpoint step (second order for the sub-flow; enough
//      for Position Verlet);
//   4: the symmetric triple-jump composition of three midpoint steps,
//      γ₁h, γ₂h, γ₁h with γ₁ = 1/(2 − 2^{1/3}), γ₂ = 1 − 2γ₁ (Yoshida 1990),
//      fourth order for the sub-flow, so that a fourth-order composition of
//      drifts and kicks (PEFRL) keeps its order when Jω ∦ ω. Each midpoint
//      step does no work, so neither does the composition.
//
// kStiffRod: for stiff rods (RodSpec::stiff_implicit, kernels/viscous_implicit.h)
// the kick is followed by the implicit solve, and ω after the explicit kick
// is not a physical velocity: the stiff couples on the tiny rotary inertia
// make it 1e3–1e5 × the final one (h|ω| ≫ 1), which the solve then removes.
// The midpoint iteration above diverges there (it contracts only for
// h|ω| < 1) and its nonlinear (Jω)×ω of that ω is not removed by a linear
// solve (a swinging hair blew up with it). So stiff rods take
// the rigid-body term explicitly at the start-of-kick ω (the physical one,
// out of the last solve): first order, like the rest of the stiff scheme,
// and negligible for thin rods, whose (Jω)×ω is tiny.
template <Terms kT, int kEulerOrder = 2, bool kStiffRod = false, class T>
MANYRODS_HD inline void dynamic_element(int k, T h, const ModelView<T>& m, const LoadsView<T>& l,
                                        const ConstScratchView<T>& sc, const StateView<T>& s) {
  static_assert(kEulerOrder == 2 || kEulerOrder == 4, "kEulerOrder: 2 or 4");
  const ConstStateView<T> cs = as_const(s);
  vec3<T> c = element_couple(k, sc);
  if constexpr (kT.loads) c = c + element_external_couple<kT>(k, l, load_frame(cs.elem_Q, k));
  const vec3<T> inertia = load3(m.elem_inertia, k), inv = load3(m.elem_inv_inertia, k);
  vec3<T> w = load3(cs.elem_w, k);
  if constexpr (kStiffRod) {
    w = w + h * hadamard(inv, c + euler_couple(inertia, w));
  } else if constexpr (kEulerOrder == 2) {
    w = euler_midpoint(w, c, inertia, inv, h);
  } else {
    const T g1 = T(1.3512071919596576340), g2 = T(-1.7024143839193152681);  // 1/(2 − ∛2), 1 − 2γ₁
    w = euler_midpoint(w, c, inertia, inv, g1 * h);
    w = euler_midpoint(w, c, inertia, inv, g2 * h);
    w = euler_midpoint(w, c, inertia, inv, g1 * h);
  }
  store3(s.elem_w, k, w);
}

}  // namespace manyrods
