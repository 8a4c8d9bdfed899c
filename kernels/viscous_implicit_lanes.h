// kernels/viscous_implicit_lanes.h — the backward-Euler Kelvin–Voigt update of
// kernels/viscous_implicit.h for W rods at once, one rod per SIMD lane.
//
// Same system as viscous_implicit_rod (read its header for the equations):
// per rod (M + hD) u⁺ = M u⁻, D block tridiagonal with 6×6 blocks over the
// cells c = 0 … cells−1 (cell c = node c and element c). That kernel
// eliminates it with G_c = Â_c⁻¹ U_c,
//   Â_0 = A_0,  Â_c = A_c − U_{c−1}ᵀ G_{c−1},  ŷ_c = y_c − U_{c−1}ᵀ g_{c−1},
//   g_c = Â_c⁻¹ ŷ_c,  u_c = g_c − G_c u_{c+1}   (backwards from the last cell),
// Â_c = L Lᵀ by Cholesky; this one with Z_c = L⁻¹ U_c, which needs no
// backward solves for the columns of U ("The elimination with Z_c = L⁻¹U_c"
// below; with kKeep it also leaves G_c). Lane l solves rod l, whose cells are the slots
// first[l] … first[l] + cells[l] − 1 (rods of different lengths: see
// viscous_implicit_lanes below). Every value is an array over the lanes
// ([…][W]) and every stage is one `omp simd` loop over the lanes whose body
// is the scalar per-rod arithmetic (fully unrolled: lane-wide vectors in
// registers, no loop over matrix indices at run time), so that every lane
// loop but the scalar fallback ones vectorizes.
//
// Where it does less arithmetic than the scalar kernel (exact in exact
// arithmetic; the results agree to round-off, tests/test_implicit_lanes.cpp):
//   * A is symmetric: only its lower triangle (21 entries) is assembled,
//     eliminated and factored; Z_{c−1}ᵀZ_{c−1} is symmetric too (lower
//     triangle only).
//   * Z_c = L⁻¹U_c instead of G_c = Â_c⁻¹U_c: no backward solves for U's six
//     columns (1,014 FLOP per rod and cell against 1,248).
//   * U_c (rows: cell c's v, ω; columns: cell c+1's v, ω) has a zero block:
//     v_c does not couple to ω_{c+1} (element k's strain involves ω_k only,
//     Voronoi k+1 involves no v), and so has Z_c. Their 27 other entries are
//     stored, the zero block is skipped in ZᵀZ, Zᵀz, Z u and in the forward
//     solves for Z's columns 3–5 (whose first three entries stay zero).
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
// small-rotation log (joint_log<true>, as voronoi_strain<true>) in the SIMD
// loop and flags the lanes outside its range; those lanes are assembled
// again, after the loop, by the same code with the general log
// (joint_log<false>, as voronoi_strain<false>), which gives bit-for-bit the
// same values where the small path is valid (kernels/math.h), as
// host/core/step/launch.h launch_with_fallback does.
//
// Fixed unknowns (zero inverse mass: a clamped node, a ghost element) become
// identity rows with u = 0, per lane, as in the scalar kernel. With kLift
// (rods with prescribed velocities: a driven hold besides the reference
// one, kernels/viscous_implicit.h) they keep their values p instead, and the
// system's coupling to them moves to the right-hand side,
//   y_c = M u⁻_c − [(A_c − M) p_c + U_c p_{c+1} + U_{c−1}ᵀ p_{c−1}]
// on the free unknowns (p: u⁻ on the fixed unknowns, 0 elsewhere), y = p on
// the fixed ones: the solution of (M + hD) u⁺ = M u⁻ with u⁺ = p there
// (tests/test_implicit_lanes.cpp checks it against the dense system,
// lifted by Eigen).
//
// reads: model, state geometry and velocities of the W rods
// writes: node_v, elem_w of their cells, and the elimination scratch:
//   G[i][c·W + l] (Z_c's 27 entries at i = ui; with kKeep, G_c at the end,
//   row-major 6×6), g[i][c·W + l] (i < 6: z_c, then u_c) and L[i][c·W + l]
//   (i < 21: Â_c's factor) for the group's cell c of lane l,
//   c ≤ max(cells): 63·W·(max(cells) + 1) values (the host passes a
//   per-thread buffer at least that long); with kKeep, the factors
//   (kernels/viscous_implicit.h kKeepValues) into `keep`.
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

// the packed indices of viscous_implicit.h (lower triangle, U's entries)
using viscous_detail::lt;
using viscous_detail::u_row0;
using viscous_detail::ui;

// One cell's system for W lanes.
template <class T, int W>
struct Cell {
  T A[21][W];     // lower triangle of A_c (eliminate_lane factors a copy)
  T U[27][W];     // U_c without its zero block (ui)
  T y[6][W];      // M u⁻
  T carry[12][W]; // the next cell's diagonal block so far: A_vv (lt 0–5), A_ωω (lt of the ω part)
  T minv[4][W];   // inverse node mass, inverse element inertia (0: fixed unknown)
  T lift[6][W];   // kLift: U_cᵀ p_c, this cell's prescribed values' share of the next cell's y
  int general[W]; // lane needs the general (large-rotation) joint strain
};

// The packed inputs (see viscous_implicit_lanes): value a of cell c, lane l
// at P[a][c·W + l].
enum Packed : int {
  kX = 0,            // node_x (3)
  kV = 3,            // node_v (3)
  kOmega = 6,        // elem_w (3)
  kQ = 9,            // elem_Q (9)
  kL = 18,           // elem_rest_length
  kCF = 19,          // elem_stiffness (3)
  kTauF = 22,        // elem_tau (3)
  kD = 25,           // vor_rest_length
  kCM = 26,          // vor_stiffness (3)
  kTauM = 29,        // vor_tau (3)
  kMass = 32,        // node_mass
  kInertia = 33,     // elem_inertia (3)
  kInvMass = 36,     // node_inv_mass
  kInvInertia = 37,  // elem_inv_inertia (3)
  kPacked = 40
};

// The blocks of a joint from its rotation R = Q_b Q_aᵀ, ψ = log R, γ and the
// weights v̂ = h C_M τ / D̂, with c1 = −J/D̂, c2 = J Rᵀ/D̂:
// S = c1ᵀWc1 h = Jᵀ diag(v̂) J (lower, 6 entries), SRt = S Rᵀ = −c1ᵀWc2 h (9),
// RSRt = R S Rᵀ = c2ᵀWc2 h (lower, 6).
template <class T>
MANYRODS_HD inline void joint_blocks(const mat3<T>& rot, vec3<T> p, T g, const T v[3], T s6[6], T sRt[9],
                                     T rsRt[6]) {
  // J = J_r(ψ)⁻¹ = (1 − γ|ψ|²) I + ½[ψ]× + γ ψψᵀ
  const T dg = T(1) - g * dot(p, p);
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
  const T* R = rot.m;
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
}

// ψ = log R and γ exactly as voronoi_strain<kSmall> computes them; returns
// true where kSmall and the rotation is beyond the small path's range (the
// caller redoes that lane with kSmall = false, which gives bit-for-bit the
// same values inside the range).
template <bool kSmall, class T>
MANYRODS_HD inline bool joint_log(const mat3<T>& R, vec3<T>& psi, T& gamma) {
  T theta, s, c;
  if constexpr (kSmall) {
    psi = rotation_log_small(R, theta, s, c);
    gamma = inverse_right_jacobian_gamma_small(theta * theta);
    return !((c >= T(kSmallRotationCos)) & (theta * theta <= T(kSmallRotation2)));
  } else {
    psi = rotation_log(R, theta, s, c);
    gamma = inverse_right_jacobian_gamma(theta, s, c);
    return false;
  }
}

// The joint's weights v̂ = h C_M τ / D̂ (τ as solve_tau: c·stiff_h on
// bending, stiff_h on twist).
template <Terms kT, class T>
MANYRODS_HD inline void joint_weights(T h, T stiff_h, T d, vec3<T> cm, vec3<T> tau_kv, T v[3]) {
  const T hd = h / d, bend_h = T(kStiffBendingC) * stiff_h;
  const vec3<T> t = kT.kelvin_voigt ? tau_kv : vec3<T>{T(0), T(0), T(0)};
  v[0] = kT.bend ? hd * cm.x * (t.x + bend_h) : T(0);
  v[1] = kT.bend ? hd * cm.y * (t.y + bend_h) : T(0);
  v[2] = kT.twist ? hd * cm.z * (t.z + stiff_h) : T(0);
}

// Prescribed values (kLift, see viscous_implicit_lanes): p = u on the
// fixed unknowns (zero inverse mass), 0 on the others.
template <class T>
MANYRODS_HD inline void fixed_values(const T (&u)[6], const T (&minv)[4], T (&p)[6]) {
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 3; ++i) {
    p[i] = minv[0] == T(0) ? u[i] : T(0);
    p[3 + i] = minv[1 + i] == T(0) ? u[3 + i] : T(0);
  }
}

// kLift: a free unknown's right-hand side loses the coupling r to the
// prescribed values; a fixed one's is its value (fix_lane keeps it).
template <int W, class T>
MANYRODS_HD inline void lift_rows(int l, const T (&minv)[4], const T (&p)[6], const T (&r)[6], Cell<T, W>& cur) {
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i)
    cur.y[i][l] = minv[i < 3 ? 0 : i - 2] == T(0) ? p[i] : cur.y[i][l] - r[i];
}

// kLift: r = U_{c−1}ᵀ p_{c−1} (prev.lift) + the carried block (the part of
// A_c from the cell before) times p.
template <int W, class T>
MANYRODS_HD inline void carried_lift(int l, const Cell<T, W>& prev, const T (&p)[6], T (&r)[6]) {
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) r[i] = prev.lift[i][l];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 3; ++i)
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < 3; ++j) {
      const int t = i >= j ? i * (i + 1) / 2 + j : j * (j + 1) / 2 + i;
      r[i] += prev.carry[t][l] * p[j];
      r[3 + i] += prev.carry[6 + t][l] * p[3 + j];
    }
}

// Assembles cell c of lane l into `cur` from the packed inputs P (cells c
// and c+1) and the block `prev` carried over from cell c−1: A_c (lower), U_c,
// y_c, the inverse masses, and the next cell's carry. kLast: the last cell
// (its element and joint k+1 are ghosts, see the header; no U, no carry).
template <Terms kT, bool kSmall, bool kLast, int W, class T, bool kLift = false>
MANYRODS_HD inline void assemble_lane(int l, int c, T h, T stiff_h, T* const* P, const Cell<T, W>& prev,
                                      Cell<T, W>& cur) {
  const int p = c * W + l, q = p + W;  // this cell, the next one
  auto at3 = [&](int a, int i) { return vec3<T>{P[a][i], P[a + 1][i], P[a + 2][i]}; };
  const T mass[6] = {P[kMass][p], P[kMass][p], P[kMass][p], P[kInertia][p], P[kInertia + 1][p], P[kInertia + 2][p]};
  const T u[6] = {P[kV][p], P[kV + 1][p], P[kV + 2][p], P[kOmega][p], P[kOmega + 1][p], P[kOmega + 2][p]};
  const T minv[4] = {P[kInvMass][p], P[kInvInertia][p], P[kInvInertia + 1][p], P[kInvInertia + 2][p]};
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
    if constexpr (kLift) {  // y −= (A − M) p + U_{c−1}ᵀ p_{c−1} (A − M: the carried block)
      T p[6], r[6];
      fixed_values(u, minv, p);
      carried_lift(l, prev, p, r);
      lift_rows(l, minv, p, r, cur);
    }
  } else {
    // element k (element_strain): a = Q e; ŵ = h C_F τ / l̂, P = diag(ŵ) Q
    mat3<T> Qk, Qn;
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 9; ++i) {
      Qk.m[i] = P[kQ + i][p];
      Qn.m[i] = P[kQ + i][q];
    }
    const vec3<T> a = mul(Qk, at3(kX, q) - at3(kX, p));
    const T hl = h / P[kL][p];
    const vec3<T> cf = at3(kCF, p);
    const vec3<T> tk = kT.kelvin_voigt ? at3(kTauF, p) : vec3<T>{T(0), T(0), T(0)};
    const T w[3] = {kT.shear ? hl * cf.x * (tk.x + stiff_h) : T(0), kT.shear ? hl * cf.y * (tk.y + stiff_h) : T(0),
                    kT.stretch ? hl * cf.z * (tk.z + stiff_h) : T(0)};
    const T* Q = Qk.m;
    T Pq[9];
    MANYRODS_UNROLL_ALL
    for (int r = 0; r < 3; ++r)
      MANYRODS_UNROLL_ALL
      for (int j = 0; j < 3; ++j) Pq[3 * r + j] = w[r] * Q[3 * r + j];
    T N[9];  // Qᵀ P, symmetric
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 3; ++i)
      MANYRODS_UNROLL_ALL
      for (int j = 0; j <= i; ++j) {
        N[3 * i + j] = Q[i] * Pq[j] + Q[3 + i] * Pq[3 + j] + Q[6 + i] * Pq[6 + j];
        N[3 * j + i] = N[3 * i + j];
      }
    T X[9];  // [a]× P
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < 3; ++j) {
      X[j] = a.y * Pq[6 + j] - a.z * Pq[3 + j];
      X[3 + j] = a.z * Pq[j] - a.x * Pq[6 + j];
      X[6 + j] = a.x * Pq[3 + j] - a.y * Pq[j];
    }
    // [a]×ᵀ diag(ŵ) [a]× (lower)
    const T xx = a.x * a.x, yy = a.y * a.y, zz = a.z * a.z;
    const T Mw[6] = {w[1] * zz + w[2] * yy, -(w[2] * a.x * a.y), w[0] * zz + w[2] * xx,
                     -(w[1] * a.x * a.z),   -(w[0] * a.y * a.z), w[0] * yy + w[1] * xx};
    // joint k+1 (voronoi_strain): R = Q_{k+1} Q_kᵀ
    const mat3<T> R = mul_transpose(Qn, Qk);
    vec3<T> psi;
    T gamma, v[3], s6[6], sRt[9], rsRt[6];
    cur.general[l] = joint_log<kSmall>(R, psi, gamma);
    joint_weights<kT>(h, stiff_h, P[kD][q], at3(kCM, q), at3(kTauM, q), v);
    joint_blocks(R, psi, gamma, v, s6, sRt, rsRt);
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
    const T nminv[4] = {P[kInvMass][q], P[kInvInertia][q], P[kInvInertia + 1][q], P[kInvInertia + 2][q]};
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
    if constexpr (kLift) {
      // y −= (A − M) p + U p_{c+1} + U_{c−1}ᵀ p_{c−1} with the full blocks
      // (A_vv = carry + N, A_ωω = carry + [a]×ᵀdiag(ŵ)[a]× + S, A_ωv = X;
      // U_vv = −N, U_ωv = −X, U_ωω = −S Rᵀ), and U_cᵀ p_c for the next cell
      const T un[6] = {P[kV][q], P[kV + 1][q], P[kV + 2][q], P[kOmega][q], P[kOmega + 1][q], P[kOmega + 2][q]};
      T p[6], pn[6], r[6];
      fixed_values(u, minv, p);
      fixed_values(un, nminv, pn);
      carried_lift(l, prev, p, r);
      MANYRODS_UNROLL_ALL
      for (int i = 0; i < 3; ++i)
        MANYRODS_UNROLL_ALL
        for (int j = 0; j < 3; ++j) {
          const int t = i >= j ? i * (i + 1) / 2 + j : j * (j + 1) / 2 + i;
          r[i] += N[3 * i + j] * (p[j] - pn[j]) + X[3 * j + i] * p[3 + j];
          r[3 + i] += X[3 * i + j] * (p[j] - pn[j]) + (Mw[t] + s6[t]) * p[3 + j] - sRt[3 * i + j] * pn[3 + j];
        }
      lift_rows(l, minv, p, r, cur);
      MANYRODS_UNROLL_ALL
      for (int j = 0; j < 3; ++j) {
        T lv = T(0), lw = T(0);
        MANYRODS_UNROLL_ALL
        for (int i = 0; i < 3; ++i) {
          lv -= N[3 * i + j] * p[i] + X[3 * i + j] * p[3 + i];
          lw -= sRt[3 * i + j] * p[3 + i];
        }
        cur.lift[j][l] = lv;
        cur.lift[3 + j][l] = lw;
      }
    }
  }
}

// The pieces of the elimination of one cell with G_c = Â_c⁻¹U_c (the
// partitioned solve of kernels/viscous_implicit_partitioned.h, whose
// separators reuse G; eliminate_lane below uses Z_c = L⁻¹U_c).
//
// The Schur update of one cell from the previous one, for either form:
//   Â_ij = A_ij − Σ_r P(r, i) R(r, j)  (j ≤ i, lower triangle),
//   ŷ_i  = y_i  − Σ_r P(r, i) v_r,
// over the rows r ≥ u_row0(i) where U's (and Z's) column i is nonzero.
template <class T, class P, class R>
MANYRODS_HD inline void schur_update(P&& left, R&& right, const T (&v)[6], T (&A)[21], T (&y)[6]) {
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) {
    MANYRODS_UNROLL_ALL
    for (int j = 0; j <= i; ++j) {
      T acc = A[lt(i, j)];
      MANYRODS_UNROLL_ALL
      for (int r = u_row0(i); r < 6; ++r) acc -= left(r, i) * right(r, j);
      A[lt(i, j)] = acc;
    }
    T acc = y[i];
    MANYRODS_UNROLL_ALL
    for (int r = u_row0(i); r < 6; ++r) acc -= left(r, i) * v[r];
    y[i] = acc;
  }
}

// Â = A − U_{c−1}ᵀ G_{c−1}, ŷ = y − U_{c−1}ᵀ g_{c−1}, from the previous cell's
// U and the scratch at `at` (cell c−1, lane l). U_{c−1}ᵀ G_{c−1} is symmetric:
// lower triangle; U's column i is zero above row u_row0(i).
template <int W, class T>
MANYRODS_HD inline void schur_lane(int l, int at, const Cell<T, W>& prev, const ImplicitScratchView<T>& sc,
                                   T (&A)[21], T (&y)[6]) {
  T Gp[36], gp[6];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 36; ++i) Gp[i] = sc.G[i][at];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) gp[i] = sc.g[i][at];
  schur_update([&](int r, int i) { return prev.U[ui(r, i)][l]; }, [&](int r, int j) { return Gp[6 * r + j]; }, gp,
               A, y);
}

// Fixed unknowns (zero inverse mass): u = 0 (kLift: their prescribed value,
// already in y), decoupled (identity rows).
template <int W, class T, bool kLift = false>
MANYRODS_HD inline void fix_lane(int l, const Cell<T, W>& cur, T (&A)[21], T (&y)[6]) {
  bool fixed[6];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) fixed[i] = cur.minv[i < 3 ? 0 : i - 2][l] == T(0);
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) {
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < i; ++j) A[lt(i, j)] = fixed[i] | fixed[j] ? T(0) : A[lt(i, j)];
    A[lt(i, i)] = fixed[i] ? T(1) : A[lt(i, i)];
    if constexpr (!kLift) y[i] = fixed[i] ? T(0) : y[i];
  }
}

// Cholesky Â = L Lᵀ in place (lower triangle), keeping 1/L_jj on the diagonal.
template <class T>
MANYRODS_HD inline void factor_lane(T (&A)[21]) {
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
}

// x = L⁻¹ x with the factor of factor_lane; x's entries above row r0 are
// zero (and stay zero).
template <int r0 = 0, class T>
MANYRODS_HD inline void forward_lane(const T (&A)[21], T (&x)[6]) {
  MANYRODS_UNROLL_ALL
  for (int i = r0; i < 6; ++i) {
    T v = x[i];
    MANYRODS_UNROLL_ALL
    for (int r = r0; r < i; ++r) v -= A[lt(i, r)] * x[r];
    x[i] = v * A[lt(i, i)];
  }
}

// x = L⁻ᵀ x.
template <class T>
MANYRODS_HD inline void backward_lane(const T (&A)[21], T (&x)[6]) {
  MANYRODS_UNROLL_ALL
  for (int i = 5; i >= 0; --i) {
    T v = x[i];
    MANYRODS_UNROLL_ALL
    for (int r = i + 1; r < 6; ++r) v -= A[lt(r, i)] * x[r];
    x[i] = v * A[lt(i, i)];
  }
}

// x = L⁻ᵀ L⁻¹ x = Â⁻¹ x (x's entries above row r0 zero).
template <int r0 = 0, class T>
MANYRODS_HD inline void solve_lane(const T (&A)[21], T (&x)[6]) {
  forward_lane<r0>(A, x);
  backward_lane(A, x);
}

// U_c's columns through the factor into the scratch at `at` (column j of U,
// and of L⁻¹U, is zero above row u_row0(j)): kZ, Z_c = L⁻¹U_c, its 27
// entries at G[ui(i, j)]; otherwise G_c = Â⁻¹U_c, row-major.
template <bool kZ, int W, class T>
MANYRODS_HD inline void solve_u_lane(int l, int at, const T (&A)[21], const Cell<T, W>& cur,
                                     const ImplicitScratchView<T>& sc) {
  MANYRODS_UNROLL_ALL
  for (int j = 0; j < 6; ++j) {
    T x[6];
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 6; ++i) x[i] = i < u_row0(j) ? T(0) : cur.U[ui(i, j)][l];
    if (j < 3)
      forward_lane<0>(A, x);
    else
      forward_lane<3>(A, x);
    if constexpr (!kZ) backward_lane(A, x);
    MANYRODS_UNROLL_ALL
    for (int i = kZ ? u_row0(j) : 0; i < 6; ++i) sc.G[kZ ? ui(i, j) : 6 * i + j][at] = x[i];
  }
}

// The elimination with Z_c = L⁻¹U_c (eliminate_lane): with Â_c = L Lᵀ,
// Z_c = L⁻¹ U_c and z_c = L⁻¹ ŷ_c,
//   Â_{c+1} = A_{c+1} − Z_cᵀ Z_c,  ŷ_{c+1} = y_{c+1} − Z_cᵀ z_c,
//   u_c = L⁻ᵀ (z_c − Z_c u_{c+1}),
// the same system as G_c = Â_c⁻¹ U_c = L⁻ᵀ Z_c, without the backward solves
// of G's six columns: 1,014 FLOP per rod and cell against 1,248 (bench/
// flop_count.cpp), at the price of keeping L for the back substitution
// (bench/RESULTS.md "The lane solve eliminates with L⁻¹U").
// Z_c has U_c's zero block (L⁻¹ is lower triangular and keeps column j's
// zeros above u_row0(j)): its 27 entries are stored at G[ui(i, j)], the
// factor at L, z_c at g.

// Â = A − Z_{c−1}ᵀ Z_{c−1} (lower triangle), ŷ = y − Z_{c−1}ᵀ z_{c−1}, from the
// scratch at `at` (cell c−1, lane l); for j ≤ i, Z's columns i and j share
// the rows r ≥ u_row0(i).
template <class T>
MANYRODS_HD inline void schur_z_lane(int at, const ImplicitScratchView<T>& sc, T (&A)[21], T (&y)[6]) {
  T Z[27], z[6];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 27; ++i) Z[i] = sc.G[i][at];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) z[i] = sc.g[i][at];
  auto col = [&](int r, int i) { return Z[ui(r, i)]; };
  schur_update(col, col, z, A, y);
}

// Elimination and factorization of cell c of lane l (after assemble_lane):
//   Â = A − Z_{c−1}ᵀ Z_{c−1},  ŷ = y − Z_{c−1}ᵀ z_{c−1}  (c > 0),
// fixed unknowns → identity rows, Â = L Lᵀ, z_c = L⁻¹ŷ, Z_c = L⁻¹U_c (not for
// the last cell), stored in the scratch with L.
// kKeep: the factors also kept for more right-hand sides (kernels/
// viscous_implicit.h kKeepValues: Â_c's factor, U_c, the inverse masses).
template <bool kFirst, bool kLast, int W, class T, bool kKeep = false, bool kLift = false>
MANYRODS_HD inline void eliminate_lane(int l, int c, const Cell<T, W>& cur, const ImplicitScratchView<T>& sc,
                                       T* const* keep = nullptr) {
  T A[21], y[6];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 21; ++i) A[i] = cur.A[i][l];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) y[i] = cur.y[i][l];
  if constexpr (!kFirst) schur_z_lane((c - 1) * W + l, sc, A, y);
  fix_lane<W, T, kLift>(l, cur, A, y);
  factor_lane(A);
  forward_lane(A, y);
  const int at = c * W + l;
  if constexpr (kKeep) {
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 21; ++i) keep[kKeepL + i][at] = A[i];
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 27; ++i) keep[kKeepU + i][at] = kLast ? T(0) : cur.U[i][l];
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 4; ++i) keep[kKeepMinv + i][at] = cur.minv[i][l];
  }
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 21; ++i) sc.L[i][at] = A[i];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) sc.g[i][at] = y[i];
  if constexpr (!kLast) solve_u_lane<true>(l, at, A, cur, sc);
}

// Back substitution for cell c of lane l: u_c = L⁻ᵀ (z_c − Z_c u_{c+1})
// (kLast: u_c = L⁻ᵀ z_c), written over z_c.
template <bool kLast, int W, class T>
MANYRODS_HD inline void back_z_lane(int l, int c, T (&next)[6][W], const ImplicitScratchView<T>& sc) {
  const int at = c * W + l;
  T x[6], L[21];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 21; ++i) L[i] = sc.L[i][at];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) {
    T v = sc.g[i][at];
    if constexpr (!kLast) {
      MANYRODS_UNROLL_ALL
      for (int j = 0; j < 6; ++j)
        if (i >= u_row0(j)) v -= sc.G[ui(i, j)][at] * next[j][l];
    }
    x[i] = v;
  }
  backward_lane(L, x);
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) {
    sc.g[i][at] = x[i];
    next[i][l] = x[i];
  }
}

// kKeep, after the back substitution: G_c = Â_c⁻¹ U_c = L⁻ᵀ Z_c over Z_c
// in the scratch at `at` (all 36 entries, row-major), for the kept
// factors' solves (viscous_solve_factored_lanes). The columns are computed
// as solve_lane computes them from U_c's (forward, then backward).
template <class T>
MANYRODS_HD inline void expand_g_lane(int at, const ImplicitScratchView<T>& sc) {
  T L[21], Z[27];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 21; ++i) L[i] = sc.L[i][at];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 27; ++i) Z[i] = sc.G[i][at];
  MANYRODS_UNROLL_ALL
  for (int j = 0; j < 6; ++j) {
    T x[6];
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 6; ++i) x[i] = i < u_row0(j) ? T(0) : Z[ui(i, j)];
    backward_lane(L, x);
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 6; ++i) sc.G[6 * i + j][at] = x[i];
  }
}

// dst[c·W + l] = src[l][c] for c in [c0, c1): a W × cells transpose, written
// so that the compiler vectorizes it along c with contiguous loads, in-register
// permutes and contiguous stores (gathers would cost several times more).
template <int W, class D, class S>
MANYRODS_HD inline void pack_lanes(D* dst, const S* const (&src)[W], int c0, int c1) {
  for (int c = c0; c < c1; ++c) {
    MANYRODS_UNROLL_ALL
    for (int l = 0; l < W; ++l) dst[c * W + l] = D(src[l][c]);
  }
}
// dst[l][c] = src[c·W + l] for c in [c0, c1): the inverse.
template <int W, class D, class S>
MANYRODS_HD inline void unpack_lanes(D* const (&dst)[W], const S* src, int c0, int c1) {
  for (int c = c0; c < c1; ++c) {
    MANYRODS_UNROLL_ALL
    for (int l = 0; l < W; ++l) dst[l][c] = D(src[c * W + l]);
  }
}

// The packed value of a cell before a lane's rod starts (see
// viscous_implicit_lanes): at rest, no stiffness, identity frame, unit
// lengths, zero inverse masses (every unknown fixed).
template <class T>
MANYRODS_HD inline T idle_value(int a) {
  if (a == kQ || a == kQ + 4 || a == kQ + 8 || a == kL || a == kD) return T(1);
  return T(0);
}

// Stage 0 of the lane kernels: the kPacked per-cell inputs of W lanes into
// P (value a of group cell c, lane l at P[a][c·W + l]); lane l's cell c is
// slot base[l] + c, for c in [0, n); its cells before lead[l] are idle
// (idle_value), and from lead_all on every lane's cells are real.
template <int W, class T, class Tc>
MANYRODS_HD inline void pack_inputs(const ModelView<T>& mv, const ConstStateView<T>& cs, const int* base,
                                    const int* lead, int lead_all, int n, Tc* const* P) {
  const T* const in[kPacked] = {
      cs.node_x[0],        cs.node_x[1],        cs.node_x[2],        cs.node_v[0],        cs.node_v[1],
      cs.node_v[2],        cs.elem_w[0],        cs.elem_w[1],        cs.elem_w[2],        cs.elem_Q[0],
      cs.elem_Q[1],        cs.elem_Q[2],        cs.elem_Q[3],        cs.elem_Q[4],        cs.elem_Q[5],
      cs.elem_Q[6],        cs.elem_Q[7],        cs.elem_Q[8],        mv.elem_rest_length, mv.elem_stiffness[0],
      mv.elem_stiffness[1], mv.elem_stiffness[2], mv.elem_tau[0],    mv.elem_tau[1],      mv.elem_tau[2],
      mv.vor_rest_length,  mv.vor_stiffness[0], mv.vor_stiffness[1], mv.vor_stiffness[2], mv.vor_tau[0],
      mv.vor_tau[1],       mv.vor_tau[2],       mv.node_mass,        mv.elem_inertia[0],  mv.elem_inertia[1],
      mv.elem_inertia[2],  mv.node_inv_mass,    mv.elem_inv_inertia[0], mv.elem_inv_inertia[1],
      mv.elem_inv_inertia[2]};
  for (int a = 0; a < kPacked; ++a) {
    const T* src[W];
    for (int l = 0; l < W; ++l) src[l] = in[a] + base[l];
    pack_lanes<W>(P[a], src, lead_all, n);
    for (int c = 0; c < lead_all; ++c)  // lanes not yet in their rods
      for (int l = 0; l < W; ++l) P[a][c * W + l] = c >= lead[l] ? Tc(src[l][c]) : idle_value<Tc>(a);
  }
}

}  // namespace lanes_detail

// Backward-Euler viscous update of W rods, rod l with cells[l] cells at
// slots [first[l], first[l] + cells[l]) — what viscous_implicit_rod does for
// each of them, to round-off. stiff_h[l]: h for a stiff rod, 0 otherwise (see
// kernels/viscous_implicit.h). Velocities in `s` are u⁻ on entry, u⁺ on exit.
// `sc` holds 42·W·(max(cells) + 1) values (see the header). Two lanes may
// hold the same rod (to fill a group): they compute the same values and write
// them to the same slots, after every read.
//
// The group runs n = max(cells) + 1 cells, the rods aligned at their tips:
// lane l's cell j is the group's cell c = n − cells[l] + j. Before its rod
// starts, every lane runs at least one cell whose unknowns are all fixed
// (identity rows, no coupling): its rod's root ghost slot (clamp frame, zero
// stiffness and masses), whose joint to the next cell is the rod's root joint,
// and before that, for shorter rods, idle cells (idle_value). Each rod's own
// cells therefore see the same arithmetic in any group (the root joint's
// block always arrives through the ghost cell, with exact zeros around it):
// a rod's result does not depend on the group it is in, bit for bit
// (tests/test_implicit_lanes.cpp). The ghost cell costs 1/cells of the work.
//
// Stages, each a loop over the lanes:
//   0. pack: the 40 per-cell inputs of the W rods (node x, v; element ω, Q,
//      l̂, C_F, τ; joint D̂, C_M, τ; masses and inverse masses) are transposed
//      into the elimination buffer, value a of cell c at P[a][c·W + l] (G's
//      36 arrays and 4 of g's; cell c's inputs are read by cells c and c−1
//      before cell c's G and g overwrite them);
//   1. per cell, forwards: assemble (small-rotation path; flagged lanes again
//      with the general path), eliminate, factor; Z_c, z_c and the factor;
//   2. per cell, backwards: u_c over z_c; then unpacked into node_v, elem_w
//      (kKeep: and G_c over Z_c, which the contacts' solves reuse).
//
// Tc: the precision of the solve (the buffer's), T otherwise: a float batch's
// stiff rods are solved in double (Tc = double). Their system (M + h D)
// with the stiffness in D is ill-conditioned (h²ω² ≈ 10⁵ for the stretch
// and shear modes of hair at frame-rate steps): a float elimination leaves an
// error of about ε·h²ω²·|u| in the slow (bending, swinging) modes, which
// builds up to a different motion within a second. In double only the
// packing reads floats and the unpacking rounds u⁺ to float once
// (bench/RESULTS.md "Float stiff rods").
//
// kKeep: the factors are also kept in `keep` (kKeepValues arrays of W·n
// values, the layout of kKeepValues in kernels/viscous_implicit.h) for more
// right-hand sides (the contacts of kernels/contact_solve.h). kLift: the
// fixed unknowns keep their prescribed values (see the header).
template <Terms kT, int W, bool kKeep = false, bool kLift = false, class T, class Tc>
MANYRODS_HD inline void viscous_implicit_lanes(const int* first, const int* cells, T h, const T* stiff_h,
                                               const ModelView<T>& m, const StateView<T>& s,
                                               const ImplicitScratchView<Tc>& sc, Tc* const* keep = nullptr) {
  using namespace lanes_detail;
  // Local copies of the views: no store in the lane loops can alias them, so
  // their pointers stay in registers (as in host/core/step/launch.h).
  const ModelView<T> mv = m;
  const ConstStateView<T> cs = as_const(s);
  const ImplicitScratchView<Tc> scv = sc;
  Tc* P[42];
  for (int i = 0; i < 36; ++i) P[i] = scv.G[i];
  for (int i = 0; i < 6; ++i) P[36 + i] = scv.g[i];
  int f[W], start[W];  // first slot; group cell of the rod's cell 0
  Tc sh[W];
  const Tc hc = Tc(h);
  // n: the longest rod's cells plus its root ghost cell
  int n = 0;
  for (int l = 0; l < W; ++l) n = cells[l] > n ? cells[l] : n;
  n += 1;
  int all_real = 0;  // from this cell on, every lane is in its rod
  for (int l = 0; l < W; ++l) {
    f[l] = first[l];
    sh[l] = Tc(stiff_h[l]);
    start[l] = n - cells[l];  // ≥ 1
    all_real = start[l] > all_real ? start[l] : all_real;
  }
  const int all_started = all_real - 1;  // … or in its root ghost slot
  // 0. pack: group cell c of lane l is slot f[l] − start[l] + c
  {
    int base[W], lead[W];
    for (int l = 0; l < W; ++l) base[l] = f[l] - start[l], lead[l] = start[l] - 1;
    pack_inputs<W>(mv, cs, base, lead, all_started, n, P);
  }
  Cell<Tc, W> cell[2];  // cell c in cell[c & 1], its predecessor in the other
  auto any_general = [](const Cell<Tc, W>& x) {
    int any = 0;
    for (int l = 0; l < W; ++l) any |= x.general[l];
    return any != 0;
  };
  for (int i = 0; i < 12; ++i)  // nothing is carried into cell 0 (idle or root ghost in every lane)
    for (int l = 0; l < W; ++l) cell[1].carry[i][l] = Tc(0);
  if constexpr (kLift)
    for (int i = 0; i < 6; ++i)
      for (int l = 0; l < W; ++l) cell[1].lift[i][l] = Tc(0);
  // 1. forward elimination
  for (int c = 0; c < n; ++c) {
    const Cell<Tc, W>& prev = cell[(c + 1) & 1];
    Cell<Tc, W>& cur = cell[c & 1];
    if (c + 1 < n) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) assemble_lane<kT, true, false, W, Tc, kLift>(l, c, hc, sh[l], P, prev, cur);
      if (any_general(cur))
        for (int l = 0; l < W; ++l)
          if (cur.general[l]) assemble_lane<kT, false, false, W, Tc, kLift>(l, c, hc, sh[l], P, prev, cur);
    } else {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) assemble_lane<kT, true, true, W, Tc, kLift>(l, c, hc, sh[l], P, prev, cur);
    }
    if (c == 0 && c + 1 < n) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_lane<true, false, W, Tc, kKeep, kLift>(l, c, cur, scv, keep);
    } else if (c == 0) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_lane<true, true, W, Tc, kKeep, kLift>(l, c, cur, scv, keep);
    } else if (c + 1 < n) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_lane<false, false, W, Tc, kKeep, kLift>(l, c, cur, scv, keep);
    } else {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_lane<false, true, W, Tc, kKeep, kLift>(l, c, cur, scv, keep);
    }
  }
  // 2. back substitution, then u⁺ out to the rods (their own cells only)
  Tc next[6][W];
  MANYRODS_LANES
  for (int l = 0; l < W; ++l) back_z_lane<true>(l, n - 1, next, scv);
  for (int c = n - 2; c >= 0; --c) {
    MANYRODS_LANES
    for (int l = 0; l < W; ++l) back_z_lane<false>(l, c, next, scv);
  }
  if constexpr (kKeep)
    for (int c = 0; c + 1 < n; ++c) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) expand_g_lane(c * W + l, scv);
    }
  for (int d = 0; d < 6; ++d) {
    T* const base = d < 3 ? s.node_v[d] : s.elem_w[d - 3];
    T* dst[W];
    for (int l = 0; l < W; ++l) dst[l] = base + (f[l] - start[l]);
    unpack_lanes<W>(dst, scv.g[d], all_real, n);
    for (int c = 0; c < all_real; ++c)
      for (int l = 0; l < W; ++l)
        if (c >= start[l]) dst[l][c] = T(scv.g[d][c * W + l]);
  }
}

// x ← A⁻¹ x for `cols` right-hand sides of each of the W rods of a lane
// group at once, with the factors the lane kernel kept (kKeep: keep, and G
// in the scratch; or viscous_implicit_rod's, W = 1), the elimination of the
// solve on other right-hand sides,
//   forward:  ŷ_c = y_c − U_{c−1}ᵀ g_{c−1} (fixed unknowns 0), g_c = Â_c⁻¹ ŷ_c,
//   back:     u_c = g_c − G_c u_{c+1},
// with the lanes innermost, so that each load of the factors serves every
// lane (the contacts' columns of kernels/contact_solve.h, one rod per lane).
// x holds group cell c's unknown i of column j of lane l at
// x[((6c + i)·cols + j)·W + l]. A lane whose right-hand side is zero up to a
// cell keeps exact zeros there, so the solve may start at the first lane's
// first nonzero cell `from` (cells before it must hold zeros); the back
// substitution stops at group cell `to`. Each lane's result on its rod's
// cells is that of solving its rod alone: idle and ghost cells hold zeros
// (their unknowns are fixed).
// reads: keep, G (the kept factors)  writes: x
template <int cols, int W, class Tc, class X>
MANYRODS_HD inline void viscous_solve_factored_lanes(Tc* const* keep, Tc* const* G, int n, int from, int to, X* x) {
  using namespace viscous_detail;
  constexpr int S = cols * W;  // one unknown's columns of every lane
  for (int c = from; c < n; ++c) {
    const int at = c * W;
    X* y = x + std::ptrdiff_t(6 * c) * S;
    if (c > from) {  // ŷ_c = y_c − U_{c−1}ᵀ g_{c−1}
      const X* gp = y - 6 * S;
      for (int i = 0; i < 6; ++i)
        for (int r = u_row0(i); r < 6; ++r) {
          const Tc* u = keep[kKeepU + ui(r, i)] + (c - 1) * W;
          for (int j = 0; j < cols; ++j) {
            MANYRODS_LANES
            for (int l = 0; l < W; ++l) y[i * S + j * W + l] -= X(u[l]) * gp[r * S + j * W + l];
          }
        }
    }
    // L Lᵀ z = y (1/L_ii on L's diagonal); fixed unknowns: 0 (each lane's
    // terms in the one-rod solve's order)
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 6; ++i) {
      const Tc* minv = keep[kKeepMinv + (i < 3 ? 0 : i - 2)] + at;
      const Tc* id = keep[kKeepL + lt(i, i)] + at;
      for (int j = 0; j < cols; ++j) {
        X* yi = y + i * S + j * W;
        MANYRODS_LANES
        for (int l = 0; l < W; ++l) yi[l] = minv[l] == Tc(0) ? X(0) : yi[l];
        MANYRODS_UNROLL_ALL
        for (int r = 0; r < i; ++r) {
          const Tc* Lir = keep[kKeepL + lt(i, r)] + at;
          const X* yr = y + r * S + j * W;
          MANYRODS_LANES
          for (int l = 0; l < W; ++l) yi[l] -= X(Lir[l]) * yr[l];
        }
        MANYRODS_LANES
        for (int l = 0; l < W; ++l) yi[l] *= X(id[l]);
      }
    }
    MANYRODS_UNROLL_ALL
    for (int i = 5; i >= 0; --i) {
      const Tc* id = keep[kKeepL + lt(i, i)] + at;
      for (int j = 0; j < cols; ++j) {
        X* yi = y + i * S + j * W;
        MANYRODS_UNROLL_ALL
        for (int r = i + 1; r < 6; ++r) {
          const Tc* Lri = keep[kKeepL + lt(r, i)] + at;
          const X* yr = y + r * S + j * W;
          MANYRODS_LANES
          for (int l = 0; l < W; ++l) yi[l] -= X(Lri[l]) * yr[l];
        }
        MANYRODS_LANES
        for (int l = 0; l < W; ++l) yi[l] *= X(id[l]);
      }
    }
  }
  // u_c = g_c − G_c u_{c+1}
  for (int c = n - 2; c >= to; --c) {
    const int at = c * W;
    X* u = x + std::ptrdiff_t(6 * c) * S;
    const X* un = u + 6 * S;
    for (int i = 0; i < 6; ++i)
      for (int k = 0; k < 6; ++k) {
        const Tc* g = G[6 * i + k] + at;
        for (int j = 0; j < cols; ++j) {
          MANYRODS_LANES
          for (int l = 0; l < W; ++l) u[i * S + j * W + l] -= X(g[l]) * un[k * S + j * W + l];
        }
      }
  }
}

}  // namespace manyrods
