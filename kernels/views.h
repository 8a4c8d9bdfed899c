// kernels/views.h — what crosses the kernel boundary: plain pointers into the
// structure-of-arrays storage of a RodBatch (include/manyrods/batch.h), no
// containers. Every array is indexed by the same slot index k (see batch.h):
// node k sits between element k−1 and element k, and Voronoi point k is the
// joint between element k−1 and element k (it sits on node k). Index k−1 and
// k+1 are valid for every k in [0, slots): the storage has guard entries.
//
// reads: nothing  writes: nothing
#pragma once

#include "kernels/math.h"

namespace manyrods {

// Constant during a run. Units SI.
template <class T>
struct ModelView {
  const T* node_mass;            // [slots] kg, lumped
  const T* node_inv_mass;        // [slots] 1/kg, 0 for clamped and ghost nodes
  const T* elem_rest_length;     // [slots] m, l̂
  const T* elem_stiffness[3];    // [3][slots] N: κ1·G·A, κ2·G·A, E·A (C_F)
  const T* elem_rest_strain[3];  // [3][slots] 1: V0 (e3 for a straight rod)
  const T* elem_tau[3];          // [3][slots] s: τS, τS, τE (V_F = C_F·diag τ)
  const T* elem_inertia[3];      // [3][slots] kg·m: ρ·l̂·(I1, I2, I3)
  const T* elem_inv_inertia[3];  // [3][slots] 0 for ghost elements
  const T* vor_rest_length;      // [slots] m, D̂
  const T* vor_stiffness[3];     // [3][slots] N·m²: E·I1, E·I2, G·J_T (C_M)
  const T* vor_rest_curvature[3];  // [3][slots] 1/m: U0
  const T* vor_tau[3];           // [3][slots] s: τE, τE, τS (V_M = C_M·diag τ)
  vec3<T> gravity;               // m/s²
};

// The state: positions, velocities, frames, angular velocities.
template <class T>
struct StateView {
  T* node_x[3];   // [3][slots] m
  T* node_v[3];   // [3][slots] m/s
  T* elem_Q[9];   // [9][slots] frame, row-major, rows = directors d1, d2, d3
  T* elem_w[3];   // [3][slots] rad/s, material components
  // float only (nullptr for double): the round-off of node_x carried between
  // drifts (compensated summation, kernels/integrate.h kinematic_node)
  T* node_xc[3];
};

template <class T>
struct ConstStateView {
  const T* node_x[3];
  const T* node_v[3];
  const T* elem_Q[9];
  const T* elem_w[3];
};

// Derived each step from the state; each array names the kernel that writes it.
template <class T>
struct ScratchView {
  T* elem_force[3];   // [3][slots] N, Qᵀn (lab)          — element_stage
  T* elem_couple[3];  // [3][slots] N·m, (Q e) × n         — element_stage
  T* vor_moment[3];   // [3][slots] N·m, m̃ = J-corrected m — voronoi_stage
  T* vor_kxm[3];      // [3][slots] N·m, D̂ κ × m           — voronoi_stage
};

template <class T>
struct ConstScratchView {
  const T* elem_force[3];
  const T* elem_couple[3];
  const T* vor_moment[3];
  const T* vor_kxm[3];
};

// External loads the user sets between steps (lab frame).
template <class T>
struct LoadsView {
  const T* node_force[3];   // [3][slots] N
  const T* elem_couple[3];  // [3][slots] N·m
};

template <class T>
MANYRODS_HD inline ConstStateView<T> as_const(const StateView<T>& s) {
  return {{s.node_x[0], s.node_x[1], s.node_x[2]},
          {s.node_v[0], s.node_v[1], s.node_v[2]},
          {s.elem_Q[0], s.elem_Q[1], s.elem_Q[2], s.elem_Q[3], s.elem_Q[4], s.elem_Q[5],
           s.elem_Q[6], s.elem_Q[7], s.elem_Q[8]},
          {s.elem_w[0], s.elem_w[1], s.elem_w[2]}};
}
template <class T>
MANYRODS_HD inline ConstScratchView<T> as_const(const ScratchView<T>& s) {
  return {{s.elem_force[0], s.elem_force[1], s.elem_force[2]},
          {s.elem_couple[0], s.elem_couple[1], s.elem_couple[2]},
          {s.vor_moment[0], s.vor_moment[1], s.vor_moment[2]},
          {s.vor_kxm[0], s.vor_kxm[1], s.vor_kxm[2]}};
}

template <class T>
MANYRODS_HD inline vec3<T> load3(const T* const a[3], int k) {
  return {a[0][k], a[1][k], a[2][k]};
}
template <class T>
MANYRODS_HD inline void store3(T* const a[3], int k, vec3<T> v) {
  a[0][k] = v.x;
  a[1][k] = v.y;
  a[2][k] = v.z;
}
template <class T>
MANYRODS_HD inline mat3<T> load_frame(const T* const q[9], int k) {
  mat3<T> r;
  MANYRODS_UNROLL
  for (int i = 0; i < 9; ++i) r.m[i] = q[i][k];
  return r;
}
template <class T>
MANYRODS_HD inline void store_frame(T* const q[9], int k, const mat3<T>& r) {
  MANYRODS_UNROLL
  for (int i = 0; i < 9; ++i) q[i][k] = r.m[i];
}

}  // namespace manyrods
