// kernels/integrate.h — the two half-flows of the explicit symplectic
// splitting (Position Verlet, DESIGN.md §3):
//   kinematic (drift), length h:  x ← x + h v,   Q ← exp(−[h ω]×) Q
//   dynamic (kick), length h:     v ← v + h m⁻¹ (F + m g + f_ext)
//                                 ω ← ω + h J⁻¹ (C + Q c_ext + (Jω̄) × ω̄)  (midpoint ω̄)
// The exponential is exact for constant ω and keeps Q orthonormal to
// round-off. Clamped and ghost entries have m⁻¹ = J⁻¹ = 0, so they never move
// (the clamp frame lives in a ghost element with ω = 0: exp(0) = I exactly).
//
// reads/writes: node_x, node_v (node k), elem_Q, elem_w (element k)
// reads: node_mass, node_inv_mass, elem_inv_inertia, loads, scratch
#pragma once

#include "kernels/internal_forces.h"

namespace manyrods {

template <class T>
MANYRODS_HD inline void kinematic_node(int k, T h, const StateView<T>& s) {
  for (int d = 0; d < 3; ++d) s.node_x[d][k] += h * s.node_v[d][k];
}

template <class T>
MANYRODS_HD inline void kinematic_element(int k, T h, const StateView<T>& s) {
  const vec3<T> w = load3(s.elem_w, k);
  const mat3<T> r = rotation_exp((-h) * w);
  store_frame(s.elem_Q, k, mul(r, load_frame(s.elem_Q, k)));
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

template <Terms kT, class T>
MANYRODS_HD inline void dynamic_element(int k, T h, const ModelView<T>& m, const LoadsView<T>& l,
                                        const ConstScratchView<T>& sc, const StateView<T>& s) {
  const ConstStateView<T> cs = as_const(s);
  vec3<T> c = element_couple(k, sc);
  if constexpr (kT.loads) c = c + element_external_couple<kT>(k, l, load_frame(cs.elem_Q, k));
  // Implicit midpoint for the rigid-body term: J(ω⁺ − ω)/h = C + (Jω̄) × ω̄,
  // ω̄ = (ω + ω⁺)/2. Since ω̄·((Jω̄) × ω̄) = 0 the rotational kinetic energy
  // changes by exactly h ω̄·C: the term does no work, as in the continuum (an
  // explicit (Jω) × ω would add O(h²) energy per step, an O(h) drift).
  // Fixed-point iterations contract by ~h|ω| per sweep; three make the
  // remaining error O((h|ω|)⁴).
  const vec3<T> inertia = load3(m.elem_inertia, k), inv = load3(m.elem_inv_inertia, k);
  const vec3<T> w0 = load3(cs.elem_w, k);
  vec3<T> w1 = w0 + h * hadamard(inv, c + euler_couple(inertia, w0));
  for (int it = 0; it < 3; ++it) {
    const vec3<T> wb = T(0.5) * (w0 + w1);
    w1 = w0 + h * hadamard(inv, c + euler_couple(inertia, wb));
  }
  store3(s.elem_w, k, w1);
}

}  // namespace manyrods
