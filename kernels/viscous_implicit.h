// kernels/viscous_implicit.h — the Kelvin–Voigt force integrated implicitly,
// so that the stable step does not depend on τ (docs/model.md "Kelvin–Voigt
// in time: explicit rates or implicit backward Euler").
//
// The viscous force is linear in the velocities u = (v, ω) at fixed geometry:
// with the strain-rate maps σ̇_k = B_k u (element k) and κ̇_k = C_k u
// (Voronoi k, see kernels/strains.h),
//   B_k = [ −Q/l̂ (v_k),  [Qe]×/l̂ (ω_k),  Q/l̂ (v_{k+1}) ]
//   C_k = [ −J_r(ψ)⁻¹/D̂ (ω_{k−1}),  J_r(ψ)⁻¹Rᵀ/D̂ (ω_k) ]
// the viscous generalized force is −D u with the symmetric, positive
// semi-definite "viscous stiffness"
//   D = Σ_k l̂ B_kᵀ V_F B_k + Σ_k D̂ C_kᵀ V_M C_k,
// i.e. exactly minus the gradient of the dissipation function D_v (seed
// eq. 11) with respect to u: uᵀ D u = 2·D_v.
//
// After the explicit elastic kick u⁻ = u + h M⁻¹ F_elastic, the viscous part
// is a backward-Euler step at the frozen (half-step) geometry:
//   (M + h D) u⁺ = M u⁻,  solved in delta form (M + h D) Δu = −h D u⁻.
// Its amplification is (I + h M⁻¹D)⁻¹: every mode decays, for any h and τ
// (L-stable), so τ no longer limits the step; the price is first-order
// accuracy in the viscous term (as the explicit lagged rate) and the
// over-damping of modes with h τ ω² ≳ 1, which the explicit scheme could not
// step at all.
//
// Per rod, ordering the unknowns by cells c = 0 … n (cell c = node c and
// element c; the tip cell's element is the tip ghost), D is block
// tridiagonal with 6×6 blocks: element k couples cells k and k+1, Voronoi k
// couples cells k−1 and k. The system is solved by block Thomas elimination
// with 6×6 Cholesky factors, one rod per call: data-parallel over rods.
// Fixed unknowns (clamped node, ghost element) keep their values (0, or a
// driven hold's prescribed velocity: the direct form lifts them to the
// right-hand side, below); a driven root's prescribed velocities enter
// through rigid_shift (below).
//
// Stiff rods (RodSpec::stiff_implicit, "frame-rate hair"): the same solve
// also integrates the elastic STIFFNESS linearly implicitly, so that no
// elastic mode limits the step.
//  - Shear, stretch and twist (the stiff components): for a stiffness
//    K_s = Σ l̂ B_kᵀ C_s B_k, backward Euler on the elastic force at the end
//    of the kick, F_s(x + h u⁺) ≈ F_s(x) − h K_s u⁺, adds exactly the
//    viscous form above with τ replaced by β h, β = 1 (`stiff_h` = h). For
//    one mode of frequency ω (Position Verlet drift–kick–drift with the
//    force explicit and −β h² ω² u⁺ implicit) the spectral radius tends to 0
//    as hω → ∞ for β = 1: the unresolved shear/stretch/twist oscillations are
//    annihilated and those strains follow their quasi-static values (the
//    inextensible, unshearable limit). The added damping acts on the stiff
//    strain RATES only: a slowly varying stretch or shear (rate σ̇ ≪ σ/h) is
//    disturbed by O(h σ̇), first order in h but small.
//  - Bending, the motion that matters, must not be damped at first order
//    (backward Euler on bending takes 2·10⁻² L off a swinging hair even at
//    h = 10⁻⁴ s, bench/RESULTS.md). The bending force is evaluated instead
//    at x_{n+½} + c h (u⁺ − u_n), linearized:
//      F_b(x_{n+½}) − c h K_b (u⁺ − u_n),
//    i.e. c h added to the joints' bending τ here and −c h K_b u_n in the
//    kick (kernels/internal_forces.h: the bending moment carries
//    −c h C_M U̇ at the start-of-step rates, at the same half-step geometry,
//    so that both parts use one K_b). Since u⁺ − u_n = O(h) the correction
//    is O(h³) per step: the scheme stays second order. For one mode
//    (a = hω, scaled x): the step matrix has determinant exactly 1 and trace
//    2 − a²/(1 + c a²), so it is stable for every hω once c ≥ ¼, undamped
//    (c = ¼ evaluates the force at (x_n + x_{n+1})/2, the implicit midpoint
//    rule), and an unresolved mode (a → ∞) turns by arccos(1 − 1/(2c)) per
//    step, π for c = ¼. c = kStiffBendingC = 0.3 (131.8°): at c = ¼ an
//    undamped hair released horizontal goes unstable at 1/240 s (its
//    whipping tip turns by radians per step; the period-2 ringing of the
//    unresolved modes feeds the nonlinear coupling), at 0.3 it stays
//    bounded at every step measured, for 1.15× the error of c = ¼ on the
//    damped hair (bench/RESULTS.md "Stiff rods: bending in the solve").
//  The stable step of a stiff rod is then set by its explicit parts only
//  (none for a rod alone); its step is an accuracy choice (stable_dt's
//  `accuracy`).
//
// reads: model, state geometry and velocities  writes: node_v, elem_w of the
// rod, and the elimination scratch G (36 per cell) and g (6 per cell), indexed
// by the rod's cell c = 0 … cells−1 (the host passes a per-thread buffer); with
// `keep`, the factors (kKeepValues, below)
#pragma once

#include <cstddef>

#include "kernels/resultants.h"
#include "kernels/strains.h"

namespace manyrods {

// Stiff rods' bending (see the file comment): the solve adds c·h to the
// joints' bending retardation times and the kick's bending moment carries
// −c·h times the start-of-step bending rate, c = kStiffBendingC.
inline constexpr double kStiffBendingC = 0.3;

namespace viscous_detail {

// Lower triangle of a symmetric 6×6, row by row: (i, j), j ≤ i.
MANYRODS_HD constexpr int lt(int i, int j) { return i >= j ? i * (i + 1) / 2 + j : j * (j + 1) / 2 + i; }
// U's 27 stored entries: (i, j) unless i < 3 ≤ j (the zero block v_c–ω_{c+1}).
MANYRODS_HD constexpr int ui(int i, int j) {
  return i < 3 ? 3 * i + j : (j < 3 ? 9 + 3 * (i - 3) + j : 18 + 3 * (i - 3) + j - 3);
}
// First row of U's column j that is not structurally zero.
MANYRODS_HD constexpr int u_row0(int j) { return j >= 3 ? 3 : 0; }

template <class T>
struct Block6 {
  T a[36];
};

// Adds s · Xᵀ W Y (X, Y 3×3, W diagonal) into block b at (row0, col0).
template <class T>
MANYRODS_HD inline void add_xtwy(Block6<T>& b, int row0, int col0, const mat3<T>& x, vec3<T> w,
                                 const mat3<T>& y, T s) {
  const T ww[3] = {w.x, w.y, w.z};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      T acc = T(0);
      for (int l = 0; l < 3; ++l) acc += x.m[3 * l + i] * ww[l] * y.m[3 * l + j];
      b.a[6 * (row0 + i) + col0 + j] += s * acc;
    }
}

// In-place Cholesky of an SPD 6×6 (lower triangle used).
template <class T>
MANYRODS_HD inline void cholesky6(Block6<T>& l) {
  for (int j = 0; j < 6; ++j) {
    T d = l.a[6 * j + j];
    for (int k = 0; k < j; ++k) d -= l.a[6 * j + k] * l.a[6 * j + k];
    using std::sqrt;  // unqualified: see kernels/math.h norm
    d = sqrt(d);
    l.a[6 * j + j] = d;
    for (int i = j + 1; i < 6; ++i) {
      T v = l.a[6 * i + j];
      for (int k = 0; k < j; ++k) v -= l.a[6 * i + k] * l.a[6 * j + k];
      l.a[6 * i + j] = v / d;
    }
  }
}

template <class T>
MANYRODS_HD inline void cholesky6_solve(const Block6<T>& l, T* x) {
  for (int i = 0; i < 6; ++i) {
    T v = x[i];
    for (int k = 0; k < i; ++k) v -= l.a[6 * i + k] * x[k];
    x[i] = v / l.a[6 * i + i];
  }
  for (int i = 5; i >= 0; --i) {
    T v = x[i];
    for (int k = i + 1; k < 6; ++k) v -= l.a[6 * k + i] * x[k];
    x[i] = v / l.a[6 * i + i];
  }
}

// The retardation times in the solve: τ if the Kelvin–Voigt term is solved
// here (kT.kelvin_voigt), plus, for a stiff rod (stiff_h = h), h on the
// stiff components (shear and stretch of an element, twist of a joint) and
// c·h on a joint's bending (kStiffBendingC).
template <Terms kT, class T>
MANYRODS_HD inline vec3<T> solve_tau(const T* const tau[3], int k, T stiff_h, bool joint) {
  const vec3<T> t = kT.kelvin_voigt ? load3(tau, k) : vec3<T>{T(0), T(0), T(0)};
  const T bend_h = joint ? T(kStiffBendingC) * stiff_h : stiff_h;
  return {t.x + bend_h, t.y + bend_h, t.z + stiff_h};
}

// Element k's viscous weight W = l̂ V_F and maps (b1, b2, b3) scaled by l̂.
template <Terms kT, class T>
MANYRODS_HD inline void element_maps(int k, T stiff_h, const ModelView<T>& m, const ConstStateView<T>& s,
                                     vec3<T>& w, mat3<T>& b1, mat3<T>& b2, mat3<T>& b3) {
  const ElementStrain<T> es = element_strain(k, m, s);
  const T l = m.elem_rest_length[k], il = T(1) / l;
  const vec3<T> c = load3(m.elem_stiffness, k), tau = solve_tau<kT>(m.elem_tau, k, stiff_h, false);
  w = {kT.shear ? l * c.x * tau.x : T(0), kT.shear ? l * c.y * tau.y : T(0),
       kT.stretch ? l * c.z * tau.z : T(0)};
  for (int i = 0; i < 9; ++i) {
    b3.m[i] = il * es.Q.m[i];
    b1.m[i] = -b3.m[i];
  }
  const mat3<T> sk = skew(es.Qe);
  for (int i = 0; i < 9; ++i) b2.m[i] = il * sk.m[i];
}

// Voronoi k's weight W = D̂ V_M and maps (c1 for ω_{k−1}, c2 for ω_k).
template <Terms kT, class T>
MANYRODS_HD inline void voronoi_maps(int k, T stiff_h, const ModelView<T>& m, const ConstStateView<T>& s,
                                     vec3<T>& w, mat3<T>& c1, mat3<T>& c2) {
  const VoronoiStrain<T> vs = voronoi_strain(k, m, s);
  const T d = m.vor_rest_length[k], id = T(1) / d;
  const vec3<T> c = load3(m.vor_stiffness, k), tau = solve_tau<kT>(m.vor_tau, k, stiff_h, true);
  w = {kT.bend ? d * c.x * tau.x : T(0), kT.bend ? d * c.y * tau.y : T(0),
       kT.twist ? d * c.z * tau.z : T(0)};
  const mat3<T> ji = inverse_right_jacobian(vs.psi, vs.gamma);
  const mat3<T> jirt = mul_transpose(ji, vs.R);
  for (int i = 0; i < 9; ++i) {
    c1.m[i] = -id * ji.m[i];
    c2.m[i] = id * jirt.m[i];
  }
}

}  // namespace viscous_detail

// Driven roots (include/manyrods/drive.h): node 0's velocity v₀ and the
// clamp frame's ω_g = Q_g Ω (the root ghost element, slot first − 1) are
// prescribed, non-zero unknowns, outside the cells the solve above runs
// over (the root joint takes the clamp frame at rest). They
// extend to a rigid velocity field of the whole rod,
//   ū: v̄_j = v₀ + Ω × (x_j − x₀),  ω̄_e = Q_e Ω  (material components),
// and a rigid motion strains nothing: D ū = 0 for the maps above, exactly
// (B_k ū = [Q(Ω × e) + (Qe) × (QΩ)]/l̂ = 0 and C_k ū = J⁻¹(Rᵀ Q_k − Q_{k−1})Ω/D̂
// = 0 with R = Q_k Q_{k−1}ᵀ). With u = ū + w the system becomes
// (M + hD) w⁺ = M w⁻ with w = 0 at the root: the solve of a clamped rod, on
// w. The host subtracts ū (sign −1), solves, and adds it back (sign +1),
// putting the root's own values back (host/core/step/implicit_solve.h viscous_update). Solving
// for w rather than moving D_fp u_p to the right-hand side also keeps the
// stiff rods' direct form from cancelling h²K v₀ against itself: a rod
// carried at v has w⁻ equal to the still rod's u⁻ up to round-off
// (tests/test_drive.cpp: the two agree to 1e-15 m).
// Nodes first … first + cells − 1 and their elements (not the tip ghost).
template <class T>
MANYRODS_HD inline void rigid_shift(int first, int cells, T sign, vec3<T> v0, vec3<T> omega, vec3<T> x0,
                                    const StateView<T>& s) {
  for (int c = 0; c < cells; ++c) {
    const int k = first + c;
    const vec3<T> v = v0 + cross(omega, load3(s.node_x, k) - x0);
    store3(s.node_v, k, load3(s.node_v, k) + sign * v);
    if (c + 1 < cells) store3(s.elem_w, k, load3(s.elem_w, k) + sign * mul(load_frame(s.elem_Q, k), omega));
  }
}

// Backward-Euler viscous update of one rod whose cells occupy slots
// [first, first + cells). Velocities in `s` are u⁻ on entry, u⁺ on exit.
// kT.kelvin_voigt: the Kelvin–Voigt term is solved here; stiff_h > 0: the
// shear, stretch and twist stiffness too (stiff rods, see above; 0 otherwise).
//
// `keep` (nullptr: not kept): the factors kept for more right-hand sides
// (kKeepValues below, W = 1, from cell 0).

// The factors of the elimination kept for more right-hand sides
// (kernels/viscous_implicit_lanes.h viscous_solve_factored_lanes; the
// contacts of kernels/contact_solve.h), as the
// lane kernel (viscous_implicit_lanes with kKeep) and viscous_implicit_rod
// (with `keep`) leave them: value a of group cell g, lane l, at
// keep[a][g·W + l], a = kKeepL + lt(i, j) the Cholesky factor of Â_g (lower
// triangle, 1/L_ii on the diagonal), kKeepU + ui(i, j) U_g (with the fixed
// unknowns' rows and columns zeroed), kKeepMinv + i the inverse node mass
// and element inertias (0: fixed unknowns); G_g in the scratch's G[·][g·W + l].
inline constexpr int kKeepL = 0, kKeepU = 21, kKeepMinv = 48, kKeepValues = 52;

template <Terms kT, class T>
MANYRODS_HD inline void viscous_implicit_rod(int first, int cells, T h, T stiff_h, const ModelView<T>& m,
                                             const StateView<T>& s, const ImplicitScratchView<T>& sc,
                                             T* const* keep = nullptr) {
  using namespace viscous_detail;
  const ConstStateView<T> cs = as_const(s);
  const bool delta = stiff_h == T(0);  // delta form (see below) for all but stiff rods
  Block6<T> carry;  // contributions to the next cell's diagonal block
  for (int i = 0; i < 36; ++i) carry.a[i] = T(0);
  Block6<T> u_prev;       // U_{c−1} as the elimination uses it (fixed rows and columns zeroed)
  Block6<T> coupled_prev;  // U_{c−1} in full: the right-hand side's coupling to cell c−1
  T g_prev[6] = {T(0), T(0), T(0), T(0), T(0), T(0)};
  T fixed_prev[6] = {T(0), T(0), T(0), T(0), T(0), T(0)};  // 1: cell c−1's unknown is fixed
  Block6<T> G_prev;
  for (int i = 0; i < 36; ++i) G_prev.a[i] = u_prev.a[i] = coupled_prev.a[i] = T(0);
  for (int c = 0; c < cells; ++c) {
    const int k = first + c;
    Block6<T> A = carry, U;
    for (int i = 0; i < 36; ++i) {
      carry.a[i] = T(0);
      U.a[i] = T(0);
    }
    // element k: cells k (v_k, ω_k) and k+1 (v_{k+1})
    vec3<T> w;
    mat3<T> b1, b2, b3;
    element_maps<kT>(k, stiff_h, m, cs, w, b1, b2, b3);
    add_xtwy(A, 0, 0, b1, w, b1, h);
    add_xtwy(A, 0, 3, b1, w, b2, h);
    add_xtwy(A, 3, 0, b2, w, b1, h);
    add_xtwy(A, 3, 3, b2, w, b2, h);
    add_xtwy(U, 0, 0, b1, w, b3, h);
    add_xtwy(U, 3, 0, b2, w, b3, h);
    add_xtwy(carry, 0, 0, b3, w, b3, h);
    // Voronoi k+1: cells k (ω_k) and k+1 (ω_{k+1})
    mat3<T> c1, c2;
    voronoi_maps<kT>(k + 1, stiff_h, m, cs, w, c1, c2);
    add_xtwy(A, 3, 3, c1, w, c1, h);
    add_xtwy(U, 3, 3, c1, w, c2, h);
    add_xtwy(carry, 3, 3, c2, w, c2, h);
    // the Voronoi point k (to the previous cell) was added through `carry`,
    // except at the root, where it joins the clamp frame (ω = 0)
    if (c == 0) {
      voronoi_maps<kT>(k, stiff_h, m, cs, w, c1, c2);
      add_xtwy(A, 3, 3, c2, w, c2, h);
    }
    // mass; fixed unknowns (zero inverse mass) become identity rows
    const T minv[6] = {m.node_inv_mass[k], m.node_inv_mass[k], m.node_inv_mass[k],
                       m.elem_inv_inertia[0][k], m.elem_inv_inertia[1][k], m.elem_inv_inertia[2][k]};
    const T mass[6] = {m.node_mass[k], m.node_mass[k], m.node_mass[k],
                       m.elem_inertia[0][k], m.elem_inertia[1][k], m.elem_inertia[2][k]};
    const T u[6] = {s.node_v[0][k], s.node_v[1][k], s.node_v[2][k],
                    s.elem_w[0][k], s.elem_w[1][k], s.elem_w[2][k]};
    // Delta form: (M + hD) Δu = −hD u⁻, u⁺ = u⁻ + Δu (the same solution as
    // (M + hD) u⁺ = M u⁻). The round-off of the elimination is then relative
    // to the viscous change Δu, not to u: in the direct form the system's
    // condition number (1 + hτω_max², ~400 for the seed cantilever at
    // τ = 0.02 s) times float's 6e-8 of u per step accumulates on every mode;
    // in delta form the slow modes, whose Δu is tiny, keep float's precision
    // (the measured effect: bench/RESULTS.md "Float against double"). hD u⁻
    // uses the assembled blocks: A_c u_c + U_{c−1}ᵀ u_{c−1} + U_c u_{c+1}.
    // Not for stiff rods (stiff_h > 0): there u⁻ holds the huge pre-solve
    // velocities of the stiff modes (h|ω⁻| ≫ 1) and Δu ≈ −u⁻ cancels them, so
    // u⁻ + Δu would lose every digit of u⁺; the direct form M u⁻ computes u⁺
    // itself. Fixed unknowns keep their values: Δu = 0 there in delta form;
    // in the direct form their prescribed values p (u⁻ on the fixed
    // unknowns, 0 elsewhere: non-zero for a driven hold besides the
    // reference one) move to the right-hand side, y = M u⁻ − hD p, and y = p
    // on their own rows (kernels/viscous_implicit_lanes.h kLift). Both use
    // the full coupling to cell c−1 (its fixed rows included).
    const int kp = c > 0 ? k - 1 : k, kn = k + 1;  // c = 0: U_{−1} = 0
    const T up[6] = {s.node_v[0][kp], s.node_v[1][kp], s.node_v[2][kp],
                     s.elem_w[0][kp], s.elem_w[1][kp], s.elem_w[2][kp]};
    const T un[6] = {s.node_v[0][kn], s.node_v[1][kn], s.node_v[2][kn],
                     s.elem_w[0][kn], s.elem_w[1][kn], s.elem_w[2][kn]};
    const T nmi[6] = {m.node_inv_mass[kn], m.node_inv_mass[kn], m.node_inv_mass[kn],
                      m.elem_inv_inertia[0][kn], m.elem_inv_inertia[1][kn], m.elem_inv_inertia[2][kn]};
    T y[6];
    for (int i = 0; i < 6; ++i) {
      const bool fixed = minv[i] == T(0);
      T acc = T(0);
      for (int j = 0; j < 6; ++j) {
        // delta: all of u⁻; direct: the fixed unknowns' values only
        const T uj = delta || minv[j] == T(0) ? u[j] : T(0);
        const T nj = delta || (c + 1 < cells && nmi[j] == T(0)) ? un[j] : T(0);
        const T pj = delta || fixed_prev[j] != T(0) ? up[j] : T(0);
        acc += A.a[6 * i + j] * uj + U.a[6 * i + j] * nj + coupled_prev.a[6 * j + i] * pj;
      }
      y[i] = delta ? (fixed ? T(0) : -acc) : (fixed ? u[i] : mass[i] * u[i] - acc);
    }
    for (int i = 0; i < 6; ++i) A.a[7 * i] += mass[i];
    // elimination: Â_c = A_c − U_{c−1}ᵀ G_{c−1},  ŷ_c = y_c − U_{c−1}ᵀ g_{c−1}
    for (int i = 0; i < 6; ++i) {
      for (int j = 0; j < 6; ++j) {
        T acc = T(0);
        for (int l = 0; l < 6; ++l) acc += u_prev.a[6 * l + i] * G_prev.a[6 * l + j];
        A.a[6 * i + j] -= acc;
      }
      T acc = T(0);
      for (int l = 0; l < 6; ++l) acc += u_prev.a[6 * l + i] * g_prev[l];
      y[i] -= acc;
    }
    for (int i = 0; i < 36; ++i) coupled_prev.a[i] = U.a[i];
    for (int i = 0; i < 6; ++i) {
      fixed_prev[i] = minv[i] == T(0) ? T(1) : T(0);
      if (minv[i] == T(0)) {  // fixed: u = y (0 or p), decoupled
        for (int j = 0; j < 6; ++j) A.a[6 * i + j] = A.a[6 * j + i] = T(0);
        A.a[7 * i] = T(1);
        for (int j = 0; j < 6; ++j) U.a[6 * i + j] = T(0);
      }
    }
    // the next cell's fixed unknowns: zero their columns of U
    if (c + 1 < cells)
      for (int j = 0; j < 6; ++j)
        if (nmi[j] == T(0))
          for (int i = 0; i < 6; ++i) U.a[6 * i + j] = T(0);
    cholesky6(A);
    if (keep) {
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j <= i; ++j) keep[kKeepL + lt(i, j)][c] = i == j ? T(1) / A.a[7 * i] : A.a[6 * i + j];
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j)
          if (i >= 3 || j < 3) keep[kKeepU + ui(i, j)][c] = U.a[6 * i + j];
      for (int i = 0; i < 4; ++i) keep[kKeepMinv + i][c] = minv[i < 1 ? 0 : i + 2];
    }
    cholesky6_solve(A, y);
    T col[6];
    for (int j = 0; j < 6; ++j) {
      for (int i = 0; i < 6; ++i) col[i] = U.a[6 * i + j];
      cholesky6_solve(A, col);
      for (int i = 0; i < 6; ++i) G_prev.a[6 * i + j] = col[i];
    }
    for (int i = 0; i < 36; ++i) {
      sc.G[i][c] = G_prev.a[i];
      u_prev.a[i] = U.a[i];
    }
    for (int i = 0; i < 6; ++i) {
      sc.g[i][c] = y[i];
      g_prev[i] = y[i];
    }
  }
  // back substitution: u_c = g_c − G_c u_{c+1}
  T next[6] = {T(0), T(0), T(0), T(0), T(0), T(0)};
  for (int c = cells - 1; c >= 0; --c) {
    const int k = first + c;
    T x[6];
    for (int i = 0; i < 6; ++i) {
      T v = sc.g[i][c];
      for (int j = 0; j < 6; ++j) v -= sc.G[6 * i + j][c] * next[j];
      x[i] = v;
    }
    for (int d = 0; d < 3; ++d) {  // delta form: u⁺ = u⁻ + Δu
      s.node_v[d][k] = delta ? s.node_v[d][k] + x[d] : x[d];
      s.elem_w[d][k] = delta ? s.elem_w[d][k] + x[3 + d] : x[3 + d];
    }
    for (int i = 0; i < 6; ++i) next[i] = x[i];
  }
}

}  // namespace manyrods
