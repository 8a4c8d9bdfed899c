// host/step.h — the time step as a short list of stages (DESIGN.md §3).
//
// Position Verlet (Gazzola et al. 2018; the scheme PyElastica uses), h = dt:
//   1. drift ½h:  x += ½h v,  Q ← exp(−½h ω) Q           kinematic_node/element
//   2. strains and total resultants at (x, Q)_{n+½} with the rates from
//      (v, ω)_n                                           element_stage, voronoi_stage
//   3. kick h:    v += h m⁻¹ F,  ω += h J⁻¹ C             dynamic_node/element
//   3b. (Viscous::implicit) (M + hD) u⁺ = M u               viscous_implicit_rod
//   4. drift ½h                                           kinematic_node/element
// Second order for the elastic (conservative) part, first order for the
// Kelvin–Voigt part in both treatments: Viscous::explicit_rate evaluates the
// viscous resultants with the velocities at the start of the kick (stable for
// dt ≲ 2/(τ ω_max²)); Viscous::implicit (the default) integrates them by
// backward Euler after the elastic kick (stable for any τ).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <omp.h>

#include "host/launch.h"
#include "kernels/energy.h"
#include "kernels/viscous_implicit_lanes.h"
#include "manyrods/batch.h"

namespace manyrods {

// The whole batch as one range of slots and rods.
template <class T>
Segment whole(const RodBatch<T>& b) {
  return {0, b.slots(), 0, b.rod_count(), false};
}

// Each stage runs on a range of slots (a Segment; default: the whole batch).

// Stages 2: scratch ← resultants of the current state.
// Joints that turn by more than ½ rad are redone by the general kernel.
template <Terms kT, class T>
void compute_resultants(RodBatch<T>& b, const Exec& ex, const Segment& r) {
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> s = std::as_const(b).state_view();
  const ScratchView<T> sc = b.scratch_view();
  launch_with_fallback(
      r.begin, r.end, ex, b.scratch.flags.data(),
      [&](int k) MANYRODS_KERNEL_LAMBDA {
        element_stage<kT>(k, m, s, sc);
        return voronoi_stage_small<kT>(k, m, s, sc);
      },
      [&](int k) MANYRODS_KERNEL_LAMBDA { voronoi_stage<kT>(k, m, s, sc); });
}
template <Terms kT, class T>
void compute_resultants(RodBatch<T>& b, const Exec& ex) {
  compute_resultants<kT>(b, ex, whole(b));
}

// Elements that turn by more than ½ rad in the drift are redone exactly.
template <class T>
void drift(RodBatch<T>& b, T h, const Exec& ex, const Segment& r) {
  const StateView<T> s = b.state_view();
  launch_with_fallback(
      r.begin, r.end, ex, b.scratch.flags.data(),
      [&](int k) MANYRODS_KERNEL_LAMBDA {
        kinematic_node(k, h, s);
        return kinematic_element_small(k, h, s);
      },
      [&](int k) MANYRODS_KERNEL_LAMBDA { kinematic_element(k, h, s); });
}
template <class T>
void drift(RodBatch<T>& b, T h, const Exec& ex) {
  drift(b, h, ex, whole(b));
}

// Float batches: one Newton–Schulz step towards orthonormal frames
// (kernels/integrate.h orthonormalize_element), after every
// kFloatFrameRenormalization-th step counted from the batch's step count, so
// that it falls on the same steps whatever the chunking of the run.
template <class T>
void renormalize_frames(RodBatch<T>& b, const Exec& ex, const Segment& r) {
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  launch(r.begin, r.end, ex, [&](int k) MANYRODS_KERNEL_LAMBDA { orthonormalize_element(k, m, s); });
}
template <class T>
constexpr bool renormalize_after(std::int64_t step_done) {
  return sizeof(T) == 4 && step_done % kFloatFrameRenormalization == 0;
}

// kEulerOrder: order of the rigid-body (Jω)×ω sub-flow inside the kick
// (kernels/integrate.h dynamic_element): 2 for Position Verlet, 4 for PEFRL.
// kStiff: the kick of stiff rods (see dynamic_element).
template <Terms kT, int kEulerOrder = 2, bool kStiff = false, class T>
void kick(RodBatch<T>& b, T h, const Exec& ex, const Segment& r) {
  const ModelView<T> m = b.model_view();
  const LoadsView<T> l = b.loads_view();
  const ConstScratchView<T> sc = std::as_const(b).scratch_view();
  const StateView<T> s = b.state_view();
  launch(r.begin, r.end, ex, [&](int k) MANYRODS_KERNEL_LAMBDA {
    dynamic_node<kT>(k, h, m, l, sc, s);
    dynamic_element<kT, kEulerOrder, kStiff>(k, h, m, l, sc, s);
  });
}
template <Terms kT, int kEulerOrder = 2, class T>
void kick(RodBatch<T>& b, T h, const Exec& ex) {
  kick<kT, kEulerOrder>(b, h, ex, whole(b));
}
// The Position Verlet kick of segment r: the stiff rods' variant where its
// rods are stiff (segments hold one kind, include/manyrods/batch.h).
template <Terms kT, class T>
void segment_kick(RodBatch<T>& b, T h, const Exec& ex, const Segment& r) {
  if (r.stiff)
    kick<kT, 2, true>(b, h, ex, r);
  else
    kick<kT>(b, h, ex, r);
}

// The driven roots of segment r at the start of a step (Position Verlet) or
// drift (PEFRL) [t, t + h] (include/manyrods/drive.h): node 0 at x(t) with
// the mean velocity (x(t + h) − x(t))/h, the clamp frame (root ghost element)
// at Q(t) with the angular velocity that turns it into Q(t + h), so that the
// drifts end exactly at the pose of t + h (h < 0 for PEFRL's backward
// drifts). Each segment evaluates the motions it uses.
template <class T>
void apply_root_motion(RodBatch<T>& b, const Segment& r, double t, double h) {
  const StateView<T> s = b.state_view();
  int last = -1;
  RootStep st;
  for (int i = r.driven_begin; i < r.driven_end; ++i) {
    const DrivenRoot& d = b.driven[i];
    if (d.motion != last) {
      st = root_step(*b.motions[d.motion], t, h);
      last = d.motion;
    }
    const Mat3 &r0 = st.start.rotation, &r1 = st.end.rotation;
    const int k = b.node_index(d.rod, 0), g = b.rods[d.rod].offset;  // node 0, clamp frame
    for (int c = 0; c < 3; ++c) {
      double x0 = st.start.translation[c], x1 = st.end.translation[c];
      for (int j = 0; j < 3; ++j) {
        x0 += r0[3 * c + j] * d.x0[j];
        x1 += r1[3 * c + j] * d.x0[j];
      }
      s.node_x[c][k] = T(x0);
      s.node_v[c][k] = T((x1 - x0) / h);
      if constexpr (sizeof(T) == 4) s.node_xc[c][k] = T(0);
    }
    Mat3 q;  // Q(t) = Q₀ R(t)ᵀ
    for (int i2 = 0; i2 < 3; ++i2)
      for (int j = 0; j < 3; ++j) {
        double a = 0;
        for (int l = 0; l < 3; ++l) a += d.q0[3 * i2 + l] * r0[3 * j + l];
        q[3 * i2 + j] = a;
        s.elem_Q[3 * i2 + j][g] = T(a);
      }
    for (int c = 0; c < 3; ++c)  // material components: ω = Q(t) Ω
      s.elem_w[c][g] = T(q[3 * c] * st.omega[0] + q[3 * c + 1] * st.omega[1] + q[3 * c + 2] * st.omega[2]);
  }
}

// How the Kelvin–Voigt force is integrated.
//   implicit:      backward Euler in the velocities after the elastic kick
//                  (kernels/viscous_implicit.h): stable for any τ, one
//                  block-tridiagonal solve per rod and step.
//   explicit_rate: the viscous resultants use the rates at the start of the
//                  kick; stable only for dt ≲ 2/(τ ω_max²). The accuracy
//                  reference.
enum class Viscous { implicit, explicit_rate };

// Runs run(segment, exec, thread) on every segment: the fused ones in
// parallel, every other one at a time (even, then odd: no slot is read while
// another thread writes it; segments only read their neighbours' root
// ghost nodes, which never move — a driven root moves node 0 and the clamp
// frame of its own rods), `thread` being the OpenMP thread number; then
// the big ones one by one with all threads (thread = 0).
template <class T, class F>
void for_each_segment(RodBatch<T>& b, const Exec& ex, F&& run) {
  const int n = int(b.segments.size());
  const Exec serial{1};
  for (int parity = 0; parity < 2; ++parity) {
#pragma omp parallel for num_threads(ex.threads) schedule(static, 1) if (ex.threads > 1 && n > 2)
    for (int i = parity; i < n; i += 2)
      if (b.segments[i].fused) run(b.segments[i], serial, omp_get_thread_num());
  }
  for (const Segment& r : b.segments)
    if (!r.fused) run(r, ex, 0);
}

#if defined(__GNUC__)
#define MANYRODS_NOINLINE __attribute__((noinline))
#else
#define MANYRODS_NOINLINE
#endif

// Rods per lane group of the implicit solve (kernels/viscous_implicit_lanes.h):
// one 512-bit vector of float or double. Measured per rod and cell (hair,
// 1 thread, this machine): float 80 ns at 16 lanes, 85 ns at 8; double
// 141 ns at 8 lanes, 172 ns at 16; the scalar kernel 1,000–1,200 ns.
template <class T>
inline constexpr int kImplicitLanes = sizeof(T) == 4 ? 16 : 8;

// Stage 3b on the rods of segment r: the backward-Euler solve
// (kernels/viscous_implicit.h) of every rod that needs one: damped rods when
// kT.kelvin_voigt (the Kelvin–Voigt term is solved here), stiff rods
// (RodSpec::stiff_implicit) always. Undamped, non-stiff rods pay nothing.
//
// The rods are solved kLanes at a time, one per SIMD lane
// (viscous_implicit_lanes; kLanes = 0: kImplicitLanes<T>; 1: every rod by the
// scalar viscous_implicit_rod). Groups are formed from the rods sorted by
// element count (longest first, then by index): the next kLanes rods form a
// group, run for the longest one's cells (the shorter ones idle first, see
// the kernel: equal counts waste nothing, and a segment of equal rods — hair,
// cables — has only equal groups). A last group of fewer rods is filled with
// copies of its last rod. Where kLanes lanes of a rod do not fit the thread's
// buffer (kLanes × (cells + 1) > a segment's slots), kLanes/2 lanes run it
// (the kernel at half width); a group of one rod, or one too long for that,
// is solved by the scalar kernel. The groups depend only on the rods of the
// segment (in chunks of kChunk rods), and a rod's result only on the kernel
// that solves it (not on the other rods of its group: the kernel's idle and
// ghost cells add exact zeros), never on the thread count. Lanes and scalar
// kernel agree to round-off, not bit for bit (tests/test_implicit_lanes.cpp).
//
// `thread` picks the elimination buffer (reserve_implicit_scratch first);
// every solve uses it from its start. With ex.threads > 1 (a segment stepped
// by all threads) the groups are shared out, each thread using its own buffer.
template <Terms kT, int kLanes = 0, class T>
void viscous_update(RodBatch<T>& b, T h, const Exec& ex, const Segment& r, int thread) {
  constexpr int W = kLanes > 0 ? kLanes : kImplicitLanes<T>;
  constexpr int kChunk = 1024;
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  auto needs_solve = [&](const RodInfo& rod) { return rod.stiff_implicit || (kT.kelvin_voigt && rod.damped); };
  for (int c0 = r.rod_begin; c0 < r.rod_end; c0 += kChunk) {
    const int c1 = c0 + kChunk < r.rod_end ? c0 + kChunk : r.rod_end;
    // the rods of this chunk that need the solve, longest first
    int order[kChunk], item_begin[kChunk + 1];
    int n = 0, items = 0;
    for (int i = c0; i < c1; ++i)
      if (needs_solve(b.rods[i])) order[n++] = i;
    if constexpr (W > 1)
      std::sort(order, order + n, [&](int x, int y) {
        const int ex_ = b.rods[x].elements, ey = b.rods[y].elements;
        return ex_ != ey ? ex_ > ey : x < y;
      });
    // items: runs of `order`, a group of 2 … W rods (of 2 … W/2 rods for the
    // half-width kernel when W lanes of the longest do not fit the buffer) or
    // a single rod
    constexpr int W2 = W >= 4 ? W / 2 : 1;
    bool half[kChunk];
    for (int a = 0; a < n;) {
      const int cells = b.rods[order[a]].elements + 1;
      const bool fits = W * (cells + 1) <= b.scratch.visc_cells;
      const bool fits_half = W2 > 1 && W2 * (cells + 1) <= b.scratch.visc_cells;
      const int count = fits ? std::min(W, n - a) : fits_half ? std::min(W2, n - a) : 1;
      half[items] = !fits;
      item_begin[items++] = a;
      a += count;
    }
    item_begin[items] = n;
    // driven roots: the solve runs on the velocities relative to the rigid
    // motion of the root (kernels/viscous_implicit.h rigid_shift)
    // (v₀, ω_g of the root; Ω = Q_gᵀ ω_g and x₀ do not change in the solve)
    const bool driven = r.driven_end > r.driven_begin;  // (a scene without them skips both passes)
    thread_local std::vector<std::array<vec3<T>, 2>> root_v;
    if (driven && root_v.size() < std::size_t(n)) root_v.resize(std::size_t(n));
    auto shift = [&](const RodInfo& rod, const vec3<T>* root, T sign) {
      const int k = rod.offset + 1;
      const vec3<T> omega = mul_transpose(load_frame(s.elem_Q, k - 1), root[1]);
      rigid_shift(k, rod.elements + 1, sign, root[0], omega, load3(s.node_x, k), s);
      store3(s.node_v, k, sign > T(0) ? root[0] : vec3<T>{T(0), T(0), T(0)});
      store3(s.elem_w, k - 1, sign > T(0) ? root[1] : vec3<T>{T(0), T(0), T(0)});
    };
    for (int i = 0; driven && i < n; ++i)
      if (const RodInfo& rod = b.rods[order[i]]; rod.driven) {
        root_v[i][0] = load3(s.node_v, rod.offset + 1);
        root_v[i][1] = load3(s.elem_w, rod.offset);
        shift(rod, root_v[i].data(), T(-1));
      }
    // One compiled copy of the kernels for both branches below (not inlined
    // twice: two copies may contract a·b + c into FMAs differently, and the
    // results would then depend on the branch, i.e. on the thread count).
    auto solve = [&](int item, int t) MANYRODS_NOINLINE {
      const int* rods = order + item_begin[item];
      const int count = item_begin[item + 1] - item_begin[item];
      const ImplicitScratchView<T> sc = b.implicit_scratch_view(t, 0);
      if (count > 1) {
        int first[W], cells[W];
        T stiff_h[W];
        for (int j = 0; j < W; ++j) {
          const RodInfo& rod = b.rods[rods[j < count ? j : count - 1]];
          first[j] = rod.offset + 1;
          cells[j] = rod.elements + 1;
          stiff_h[j] = rod.stiff_implicit ? h : T(0);
        }
        if constexpr (W2 > 1)
          if (half[item]) {
            viscous_implicit_lanes<kT, W2>(first, cells, h, stiff_h, m, s, sc);
            return;
          }
        viscous_implicit_lanes<kT, W>(first, cells, h, stiff_h, m, s, sc);
      } else {
        const RodInfo& rod = b.rods[rods[0]];
        viscous_implicit_rod<kT>(rod.offset + 1, rod.elements + 1, h, rod.stiff_implicit ? h : T(0), m, s, sc);
      }
    };
    if (ex.threads > 1 && items > 1) {
#pragma omp parallel for num_threads(ex.threads) schedule(dynamic, 1)
      for (int it = 0; it < items; ++it) solve(it, omp_get_thread_num());
    } else {
      for (int it = 0; it < items; ++it) solve(it, thread);
    }
    for (int i = 0; driven && i < n; ++i)
      if (const RodInfo& rod = b.rods[order[i]]; rod.driven) shift(rod, root_v[i].data(), T(1));
  }
}
template <Terms kT, int kLanes = 0, class T>
void viscous_update(RodBatch<T>& b, T h, const Exec& ex) {
  b.reserve_implicit_scratch(ex.threads);
  for_each_segment(b, ex, [&](const Segment& r, const Exec& e, int thread) {
    viscous_update<kT, kLanes>(b, h, e, r, thread);
  });
}

// `count` Position Verlet steps of length dt for every rod in the batch.
//
// The batch is stepped segment by segment (include/manyrods/batch.h): a
// segment (≤ 2048 slots, in L2) runs all stages of all `count` steps before
// the next segment is touched (temporal blocking: rods do not interact, so
// the order does not change any result), instead of four sweeps over the
// whole batch per step. Threads take whole segments (for_each_segment), so
// each slot is computed by the same instructions whatever the thread count
// or `count`. A rod longer than a segment is stepped stage by stage, with
// all threads on each stage.
template <Terms kT = kAllTerms, Viscous kV = Viscous::implicit, class T>
void step_n(RodBatch<T>& b, T dt, std::int64_t count, const Exec& ex = {}) {
  constexpr bool kImplicitKV = kT.kelvin_voigt && kV == Viscous::implicit;
  constexpr Terms kExplicit = [] {
    Terms t = kT;
    if (kImplicitKV) t.kelvin_voigt = false;
    return t;
  }();
  constexpr Terms kSolve = [] {  // what the implicit solve integrates
    Terms t = kT;
    t.kelvin_voigt = kImplicitKV;
    return t;
  }();
  const bool solve = kImplicitKV || b.any_stiff();
  if (solve) b.reserve_implicit_scratch(ex.threads);
  for_each_segment(b, ex, [&](const Segment& r, const Exec& e, int thread) {
    double t = b.state.time;
    for (std::int64_t i = 0; i < count; ++i) {
      if (r.driven_end > r.driven_begin) apply_root_motion(b, r, t, double(dt));
      t += double(dt);
      drift(b, T(0.5) * dt, e, r);
      compute_resultants<kExplicit>(b, e, r);
      segment_kick<kExplicit>(b, dt, e, r);
      if (solve) viscous_update<kSolve>(b, dt, e, r, thread);
      drift(b, T(0.5) * dt, e, r);
      if (renormalize_after<T>(b.state.steps + i + 1)) renormalize_frames(b, e, r);
    }
  });
  for (std::int64_t i = 0; i < count; ++i) b.state.time += double(dt);  // as `count` step() calls
  b.state.steps += count;
}

// One Position Verlet step of length dt for every rod in the batch.
template <Terms kT = kAllTerms, Viscous kV = Viscous::implicit, class T>
void step(RodBatch<T>& b, T dt, const Exec& ex = {}) {
  step_n<kT, kV>(b, dt, 1, ex);
}

// PEFRL coefficients (Omelyan, Mryglod, Folk, Comput. Phys. Commun. 146,
// 188–202, 2002, eq. 20: the position-extended Forest–Ruth-like method with
// the smallest leading error of its family).
struct Pefrl {
  static constexpr double xi = 0.1786178958448091;
  static constexpr double lambda = -0.2123418310626054;
  static constexpr double chi = -0.06626458266981849;
};

// One PEFRL step of length dt (4th order, symplectic): the drift and kick
// stages of Position Verlet, composed as
//   drift ξh, kick (½−λ)h, drift χh, kick λh, drift (1−2(χ+ξ))h,
//   kick λh, drift χh, kick (½−λ)h, drift ξh
// (four resultant evaluations per step; λ, χ < 0, so two kicks and two
// drifts run backwards). Linear stability (undamped): h·ω_max < 2.99, against
// 2 for Position Verlet with a quarter of the force evaluations.
//
// The rigid-body term (Jω)×ω is integrated inside each kick by a 4th-order
// composition of implicit-midpoint steps (kEulerOrder = 4, see
// kernels/integrate.h); with Position Verlet's single midpoint step
// (kEulerOrder = 2) PEFRL is only second order in 3-D
// (tests/test_integrators.cpp measures both).
//
// Order 4 holds for the conservative part. The Kelvin–Voigt term stays FIRST
// order in both treatments:
//   explicit_rate: each kick includes the viscous force with the rates at the
//     start of that kick (as in step); limited to h ≲ 2/(τ ω_max²);
//   implicit: after EACH of the four kicks a backward-Euler update of length
//     h/4 (positive, total h per step), at that kick's geometry: stable for
//     any τ. For one linear mode (frequency ω, viscous rate τω²) the
//     spectral radius of the step stays ≤ 1 for every h ω < 2.985 and
//     h τ ω² from 1e-4 to 1e9 (checked on a grid; the undamped PEFRL limit
//     is h ω < 2.989). Measured on the released seed cantilever (n = 20,
//     τ = 0.02 s, T = 0.1 s) its state error falls at order 1.1–1.4 and is
//     below Position Verlet's at equal h (tests/test_integrators.cpp).
//   Placements that do not work (measured, tests/test_integrators.cpp):
//   - after every kick with that kick's length: backward Euler runs
//     backwards over the inner kicks (λh < 0) and M − |λh|D loses
//     definiteness once |λ| h τ ω² ≥ 1: blows up at the elastic step;
//   - h/2 after each of the two outer kicks: a strongly damped mode loses
//     its velocity there, and the inner part (kick λh, drift (1−2(χ+ξ))h,
//     kick λh with λ < 0) pushes it from equilibrium by a factor
//     1 + |λ|(1−2(χ+ξ))(hω)² per step: blows up too;
//   - once per step outside the composition (h at the end, or h/2 at each
//     end): stable, but the strongly damped modes then oscillate undamped
//     through the whole step and their slow relaxation is wrong by O(1)
//     (at hω = 1, hτω² = 100 the slow eigenvalue is 0.53 instead of 0.99);
//     the energy identity's residual then falls at order 0.6 or not at all.
//   Negative sub-steps and dissipation do not mix well (no splitting of
//   order > 2 avoids negative sub-steps, Sheng 1989, Suzuki 1991): for
//   strongly damped rods Position Verlet (step) is the better choice.
template <Terms kT = kAllTerms, Viscous kV = Viscous::implicit, int kEulerOrder = 4, class T>
void step_pefrl(RodBatch<T>& b, T dt, const Exec& ex = {}) {
  constexpr bool kImplicit = kT.kelvin_voigt && kV == Viscous::implicit;
  constexpr Terms kExplicit = [] {
    Terms t = kT;
    if (kImplicit) t.kelvin_voigt = false;
    return t;
  }();
  if (b.any_stiff())
    throw std::invalid_argument(
        "step_pefrl: the batch has stiff rods (RodSpec::stiff_implicit), which only Position Verlet "
        "steps stably; use step/step_n/advance with Integrator::position_verlet");
  const T xi = T(Pefrl::xi) * dt, chi = T(Pefrl::chi) * dt;
  const T mid = T(1 - 2 * (Pefrl::chi + Pefrl::xi)) * dt;
  const T outer = T(0.5 - Pefrl::lambda) * dt, inner = T(Pefrl::lambda) * dt;
  auto kick_stage = [&](T h) {
    compute_resultants<kExplicit>(b, ex);
    kick<kExplicit, kEulerOrder>(b, h, ex);
    if constexpr (kImplicit) viscous_update<kT>(b, T(0.25) * dt, ex);
  };
  // Driven roots follow their motion drift by drift: each drift of length
  // c·dt starts the root at its pose of that stage's time and lands on the
  // next stage's (so the kicks see the root where it is at their time and
  // PEFRL keeps its order; tests/test_drive.cpp).
  double t = b.state.time;
  const bool driven = !b.driven.empty();
  auto root_drift = [&](T h, double c) {
    if (driven)
      for (const Segment& r : b.segments)
        if (r.driven_end > r.driven_begin) apply_root_motion(b, r, t, c * double(dt));
    drift(b, h, ex);
    t += c * double(dt);
  };
  root_drift(xi, Pefrl::xi);
  kick_stage(outer);
  root_drift(chi, Pefrl::chi);
  kick_stage(inner);
  root_drift(mid, 1 - 2 * (Pefrl::chi + Pefrl::xi));
  kick_stage(inner);
  root_drift(chi, Pefrl::chi);
  kick_stage(outer);
  root_drift(xi, Pefrl::xi);
  if (renormalize_after<T>(b.state.steps + 1)) renormalize_frames(b, ex, whole(b));
  b.state.time += double(dt);
  b.state.steps += 1;
}

// Generalized forces of the current state (for analysis: statics, linearized
// dynamics, tests): total node force (internal + external, lab frame) and
// element couple (internal + external, material frame, including (Jω)×ω),
// written per slot into force[3][slots] and couple[3][slots].
template <Terms kT = kAllTerms, class T>
void generalized_forces(RodBatch<T>& b, T* const force[3], T* const couple[3], const Exec& ex = {}) {
  compute_resultants<kT>(b, ex);
  const ModelView<T> m = b.model_view();
  const LoadsView<T> l = b.loads_view();
  const ConstScratchView<T> sc = std::as_const(b).scratch_view();
  const ConstStateView<T> s = std::as_const(b).state_view();
  launch(b.slots(), ex, [&](int k) MANYRODS_KERNEL_LAMBDA {
    store3(force, k, node_force(k, sc) + node_external_force<kT>(k, m, l));
    const mat3<T> Q = load_frame(s.elem_Q, k);
    store3(couple, k, element_couple(k, sc) + euler_couple(load3(m.elem_inertia, k), load3(s.elem_w, k)) +
                          element_external_couple<kT>(k, l, Q));
  });
}

// Energies of rod `rod` (or of the whole batch when rod < 0), summed in
// double in index order (deterministic).
struct Energies {
  double kinetic = 0;       // translational + rotational
  double elastic = 0;       // stretch, shear, bend, twist
  double potential = 0;     // gravity and dead point forces
  double dissipation = 0;   // 2·D_v: rate of viscous energy loss, W
  double total() const { return kinetic + elastic + potential; }
};

template <Terms kT = kAllTerms, class T>
Energies energies(const RodBatch<T>& b, int rod = -1) {
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> s = b.state_view();
  const LoadsView<T> l = b.loads_view();
  Energies e;
  auto add_range = [&](int first, int last) {  // slots [first, last)
    for (int k = first; k < last; ++k) {
      e.kinetic += double(node_kinetic_energy(k, m, s)) + double(element_kinetic_energy(k, m, s));
      e.elastic += double(element_elastic_energy<kT>(k, m, s)) + double(voronoi_elastic_energy<kT>(k, m, s));
      e.potential += double(node_potential_energy<kT>(k, m, l, s));
      e.dissipation += double(element_dissipation<kT>(k, m, s)) + double(voronoi_dissipation<kT>(k, m, s));
    }
  };
  if (rod >= 0) {
    const int o = b.rods[rod].offset;
    add_range(o, o + b.rods[rod].elements + 2);
  } else {
    for (const RodInfo& r : b.rods) add_range(r.offset, r.offset + r.elements + 2);
  }
  return e;
}

// The first non-finite entry of the state, if any: rod, what and index.
struct NonFinite {
  bool found = false;
  int rod = -1;
  std::string field;  // "node" or "element"
  int index = -1;
};

template <class T>
NonFinite find_non_finite(const RodBatch<T>& b) {
  for (int r = 0; r < b.rod_count(); ++r) {
    const int n = b.rods[r].elements;
    for (int j = 0; j <= n; ++j) {
      const int k = b.node_index(r, j);
      for (int d = 0; d < 3; ++d)
        if (!std::isfinite(b.state.node_x[d][k]) || !std::isfinite(b.state.node_v[d][k]))
          return {true, r, "node", j};
    }
    for (int e = 0; e < n; ++e) {
      const int k = b.elem_index(r, e);
      for (int i = 0; i < 9; ++i)
        if (!std::isfinite(b.state.elem_Q[i][k])) return {true, r, "element", e};
      for (int d = 0; d < 3; ++d)
        if (!std::isfinite(b.state.elem_w[d][k])) return {true, r, "element", e};
    }
  }
  return {};
}

}  // namespace manyrods
