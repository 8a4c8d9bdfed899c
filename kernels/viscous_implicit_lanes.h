// kernels/viscous_implicit_lanes.h — the backward-Euler Kelvin–Voigt update of
// kernels/viscous_implicit.h for W rods at once, one rod per SIMD lane.
//
// Same system, same elimination as viscous_implicit_rod (read its header for
// the equations): per rod (M + hD) u⁺ = M u⁻, D block tridiagonal with 6×6
// blocks over the cells c = 0 … cells−1 (cell c = node c and element c),
//   Â_0 = A_0,  Â_c = A_c − U_{c−1}ᵀ G_{c−1},  G_c = Â_c⁻¹ U_c,
//   ŷ_c = y_c − U_{c−1}ᵀ g_{c−1},  g_c = Â_c⁻¹ ŷ_c,
//   u_c = g_c − G_c u_{c+1}   (backwards from the last cell),
// Â_c = L Lᵀ by Cholesky. The W rods must have the same cell count; lane l
// reads and writes rod l's cells at slots first[l] + c. Every value below is
// an array over the lanes ([…][W]) and every stage is one `omp simd` loop
// over the lanes whose body is the scalar per-rod arithmetic (fully unrolled:
// lane-wide vectors in registers, no loop over matrix indices at run time).
//
// Where it does less arithmetic than the scalar kernel (exact in exact
// arithmetic; the results agree to round-off, tests/test_implicit_lanes.cpp):
//   * A is symmetric: only its lower triangle (21 entries) is assembled,
//     eliminated and factored; U_{c−1}ᵀG_{c−1} = U_{c−1}ᵀÂ_{c−1}⁻¹U_{c−1} is
//     symmetric too (lower triangle only).
//   * U_c (rows: cell c's v, ω; columns: cell c+1's v, ω) has a zero block:
//     v_c does not couple to ω_{c+1} (element k's strain involves ω_k only,
//     Voronoi k+1 involves no v). Its 27 other entries are stored, the zero
//     block is skipped in UᵀG, Uᵀg and in the forward solves for G's columns
//     3–5 (whose first three entries stay zero).
//   * The element blocks share one product. With b1 = −Q/l̂, b3 = Q/l̂,
//     b2 = [a]×/l̂ (a = Q e), ŵ = h C_F τ / l̂ (= h W / l̂²) and P = diag(ŵ) Q:
//       b3ᵀWb3 h = b1ᵀWb1 h = −b1ᵀWb3 h = QᵀP = N   (A_vv, −U_vv, next A_vv)
//       b2ᵀWb1 h = [a]× P = X,  b2ᵀWb3 h = −X         (A_ωv, U_ωv)
//       b2ᵀWb2 h = [a]×ᵀ diag(ŵ) [a]×                (A_ωω, 6 products)
//   * The joint blocks: with c1 = −J/D̂, c2 = J Rᵀ/D̂ (J = J_r(ψ)⁻¹) and
//     v̂ = h C_M τ / D̂, S = Jᵀ diag(v̂) J:
//       c1ᵀWc1 h = S,  c1ᵀWc2 h = −S Rᵀ,  c2ᵀWc2 h = R S Rᵀ.
//     J = (1 − γ|ψ|²) I + ½[ψ]× + γ ψψᵀ directly (kernels/math.h's
//     J_r⁻¹ = I + ½[ψ]× + γ[ψ]×², [ψ]×² = ψψᵀ − |ψ|² I).
//   * Cholesky keeps the inverse of its diagonal: 6 divisions per cell, the
//     solves multiply.
//   * The last cell's element (tip ghost) and its joint k+1 (the next rod's
//     root ghost, or padding) have zero stiffness (include/manyrods/batch.h:
//     ghosts have zero stiffness), so they add exactly nothing: the last cell
//     is its carried block plus the mass, and has no U (nothing follows).
//
// Joints that turn by more than ½ rad: the assembly runs the branch-free
// small-rotation strain (voronoi_strain<true>) in the SIMD loop and flags the
// lanes outside its range; those lanes are assembled again, after the loop,
// by the same code with the general strain (voronoi_strain<false>), which
// gives bit-for-bit the same values where the small path is valid
// (kernels/math.h), exactly as host/launch.h launch_with_fallback does.
//
// Fixed unknowns (zero inverse mass: a clamped node, a ghost element) become
// identity rows with u = 0, per lane, as in the scalar kernel.
//
// reads: model, state geometry and velocities of the W rods
// writes: node_v, elem_w of their cells, and the elimination scratch:
//   G[i][c·W + l] (i < 36, row-major 6×6) and g[i][c·W + l] (i < 6) for cell c
//   of lane l, c < cells: 42·W·cells values (the host passes a per-thread
//   buffer at least that long).
#pragma once

#include "kernels/viscous_implicit.h"

// One SIMD loop over the lanes (host); a plain loop in CUDA device code, where
// a lane group is one thread.
#if defined(_OPENMP) && !defined(__CUDACC__)
#define MANYRODS_LANES _Pragma("omp simd")
#else
#define MANYRODS_LANES
#endif

// Fully unroll every loop over matrix entries (up to 36 long: beyond
// MANYRODS_UNROLL's 16), so that only the loop over lanes is left.
#if defined(__CUDACC__)
#define MANYRODS_UNROLL_ALL _Pragma("unroll")
#elif defined(__clang__)
#define MANYRODS_UNROLL_ALL _Pragma("clang loop unroll(full)")
#elif defined(__GNUC__)
#define MANYRODS_UNROLL_ALL _Pragma("GCC unroll 64")
#else
#define MANYRODS_UNROLL_ALL
#endif

namespace manyrods {

namespace lanes_detail {

// Lower triangle of a symmetric 6×6, row by row: (i, j), j ≤ i.
MANYRODS_HD constexpr int lt(int i, int j) { return i >= j ? i * (i + 1) / 2 + j : j * (j + 1) / 2 + i; }
// U's 27 stored entries: (i, j) unless i < 3 ≤ j (the zero block v_c–ω_{c+1}).
MANYRODS_HD constexpr int ui(int i, int j) {
  return i < 3 ? 3 * i + j : (j < 3 ? 9 + 3 * (i - 3) + j : 18 + 3 * (i - 3) + j - 3);
}
// First row of U's column j that is not structurally zero.
MANYRODS_HD constexpr int u_row0(int j) { return j >= 3 ? 3 : 0; }

// One cell's system for W lanes.
template <class T, int W>
struct Cell {
  T A[21][W];     // lower triangle of A_c; after factor(): L with 1/L_ii on the diagonal
  T U[27][W];     // U_c without its zero block (ui)
  T y[6][W];      // M u⁻
  T carry[12][W]; // the next cell's diagonal block so far: A_vv (lt 0–5), A_ωω (lt of the ω part)
  T minv[4][W];   // inverse node mass, inverse element inertia (0: fixed unknown)
  int general[W]; // lane needs the general (large-rotation) joint strain
};

// The blocks of joint (Voronoi point) k, from c1 = −J/D̂, c2 = J Rᵀ/D̂ and
// v̂ = h C_M τ / D̂: S = c1ᵀWc1 h = Jᵀ diag(v̂) J (lower, 6 entries),
// SRt = S Rᵀ = −c1ᵀWc2 h (9), RSRt = R S Rᵀ = c2ᵀWc2 h (lower, 6). Returns
// true where kSmall and the joint turns by more than the small-rotation path
// covers (the caller redoes that lane with kSmall = false).
template <Terms kT, bool kSmall, class T>
MANYRODS_HD inline bool joint_blocks(int k, T h, T stiff_h, const ModelView<T>& m, const ConstStateView<T>& s,
                                     T s6[6], T sRt[9], T rsRt[6]) {
  const VoronoiStrain<T> vs = voronoi_strain<kSmall>(k, m, s);
  bool general = false;
  if constexpr (kSmall) general = !((vs.c >= T(kSmallRotationCos)) & (vs.theta * vs.theta <= T(kSmallRotation2)));
  const T hd = h / m.vor_rest_length[k];
  const vec3<T> cm = load3(m.vor_stiffness, k);
  const vec3<T> tau = viscous_detail::solve_tau<kT>(m.vor_tau, k, stiff_h, true);
  const T v[3] = {kT.bend ? hd * cm.x * tau.x : T(0), kT.bend ? hd * cm.y * tau.y : T(0),
                  kT.twist ? hd * cm.z * tau.z : T(0)};
  // J = (1 − γ|ψ|²) I + ½[ψ]× + γ ψψᵀ
  const vec3<T> p = vs.psi;
  const T g = vs.gamma, dg = T(1) - g * dot(p, p);
  const T gx = g * p.x, gy = g * p.y, gz = g * p.z;
  const T hx = T(0.5) * p.x, hy = T(0.5) * p.y, hz = T(0.5) * p.z;
  const T gxy = gx * p.y, gxz = gx * p.z, gyz = gy * p.z;
  const T J[9] = {dg + gx * p.x, gxy - hz,      gxz + hy,  //
                  gxy + hz,      dg + gy * p.y, gyz - hx,  //
                  gxz - hy,      gyz + hx,      dg + gz * p.z};
  T P[9];  // diag(v̂) J
  MANYRODS_UNROLL_ALL
  for (int l = 0; l < 3; ++l)
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < 3; ++j) P[3 * l + j] = v[l] * J[3 * l + j];
  T S[9];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 3; ++i)
    MANYRODS_UNROLL_ALL
    for (int j = 0; j <= i; ++j) {
      S[3 * i + j] = J[i] * P[j] + J[3 + i] * P[3 + j] + J[6 + i] * P[6 + j];
      S[3 * j + i] = S[3 * i + j];
      s6[i * (i + 1) / 2 + j] = S[3 * i + j];
    }
  const T* R = vs.R.m;
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 3; ++i)
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < 3; ++j)
      sRt[3 * i + j] = S[3 * i] * R[3 * j] + S[3 * i + 1] * R[3 * j + 1] + S[3 * i + 2] * R[3 * j + 2];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 3; ++i)
    MANYRODS_UNROLL_ALL
    for (int j = 0; j <= i; ++j)
      rsRt[i * (i + 1) / 2 + j] = R[3 * i] * sRt[j] + R[3 * i + 1] * sRt[3 + j] + R[3 * i + 2] * sRt[6 + j];
  return general;
}

// The root cell's carried block: the root joint (to the clamp frame, zero
// stiffness for a free root) adds c2ᵀWc2 h to A_ωω of cell 0.
template <Terms kT, bool kSmall, int W, class T>
MANYRODS_HD inline void root_lane(int l, int k, T h, T stiff_h, const ModelView<T>& m, const ConstStateView<T>& s,
                                  Cell<T, W>& out) {
  T s6[6], sRt[9], rsRt[6];
  out.general[l] = joint_blocks<kT, kSmall>(k, h, stiff_h, m, s, s6, sRt, rsRt);
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) {
    out.carry[i][l] = T(0);
    out.carry[6 + i][l] = rsRt[i];
  }
}

// Assembles cell c (slot k) of lane l into `cur` from the block `prev`
// carried over from cell c−1: A_c (lower), U_c, y_c, the inverse masses, and
// the next cell's carry. kLast: the last cell (element and joint k+1 are
// ghosts, see the header; no U, no carry).
template <Terms kT, bool kSmall, bool kLast, int W, class T>
MANYRODS_HD inline void assemble_lane(int l, int k, T h, T stiff_h, const ModelView<T>& m,
                                      const ConstStateView<T>& s, const Cell<T, W>& prev, Cell<T, W>& cur) {
  const T mass[6] = {m.node_mass[k],       m.node_mass[k],       m.node_mass[k],
                     m.elem_inertia[0][k], m.elem_inertia[1][k], m.elem_inertia[2][k]};
  const T u[6] = {s.node_v[0][k], s.node_v[1][k], s.node_v[2][k],
                  s.elem_w[0][k], s.elem_w[1][k], s.elem_w[2][k]};
  const T minv[4] = {m.node_inv_mass[k], m.elem_inv_inertia[0][k], m.elem_inv_inertia[1][k],
                     m.elem_inv_inertia[2][k]};
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 4; ++i) cur.minv[i][l] = minv[i];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) cur.y[i][l] = mass[i] * u[i];
  if constexpr (kLast) {
    cur.general[l] = 0;
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 3; ++i)
      MANYRODS_UNROLL_ALL
      for (int j = 0; j <= i; ++j) {
        const int t = i * (i + 1) / 2 + j;
        cur.A[lt(i, j)][l] = i == j ? prev.carry[t][l] + mass[i] : prev.carry[t][l];
        cur.A[lt(3 + i, 3 + j)][l] = i == j ? prev.carry[6 + t][l] + mass[3 + i] : prev.carry[6 + t][l];
      }
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 3; ++i)
      MANYRODS_UNROLL_ALL
      for (int j = 0; j < 3; ++j) cur.A[lt(3 + i, j)][l] = T(0);
    return;
  } else {
    // element k: ŵ = h C_F τ / l̂, P = diag(ŵ) Q, a = Q e
    const ElementStrain<T> es = element_strain(k, m, s);
    const T hl = h / m.elem_rest_length[k];
    const vec3<T> cf = load3(m.elem_stiffness, k);
    const vec3<T> tau = viscous_detail::solve_tau<kT>(m.elem_tau, k, stiff_h, false);
    const T w[3] = {kT.shear ? hl * cf.x * tau.x : T(0), kT.shear ? hl * cf.y * tau.y : T(0),
                    kT.stretch ? hl * cf.z * tau.z : T(0)};
    const T* Q = es.Q.m;
    const vec3<T> a = es.Qe;
    T P[9];
    MANYRODS_UNROLL_ALL
    for (int r = 0; r < 3; ++r)
      MANYRODS_UNROLL_ALL
      for (int j = 0; j < 3; ++j) P[3 * r + j] = w[r] * Q[3 * r + j];
    T N[9];  // Qᵀ P, symmetric
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 3; ++i)
      MANYRODS_UNROLL_ALL
      for (int j = 0; j <= i; ++j) {
        N[3 * i + j] = Q[i] * P[j] + Q[3 + i] * P[3 + j] + Q[6 + i] * P[6 + j];
        N[3 * j + i] = N[3 * i + j];
      }
    T X[9];  // [a]× P
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < 3; ++j) {
      X[j] = a.y * P[6 + j] - a.z * P[3 + j];
      X[3 + j] = a.z * P[j] - a.x * P[6 + j];
      X[6 + j] = a.x * P[3 + j] - a.y * P[j];
    }
    // [a]×ᵀ diag(ŵ) [a]× (lower)
    const T xx = a.x * a.x, yy = a.y * a.y, zz = a.z * a.z;
    const T Mw[6] = {w[1] * zz + w[2] * yy, -(w[2] * a.x * a.y), w[0] * zz + w[2] * xx,
                     -(w[1] * a.x * a.z),   -(w[0] * a.y * a.z), w[0] * yy + w[1] * xx};
    // joint k+1
    T s6[6], sRt[9], rsRt[6];
    cur.general[l] = joint_blocks<kT, kSmall>(k + 1, h, stiff_h, m, s, s6, sRt, rsRt);
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 3; ++i)
      MANYRODS_UNROLL_ALL
      for (int j = 0; j <= i; ++j) {
        const int t = i * (i + 1) / 2 + j;
        const T av = prev.carry[t][l] + N[3 * i + j];
        const T aw = prev.carry[6 + t][l] + Mw[t] + s6[t];
        cur.A[lt(i, j)][l] = i == j ? av + mass[i] : av;
        cur.A[lt(3 + i, 3 + j)][l] = i == j ? aw + mass[3 + i] : aw;
        cur.carry[t][l] = N[3 * i + j];
        cur.carry[6 + t][l] = rsRt[t];
      }
    // U, with the rows of this cell's and the columns of the next cell's
    // fixed unknowns zeroed (as viscous_implicit_rod does)
    const T nminv[4] = {m.node_inv_mass[k + 1], m.elem_inv_inertia[0][k + 1], m.elem_inv_inertia[1][k + 1],
                        m.elem_inv_inertia[2][k + 1]};
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 3; ++i)
      MANYRODS_UNROLL_ALL
      for (int j = 0; j < 3; ++j) {
        const bool rv = minv[0] == T(0), rw = minv[1 + i] == T(0);
        const bool cv = nminv[0] == T(0), cw = nminv[1 + j] == T(0);
        cur.A[lt(3 + i, j)][l] = X[3 * i + j];
        cur.U[ui(i, j)][l] = rv | cv ? T(0) : -N[3 * i + j];
        cur.U[ui(3 + i, j)][l] = rw | cv ? T(0) : -X[3 * i + j];
        cur.U[ui(3 + i, 3 + j)][l] = rw | cw ? T(0) : -sRt[3 * i + j];
      }
  }
}

// Elimination and factorization of cell c of lane l (after assemble_lane):
//   Â = A − U_{c−1}ᵀ G_{c−1},  ŷ = y − U_{c−1}ᵀ g_{c−1}  (c > 0),
// fixed unknowns → identity rows, Â = L Lᵀ, g_c = Â⁻¹ŷ, G_c = Â⁻¹U_c (not for
// the last cell), stored in the scratch.
template <bool kFirst, bool kLast, int W, class T>
MANYRODS_HD inline void eliminate_lane(int l, int c, const Cell<T, W>& prev, Cell<T, W>& cur,
                                       const ImplicitScratchView<T>& sc) {
  T A[21], y[6];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 21; ++i) A[i] = cur.A[i][l];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) y[i] = cur.y[i][l];
  if constexpr (!kFirst) {
    const int at = (c - 1) * W + l;
    T Gp[36], gp[6];
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 36; ++i) Gp[i] = sc.G[i][at];
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 6; ++i) gp[i] = sc.g[i][at];
    // U_{c−1}ᵀ G_{c−1} is symmetric: lower triangle; U's column i is zero
    // above row u_row0(i)
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 6; ++i) {
      MANYRODS_UNROLL_ALL
      for (int j = 0; j <= i; ++j) {
        T acc = A[lt(i, j)];
        MANYRODS_UNROLL_ALL
        for (int r = u_row0(i); r < 6; ++r) acc -= prev.U[ui(r, i)][l] * Gp[6 * r + j];
        A[lt(i, j)] = acc;
      }
      T acc = y[i];
      MANYRODS_UNROLL_ALL
      for (int r = u_row0(i); r < 6; ++r) acc -= prev.U[ui(r, i)][l] * gp[r];
      y[i] = acc;
    }
  }
  // fixed unknowns: u = 0, decoupled
  bool fixed[6];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) fixed[i] = cur.minv[i < 3 ? 0 : i - 2][l] == T(0);
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) {
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < i; ++j) A[lt(i, j)] = fixed[i] | fixed[j] ? T(0) : A[lt(i, j)];
    A[lt(i, i)] = fixed[i] ? T(1) : A[lt(i, i)];
    y[i] = fixed[i] ? T(0) : y[i];
  }
  // Cholesky, keeping 1/L_jj on the diagonal
  MANYRODS_UNROLL_ALL
  for (int j = 0; j < 6; ++j) {
    T d = A[lt(j, j)];
    MANYRODS_UNROLL_ALL
    for (int r = 0; r < j; ++r) d -= A[lt(j, r)] * A[lt(j, r)];
    using std::sqrt;  // unqualified: see kernels/math.h norm
    const T id = T(1) / sqrt(d);
    A[lt(j, j)] = id;
    MANYRODS_UNROLL_ALL
    for (int i = j + 1; i < 6; ++i) {
      T v = A[lt(i, j)];
      MANYRODS_UNROLL_ALL
      for (int r = 0; r < j; ++r) v -= A[lt(i, r)] * A[lt(j, r)];
      A[lt(i, j)] = v * id;
    }
  }
  // g = L⁻ᵀ L⁻¹ ŷ
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) {
    T v = y[i];
    MANYRODS_UNROLL_ALL
    for (int r = 0; r < i; ++r) v -= A[lt(i, r)] * y[r];
    y[i] = v * A[lt(i, i)];
  }
  MANYRODS_UNROLL_ALL
  for (int i = 5; i >= 0; --i) {
    T v = y[i];
    MANYRODS_UNROLL_ALL
    for (int r = i + 1; r < 6; ++r) v -= A[lt(r, i)] * y[r];
    y[i] = v * A[lt(i, i)];
  }
  const int at = c * W + l;
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) sc.g[i][at] = y[i];
  if constexpr (!kLast) {
    // G = L⁻ᵀ L⁻¹ U column by column; column j of U (and of L⁻¹U) is zero
    // above row u_row0(j)
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < 6; ++j) {
      T x[6];
      MANYRODS_UNROLL_ALL
      for (int i = 0; i < 6; ++i) {
        if (i < u_row0(j)) {
          x[i] = T(0);
          continue;
        }
        T v = cur.U[ui(i, j)][l];
        MANYRODS_UNROLL_ALL
        for (int r = u_row0(j); r < i; ++r) v -= A[lt(i, r)] * x[r];
        x[i] = v * A[lt(i, i)];
      }
      MANYRODS_UNROLL_ALL
      for (int i = 5; i >= 0; --i) {
        T v = x[i];
        MANYRODS_UNROLL_ALL
        for (int r = i + 1; r < 6; ++r) v -= A[lt(r, i)] * x[r];
        x[i] = v * A[lt(i, i)];
      }
      MANYRODS_UNROLL_ALL
      for (int i = 0; i < 6; ++i) sc.G[6 * i + j][at] = x[i];
    }
  }
}

// Back substitution for cell c of lane l: u_c = g_c − G_c u_{c+1}; writes
// the rod's velocities. kLast: u_c = g_c.
template <bool kLast, int W, class T>
MANYRODS_HD inline void back_lane(int l, int c, int k, T (&next)[6][W], const StateView<T>& s,
                                  const ImplicitScratchView<T>& sc) {
  const int at = c * W + l;
  T x[6];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) {
    T v = sc.g[i][at];
    if constexpr (!kLast) {
      MANYRODS_UNROLL_ALL
      for (int j = 0; j < 6; ++j) v -= sc.G[6 * i + j][at] * next[j][l];
    }
    x[i] = v;
  }
  MANYRODS_UNROLL_ALL
  for (int d = 0; d < 3; ++d) {
    s.node_v[d][k] = x[d];
    s.elem_w[d][k] = x[3 + d];
  }
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) next[i][l] = x[i];
}
}  // namespace lanes_detail
// Backward-Euler viscous update of W rods with `cells` cells each, rod l's
// cells at slots [first[l], first[l] + cells) — what viscous_implicit_rod
// does for each of them, to round-off. stiff_h[l]: h for a stiff rod, 0
// otherwise (see kernels/viscous_implicit.h). Velocities in `s` are u⁻ on
// entry, u⁺ on exit. `sc` holds 42·W·cells values (see the header).
template <Terms kT, int W, class T>
MANYRODS_HD inline void viscous_implicit_lanes(const int* first, int cells, T h, const T* stiff_h,
                                               const ModelView<T>& m, const StateView<T>& s,
                                               const ImplicitScratchView<T>& sc) {
  using namespace lanes_detail;
  // Local copies of the views: no store in the lane loops can alias them, so
  // their pointers stay in registers (as in host/launch.h).
  const ModelView<T> mv = m;
  const StateView<T> sv = s;
  const ConstStateView<T> cs = as_const(s);
  const ImplicitScratchView<T> scv = sc;
  Cell<T, W> cell[2];  // cell c in cell[c & 1], its predecessor in the other
  int f[W];
  T sh[W];
  for (int l = 0; l < W; ++l) f[l] = first[l], sh[l] = stiff_h[l];
  // Redoes the lanes whose joints turn by more than the small-rotation path
  // covers (rare): the same code with the general strain.
  auto any_general = [](const Cell<T, W>& x) {
    int any = 0;
    for (int l = 0; l < W; ++l) any |= x.general[l];
    return any != 0;
  };
  {
    Cell<T, W>& root = cell[1];
    MANYRODS_LANES
    for (int l = 0; l < W; ++l) root_lane<kT, true>(l, f[l], h, sh[l], mv, cs, root);
    if (any_general(root))
      for (int l = 0; l < W; ++l)
        if (root.general[l]) root_lane<kT, false>(l, f[l], h, sh[l], mv, cs, root);
  }
  for (int c = 0; c < cells; ++c) {
    const Cell<T, W>& prev = cell[(c + 1) & 1];
    Cell<T, W>& cur = cell[c & 1];
    if (c + 1 < cells) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) assemble_lane<kT, true, false>(l, f[l] + c, h, sh[l], mv, cs, prev, cur);
      if (any_general(cur))
        for (int l = 0; l < W; ++l)
          if (cur.general[l]) assemble_lane<kT, false, false>(l, f[l] + c, h, sh[l], mv, cs, prev, cur);
    } else {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) assemble_lane<kT, true, true>(l, f[l] + c, h, sh[l], mv, cs, prev, cur);
    }
    if (c == 0 && c + 1 < cells) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_lane<true, false>(l, c, prev, cur, scv);
    } else if (c == 0) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_lane<true, true>(l, c, prev, cur, scv);
    } else if (c + 1 < cells) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_lane<false, false>(l, c, prev, cur, scv);
    } else {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_lane<false, true>(l, c, prev, cur, scv);
    }
  }
  T next[6][W];
  MANYRODS_LANES
  for (int l = 0; l < W; ++l) back_lane<true>(l, cells - 1, f[l] + cells - 1, next, sv, scv);
  for (int c = cells - 2; c >= 0; --c) {
    MANYRODS_LANES
    for (int l = 0; l < W; ++l) back_lane<false>(l, c, f[l] + c, next, sv, scv);
  }
}

}  // namespace manyrods
