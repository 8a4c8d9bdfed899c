// kernels/views.h — what crosses the kernel boundary: plain pointers into the
// structure-of-arrays storage of a RodBatch (include/manyrods/batch.h), no
// containers. The members are generated from the field list
// (include/manyrods/fields.h), so storage and views cannot disagree. Every array is indexed by the same slot index k (see batch.h):
// node k sits between element k−1 and element k, and Voronoi point k is the
// joint between element k−1 and element k (it sits on node k). Index k−1 and
// k+1 are valid for every k in [0, slots): the storage has guard entries.
//
// reads: nothing  writes: nothing
#pragma once

#include <type_traits>

#include "kernels/math.h"
#include "manyrods/fields.h"

namespace manyrods {

// One field of include/manyrods/fields.h as a view member: a pointer, or one
// pointer per component.
template <class P, int N>
using FieldView = std::conditional_t<N == 1, P, P[N]>;

#define MANYRODS_VIEW_MEMBER(name, n, fill, float_only, doc) FieldView<T*, n> name;
#define MANYRODS_CONST_VIEW_MEMBER(name, n, fill, float_only, doc) FieldView<const T*, n> name;

// Constant during a run (MANYRODS_MODEL_FIELDS: shapes and units).
template <class T>
struct ModelView {
  MANYRODS_MODEL_FIELDS(MANYRODS_CONST_VIEW_MEMBER)
  vec3<T> gravity;  // m/s²
};

// The state: positions, velocities, frames, angular velocities
// (MANYRODS_STATE_FIELDS; node_xc is nullptr for double batches).
template <class T>
struct StateView {
  MANYRODS_STATE_FIELDS(MANYRODS_VIEW_MEMBER)
};
template <class T>
struct ConstStateView {
  MANYRODS_STATE_FIELDS(MANYRODS_CONST_VIEW_MEMBER)
};

// Derived each step from the state; each array names the kernel that writes
// it (MANYRODS_SCRATCH_FIELDS).
template <class T>
struct ScratchView {
  MANYRODS_SCRATCH_FIELDS(MANYRODS_VIEW_MEMBER)
};
template <class T>
struct ConstScratchView {
  MANYRODS_SCRATCH_FIELDS(MANYRODS_CONST_VIEW_MEMBER)
};

// External loads the user sets between steps (lab frame, MANYRODS_LOADS_FIELDS).
template <class T>
struct LoadsView {
  MANYRODS_LOADS_FIELDS(MANYRODS_CONST_VIEW_MEMBER)
};

#undef MANYRODS_VIEW_MEMBER
#undef MANYRODS_CONST_VIEW_MEMBER

// The elimination buffer of one implicit solve (kernels/viscous_implicit.h),
// indexed by cell.
template <class T>
struct ImplicitScratchView {
  T* G[36];  // [36][cells] Â_c⁻¹ U_c, row-major 6×6 (the lane solve: L⁻¹U_c at ui; with kept factors Â_c⁻¹ U_c after it)
  T* g[6];   // [6][cells]  Â_c⁻¹ ŷ_c (the lane solve: L⁻¹ŷ_c, then u_c)
  T* L[21];  // [21][cells] the lane solve: Â_c's Cholesky factor (lower, 1/L_ii on the diagonal)
};

namespace views_detail {
template <class T>
MANYRODS_HD inline void copy_view(const T*& dst, T* src) {
  dst = src;
}
template <class T, int N>
MANYRODS_HD inline void copy_view(const T* (&dst)[N], T* const (&src)[N]) {
  for (int i = 0; i < N; ++i) dst[i] = src[i];
}
}  // namespace views_detail

#define MANYRODS_AS_CONST(name, n, fill, float_only, doc) views_detail::copy_view(c.name, s.name);
template <class T>
MANYRODS_HD inline ConstStateView<T> as_const(const StateView<T>& s) {
  ConstStateView<T> c{};
  MANYRODS_STATE_FIELDS(MANYRODS_AS_CONST)
  return c;
}
template <class T>
MANYRODS_HD inline ConstScratchView<T> as_const(const ScratchView<T>& s) {
  ConstScratchView<T> c{};
  MANYRODS_SCRATCH_FIELDS(MANYRODS_AS_CONST)
  return c;
}
#undef MANYRODS_AS_CONST

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
