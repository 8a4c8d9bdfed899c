// kernels/viscous_implicit_partitioned.h — the backward-Euler solve of
// kernels/viscous_implicit.h for ONE long rod, cut into partitions that run
// one per SIMD lane (and lane groups on several threads): a rod of 10⁴–10⁵
// elements no longer runs its chain of 6×6 eliminations on one scalar lane.
//
// The system (M + hD) u⁺ = M u⁻ is block tridiagonal over the rod's cells
// (kernels/viscous_implicit_lanes.h: A_c on the diagonal, U_c between cells c
// and c+1). Every k-th cell is a separator s_q; the cells between two
// separators are a partition's interior, eliminated independently of the
// other partitions with the first separator L = s_{q−1} as a bordered
// unknown (substructuring; Golub & Van Loan, "Matrix Computations", §4.5.4
// on block tridiagonal systems, and the SPIKE family of partitioned solvers,
// Polizzi & Sameh, Parallel Computing 32, 2006):
//   interior cell i (i = 1 … k−1) reads  U_{i−1}ᵀ u_{i−1} + A_i u_i + U_i u_{i+1} = y_i,
//   with u_0 = u_L and u_k = u_R (R = s_q). Forwards, from Â_1 = A_1,
//   F_1 = U_Lᵀ (the coupling of cell i to L):
//     g_i = Â_i⁻¹ ŷ_i,  G_i = Â_i⁻¹ U_i,  H_i = Â_i⁻¹ F_i,
//     S_L −= F_iᵀ H_i,  r_L −= F_iᵀ g_i          (L's diagonal and right side)
//     Â_{i+1} = A_{i+1} − U_iᵀ G_i,  ŷ_{i+1} = y_{i+1} − U_iᵀ g_i,  F_{i+1} = −U_iᵀ H_i,
//   from S_L = A_L, r_L = y_L (the part of L's row that the partition holds:
//   its mass, element s_{q−1} and joint s_{q−1}+1); at R (its carried block
//   A_R only: element R−1, joint R; the mass belongs to the next partition's
//   L, except at the rod's tip) the same update gives Â_R, ŷ_R and F_R.
//   Every partition therefore hands over (S_L, r_L, Â_R, ŷ_R, F_R).
// The separators' system — separator q's diagonal Â_R(q) + S_L(q+1), right
// side ŷ_R(q) + r_L(q+1), coupling F_R(q) to separator q−1 — is block
// tridiagonal with dense 6×6 blocks and one block per partition; it is solved
// serially (partitioned_reduced), and each partition then back-substitutes
//   u_i = g_i − G_i u_{i+1} − H_i u_L   (i = k−1 … 1, u_k = u_R).
// Exact in exact arithmetic; it agrees with the scalar kernel to round-off
// (tests/test_implicit_lanes.cpp). The partitions depend only on the rod's
// cell count and k, never on the thread count, so neither does the result.
//
// Cost: the bordering (H_i, S_L, F_{i+1}: about 600 multiply-adds per cell)
// roughly doubles the elimination's arithmetic; the reduced system is one
// block per k cells, serial.
//
// Layout: the rod's N cells (cell j at slot `first` + j; its root ghost at
// first − 1) in P = ⌈N/k⌉ partitions; the last N − (P−1)k = r cells
// (1 ≤ r ≤ k) are partition 0's: its separator R is cell r − 1 and
// partition q's R is cell r − 1 + qk (the tip for q = P − 1). Lane l of a
// group holds partition part[l] over the group cells c = 0 … k: c = 0 is its
// L, c = k its R, c ↔ slot r − 1 + (part − 1)k + c + first. Partition 0 runs
// k − r idle cells first (idle_value: all unknowns fixed, no coupling), then
// the root ghost (fixed, it carries the root joint) in place of an L.
//
// reads: model, state geometry and velocities of the rod
// writes: node_v, elem_w of its cells (interiors in partitioned_back, the
//   separators in partitioned_reduced), the scratch (PartitionScratchView)
#pragma once

#include "kernels/viscous_implicit_lanes.h"

namespace manyrods {

// Values a partition hands to the separators' system (per partition, [a][q]).
enum PartitionOut : int {
  kOutSL = 0,   // S_L, lower triangle (21)
  kOutRL = 21,  // r_L (6)
  kOutAR = 27,  // Â_R, lower triangle (21)
  kOutYR = 48,  // ŷ_R (6)
  kOutFR = 54,  // F_R, row-major (36): R's coupling to L
  kPartitionOut = 90
};

// The scratch of one lane group (G, g: as ImplicitScratchView, at [i][c·W + l];
// H: [36][c·W + l], c ≤ k) and the hand-over values of every partition of
// the rod ([kPartitionOut][parts]).
template <class T>
struct PartitionScratchView {
  ImplicitScratchView<T> e;
  T* H[36];
  T* out[kPartitionOut];
};

namespace partition_detail {

using namespace lanes_detail;

// Per-lane running values of the bordering: F (row-major, cell i's coupling
// to L), S_L (lower), r_L.
template <class T, int W>
struct Border {
  T F[36][W];
  T SL[21][W];
  T rL[6][W];
};

// Cell 0 (the separator L) of lane l: S_L = A_L, r_L = y_L, F_1 = U_Lᵀ.
template <int W, class T>
MANYRODS_HD inline void border_start_lane(int l, const Cell<T, W>& cur, Border<T, W>& b) {
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 21; ++i) b.SL[i][l] = cur.A[i][l];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) b.rL[i][l] = cur.y[i][l];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i)
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < 6; ++j) b.F[6 * i + j][l] = j < u_row0(i) ? T(0) : cur.U[ui(j, i)][l];
}

// F_{next} = −Uᵀ H (U's column i is zero above row u_row0(i)).
template <int W, class T>
MANYRODS_HD inline void border_carry_lane(int l, const Cell<T, W>& cur, const T (&H)[36], Border<T, W>& b) {
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i)
    MANYRODS_UNROLL_ALL
    for (int j = 0; j < 6; ++j) {
      T acc = T(0);
      MANYRODS_UNROLL_ALL
      for (int r = u_row0(i); r < 6; ++r) acc -= cur.U[ui(r, i)][l] * H[6 * r + j];
      b.F[6 * i + j][l] = acc;
    }
}

// Interior cell c of lane l (after assemble_lane): the block elimination
// with G_c = Â⁻¹U_c (schur_lane, solve_u_lane<false>; the one-rod lane
// kernel uses Z_c = L⁻¹U_c instead, but the bordering needs Â⁻¹; no Schur
// update at c = 1: L is not eliminated) plus the
// bordering: H_c = Â⁻¹F_c into the scratch, S_L −= FᵀH, r_L −= Fᵀg,
// F_{c+1} = −U_cᵀ H_c.
template <bool kFirst, int W, class T>
MANYRODS_HD inline void eliminate_border_lane(int l, int c, const Cell<T, W>& prev, const Cell<T, W>& cur,
                                              Border<T, W>& b, const PartitionScratchView<T>& sc) {
  T A[21], y[6];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 21; ++i) A[i] = cur.A[i][l];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) y[i] = cur.y[i][l];
  if constexpr (!kFirst) schur_lane(l, (c - 1) * W + l, prev, sc.e, A, y);
  fix_lane(l, cur, A, y);
  factor_lane(A);
  solve_lane(A, y);
  const int at = c * W + l;
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) sc.e.g[i][at] = y[i];
  solve_u_lane<false>(l, at, A, cur, sc.e);
  T H[36];
  MANYRODS_UNROLL_ALL
  for (int j = 0; j < 6; ++j) {
    T x[6];
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 6; ++i) x[i] = b.F[6 * i + j][l];
    solve_lane(A, x);
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 6; ++i) {
      H[6 * i + j] = x[i];
      sc.H[6 * i + j][at] = x[i];
    }
  }
  MANYRODS_UNROLL_ALL
  for (int j = 0; j < 6; ++j) {
    MANYRODS_UNROLL_ALL
    for (int t = 0; t <= j; ++t) {
      T acc = b.SL[lt(j, t)][l];
      MANYRODS_UNROLL_ALL
      for (int i = 0; i < 6; ++i) acc -= b.F[6 * i + j][l] * H[6 * i + t];
      b.SL[lt(j, t)][l] = acc;
    }
    T acc = b.rL[j][l];
    MANYRODS_UNROLL_ALL
    for (int i = 0; i < 6; ++i) acc -= b.F[6 * i + j][l] * y[i];
    b.rL[j][l] = acc;
  }
  border_carry_lane(l, cur, H, b);
}

// The separator R (cell k, after assemble_lane<kLast>): Â_R = A_R − U_{k−1}ᵀG_{k−1},
// ŷ_R, F_R = −U_{k−1}ᵀ H_{k−1} (carried in b.F by the last interior cell);
// with S_L and r_L into the hand-over values of partition q.
template <int W, class T>
MANYRODS_HD inline void border_end_lane(int l, int q, int k, const Cell<T, W>& prev, const Cell<T, W>& cur,
                                        const Border<T, W>& b, const PartitionScratchView<T>& sc) {
  T A[21], y[6];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 21; ++i) A[i] = cur.A[i][l];
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) y[i] = cur.y[i][l];
  schur_lane(l, (k - 1) * W + l, prev, sc.e, A, y);
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 21; ++i) {
    sc.out[kOutSL + i][q] = b.SL[i][l];
    sc.out[kOutAR + i][q] = A[i];
  }
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 6; ++i) {
    sc.out[kOutRL + i][q] = b.rL[i][l];
    sc.out[kOutYR + i][q] = y[i];
  }
  MANYRODS_UNROLL_ALL
  for (int i = 0; i < 36; ++i) sc.out[kOutFR + i][q] = b.F[i][l];
}

}  // namespace partition_detail

// Forward pass of the W partitions part[0 … W−1] of the rod whose cells start
// at slot `first`, `cells` of them, `parts` partitions of k cells (see the
// header; part[l] may repeat: a repeated lane computes and writes the same
// values). stiff_h: h for a stiff rod, 0 otherwise. `sc`: this group's
// scratch (78·W·(k + 1) values) and the rod's hand-over values.
//
// Stages, each a loop over the lanes:
//   0. pack the 40 per-cell inputs as viscous_implicit_lanes does (partition
//      0's idle cells: idle_value; R's mass and inertia zeroed but at the tip);
//   1. c = 0: assemble L, start the bordering;
//   2. c = 1 … k−1: assemble, eliminate with the bordering;
//   3. c = k: assemble R (its carried block), hand over.
template <Terms kT, int W, class T>
MANYRODS_HD inline void partitioned_forward(int first, int cells, int k, const int* part, T h, T stiff_h,
                                            const ModelView<T>& m, const StateView<T>& s,
                                            const PartitionScratchView<T>& sc) {
  using namespace lanes_detail;
  using namespace partition_detail;
  const ModelView<T> mv = m;
  const ConstStateView<T> cs = as_const(s);
  const PartitionScratchView<T> scv = sc;
  const int parts = (cells + k - 1) / k, r = cells - (parts - 1) * k;
  T* P[42];
  for (int i = 0; i < 36; ++i) P[i] = scv.e.G[i];
  for (int i = 0; i < 6; ++i) P[36 + i] = scv.e.g[i];
  int q[W], idle[W], base[W];  // partition; leading idle cells; slot of cell c = 0
  int max_idle = 0;
  for (int l = 0; l < W; ++l) {
    q[l] = part[l];
    idle[l] = q[l] == 0 ? k - r : 0;
    base[l] = first + r - 1 + (q[l] - 1) * k;
    max_idle = idle[l] > max_idle ? idle[l] : max_idle;
  }
  {
    pack_inputs<W>(mv, cs, base, idle, max_idle, k + 1, P);
    // R's mass and inertia belong to the next partition's L (but at the tip)
    const int massive[4] = {kMass, kInertia, kInertia + 1, kInertia + 2};
    for (int a : massive)
      for (int l = 0; l < W; ++l)
        if (q[l] + 1 < parts) P[a][k * W + l] = T(0);
  }
  Cell<T, W> cell[2];
  Border<T, W> bd;
  auto any_general = [](const Cell<T, W>& x) {
    int any = 0;
    for (int l = 0; l < W; ++l) any |= x.general[l];
    return any != 0;
  };
  for (int i = 0; i < 12; ++i)
    for (int l = 0; l < W; ++l) cell[1].carry[i][l] = T(0);
  for (int c = 0; c < k; ++c) {
    const Cell<T, W>& prev = cell[(c + 1) & 1];
    Cell<T, W>& cur = cell[c & 1];
    MANYRODS_LANES
    for (int l = 0; l < W; ++l) assemble_lane<kT, true, false>(l, c, h, stiff_h, P, prev, cur);
    if (any_general(cur))
      for (int l = 0; l < W; ++l)
        if (cur.general[l]) assemble_lane<kT, false, false>(l, c, h, stiff_h, P, prev, cur);
    if (c == 0) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) border_start_lane(l, cur, bd);
    } else if (c == 1) {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_border_lane<true>(l, c, prev, cur, bd, scv);
    } else {
      MANYRODS_LANES
      for (int l = 0; l < W; ++l) eliminate_border_lane<false>(l, c, prev, cur, bd, scv);
    }
  }
  {
    const Cell<T, W>& prev = cell[(k + 1) & 1];
    Cell<T, W>& cur = cell[k & 1];
    MANYRODS_LANES
    for (int l = 0; l < W; ++l) assemble_lane<kT, true, true>(l, k, h, stiff_h, P, prev, cur);
    MANYRODS_LANES
    for (int l = 0; l < W; ++l) border_end_lane(l, q[l], k, prev, cur, bd, scv);
  }
}

// The separators' system of a rod in `parts` partitions (see the header),
// from the hand-over values sc.out; writes u at each separator (slot
// first + r − 1 + qk) into node_v, elem_w and into x[i][q] (i < 6) for the
// back substitution. Fixed separator unknowns (zero inverse mass) are
// identity rows. `work`: 78·parts values.
template <class T>
MANYRODS_HD inline void partitioned_reduced(int first, int cells, int k, const ModelView<T>& m,
                                            const StateView<T>& s, const PartitionScratchView<T>& sc,
                                            T* const (&x)[6], T* work) {
  using viscous_detail::Block6;
  using lanes_detail::lt;
  const int parts = (cells + k - 1) / k, r = cells - (parts - 1) * k;
  // per separator: its factor (36), Z = D̂⁻¹ Eᵀ of the next one (36), ĝ (6)
  auto factor = [&](int q) { return work + 78 * std::size_t(q); };
  auto Z = [&](int q) { return work + 78 * std::size_t(q) + 36; };
  auto gq = [&](int q) { return work + 78 * std::size_t(q) + 72; };
  Block6<T> D, Dp;
  for (int q = 0; q < parts; ++q) {
    const int slot = first + r - 1 + q * k;
    T* b = gq(q);
    for (int i = 0; i < 6; ++i) {
      for (int j = 0; j <= i; ++j) {
        T v = sc.out[kOutAR + lt(i, j)][q];
        if (q + 1 < parts) v += sc.out[kOutSL + lt(i, j)][q + 1];
        D.a[6 * i + j] = v;
        D.a[6 * j + i] = v;
      }
      b[i] = sc.out[kOutYR + i][q] + (q + 1 < parts ? sc.out[kOutRL + i][q + 1] : T(0));
    }
    if (q > 0) {
      // E = F_R(q) (row: separator q, column: separator q − 1); Z_{q−1} = D̂_{q−1}⁻¹ Eᵀ
      const T* const* E = sc.out + kOutFR;
      T* zp = Z(q - 1);
      const T* gp = gq(q - 1);
      for (int i = 0; i < 36; ++i) Dp.a[i] = factor(q - 1)[i];
      for (int j = 0; j < 6; ++j) {
        T col[6];
        for (int i = 0; i < 6; ++i) col[i] = E[6 * j + i][q];
        viscous_detail::cholesky6_solve(Dp, col);
        for (int i = 0; i < 6; ++i) zp[6 * i + j] = col[i];
      }
      for (int i = 0; i < 6; ++i) {
        for (int j = 0; j < 6; ++j) {
          T acc = D.a[6 * i + j];
          for (int t = 0; t < 6; ++t) acc -= E[6 * i + t][q] * zp[6 * t + j];
          D.a[6 * i + j] = acc;
        }
        T acc = b[i];
        for (int t = 0; t < 6; ++t) acc -= E[6 * i + t][q] * gp[t];
        b[i] = acc;
      }
    }
    const T minv[4] = {m.node_inv_mass[slot], m.elem_inv_inertia[0][slot], m.elem_inv_inertia[1][slot],
                       m.elem_inv_inertia[2][slot]};
    for (int i = 0; i < 6; ++i)
      if (minv[i < 3 ? 0 : i - 2] == T(0)) {
        for (int j = 0; j < 6; ++j) D.a[6 * i + j] = D.a[6 * j + i] = T(0);
        D.a[6 * i + i] = T(1);
        b[i] = T(0);
      }
    viscous_detail::cholesky6(D);
    viscous_detail::cholesky6_solve(D, b);
    for (int i = 0; i < 36; ++i) factor(q)[i] = D.a[i];
  }
  for (int q = parts - 1; q >= 0; --q) {
    T u[6];
    const T* g = gq(q);
    for (int i = 0; i < 6; ++i) {
      T v = g[i];
      if (q + 1 < parts)
        for (int j = 0; j < 6; ++j) v -= Z(q)[6 * i + j] * x[j][q + 1];
      u[i] = v;
      x[i][q] = v;
    }
    const int slot = first + r - 1 + q * k;
    for (int d = 0; d < 3; ++d) {
      s.node_v[d][slot] = u[d];
      s.elem_w[d][slot] = u[3 + d];
    }
  }
}

// Back substitution of the W partitions part[…] (after partitioned_reduced):
// u_c = g_c − G_c u_{c+1} − H_c u_L for c = k−1 … 1, into node_v, elem_w of
// the partitions' interior cells (not partition 0's idle and ghost cells).
template <int W, class T>
MANYRODS_HD inline void partitioned_back(int first, int cells, int k, const int* part, const StateView<T>& s,
                                         const PartitionScratchView<T>& sc, const T* const (&x)[6]) {
  using namespace lanes_detail;
  const PartitionScratchView<T> scv = sc;
  const int parts = (cells + k - 1) / k, r = cells - (parts - 1) * k;
  int q[W], idle[W], base[W];
  int all_real = 1;  // from this cell on, every lane is in its interior
  for (int l = 0; l < W; ++l) {
    q[l] = part[l];
    idle[l] = q[l] == 0 ? k - r : 0;
    base[l] = first + r - 1 + (q[l] - 1) * k;
    all_real = idle[l] + 1 > all_real ? idle[l] + 1 : all_real;
  }
  T next[6][W], left[6][W];
  for (int i = 0; i < 6; ++i)
    for (int l = 0; l < W; ++l) {
      next[i][l] = x[i][q[l]];
      left[i][l] = q[l] > 0 ? x[i][q[l] - 1] : T(0);
    }
  for (int c = k - 1; c >= 1; --c) {
    MANYRODS_LANES
    for (int l = 0; l < W; ++l) {
      const int at = c * W + l;
      T u[6];
      MANYRODS_UNROLL_ALL
      for (int i = 0; i < 6; ++i) {
        T v = scv.e.g[i][at];
        MANYRODS_UNROLL_ALL
        for (int j = 0; j < 6; ++j) v -= scv.e.G[6 * i + j][at] * next[j][l];
        MANYRODS_UNROLL_ALL
        for (int j = 0; j < 6; ++j) v -= scv.H[6 * i + j][at] * left[j][l];
        u[i] = v;
      }
      MANYRODS_UNROLL_ALL
      for (int i = 0; i < 6; ++i) {
        scv.e.g[i][at] = u[i];
        next[i][l] = u[i];
      }
    }
  }
  for (int d = 0; d < 6; ++d) {
    T* const dst0 = d < 3 ? s.node_v[d] : s.elem_w[d - 3];
    T* dst[W];
    for (int l = 0; l < W; ++l) dst[l] = dst0 + base[l];
    if (all_real < k) unpack_lanes<W>(dst, scv.e.g[d], all_real, k);
    for (int c = 1; c < all_real && c < k; ++c)
      for (int l = 0; l < W; ++l)
        if (c > idle[l]) dst[l][c] = scv.e.g[d][c * W + l];
  }
}

}  // namespace manyrods
