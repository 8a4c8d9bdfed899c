// host/core/step/implicit_solve.h — the implicit stage of a step: the backward-Euler
// solve (kernels/viscous_implicit.h, kernels/viscous_implicit_lanes.h) of
// every rod that needs one — damped rods when the step has the Kelvin–Voigt
// term, stiff rods (RodSpec::stiff_implicit) always. Undamped, non-stiff rods
// pay nothing. The rods and their lane groups come from the batch's plan
// (host/core/step/implicit_plan.h), built with the batch.
#pragma once

#include <omp.h>

#include <algorithm>
#include <functional>
#include <tuple>
#include <type_traits>
#include <vector>

#include "host/core/step/implicit_plan.h"
#include "host/core/step/schedule.h"
#include "kernels/viscous_implicit.h"
#include "kernels/viscous_implicit_lanes.h"
#include "kernels/viscous_implicit_partitioned.h"
#include "kernels/views.h"
#include "manyrods/batch.h"

namespace manyrods {

#if defined(__GNUC__)
#define MANYRODS_NOINLINE __attribute__((noinline))
#else
#define MANYRODS_NOINLINE
#endif

namespace detail {

// Driven holds: the solve runs on the velocities relative to the rigid
// motion of the rod's reference hold (DrivenHold::reference: a driven root,
// or a stiff rod's one driven hold at its tip; kernels/viscous_implicit.h
// rigid_shift). sign −1 keeps the hold's (v, ω_g) in `saved` and subtracts
// its rigid field; +1 adds it back. Ω = Q_gᵀ ω_g and the hold's x do not
// change in the solve. The tip's clamp frame (the tip ghost element, which
// rigid_shift leaves alone) is a held unknown too: its relative value is
// ω − Q Ω, and its own value is kept in `saved` and put back exactly (a
// clamped tip held at rest with a nodding root feels the root's turn at its
// joint; tests/test_constraints.cpp). Other held unknowns keep their (shifted) prescribed
// velocities: their rods (RodInfo::prescribed) are solved with the fixed
// unknowns' values lifted to the right-hand side (SolveGroup::lift).
// shift_hold: hold i alone; shift_reference_holds: the reference holds of
// the rods segment r solves.
template <class T>
void shift_hold(RodBatch<T>& b, int i, T sign) {
  const StateView<T> s = b.state_view();
  const DrivenHold& d = b.driven[std::size_t(i)];
  const RodInfo& rod = b.rods[d.rod];
  T* saved = b.workspace->driven_root_velocity.data() + kHoldSaved * std::size_t(i);
  const int k = d.node, g = d.frame[0], tip = rod.offset + rod.elements + 1;
  vec3<T> root[2];
  if (sign < T(0)) {
    root[0] = load3(s.node_v, k);
    root[1] = load3(s.elem_w, g);
    const T keep[6] = {root[0].x, root[0].y, root[0].z, root[1].x, root[1].y, root[1].z};
    for (int c = 0; c < 6; ++c) saved[c] = keep[c];
  } else {
    root[0] = {saved[0], saved[1], saved[2]};
    root[1] = {saved[3], saved[4], saved[5]};
  }
  const vec3<T> omega = mul_transpose(load_frame(s.elem_Q, g), root[1]);
  if (sign < T(0) && tip != g) {
    const vec3<T> own = load3(s.elem_w, tip);
    saved[6] = own.x, saved[7] = own.y, saved[8] = own.z;
  }
  rigid_shift(rod.offset + 1, rod.elements + 1, sign, root[0], omega, load3(s.node_x, k), s);
  if (tip != g) {  // the tip's clamp frame: relative, or its own value back
    const vec3<T> own{saved[6], saved[7], saved[8]};
    store3(s.elem_w, tip, sign < T(0) ? own - mul(load_frame(s.elem_Q, tip), omega) : own);
  }
  const vec3<T> zero{T(0), T(0), T(0)};
  store3(s.node_v, k, sign > T(0) ? root[0] : zero);
  store3(s.elem_w, g, sign > T(0) ? root[1] : zero);
}
// `done(rod)`: the rod's hold was shifted back already (a stage fused
// into the solve did, NoSolveHook never).
template <class T, class Done>
void shift_reference_holds(RodBatch<T>& b, const Segment& r, bool kelvin_voigt, T sign, Done&& done) {
  for (int i = r.driven_begin; i < r.driven_end; ++i) {
    const DrivenHold& d = b.driven[i];
    if (d.reference && needs_implicit_solve(b.rods[d.rod], kelvin_voigt) && !done(d.rod)) shift_hold(b, i, sign);
  }
}
template <class T>
void shift_reference_holds(RodBatch<T>& b, const Segment& r, bool kelvin_voigt, T sign) {
  shift_reference_holds(b, r, kelvin_voigt, sign, [](int) { return false; });
}

// The terms the solve reads: the elastic components and the Kelvin–Voigt
// term. Step variants that differ only in others (gravity, loads, contact)
// share one compiled solve (viscous_update forwards to it): the same
// instructions for all of them, and a fraction of the compile time.
constexpr Terms solve_kernel_terms(Terms t) {
  Terms s{};
  s.shear = t.shear;
  s.stretch = t.stretch;
  s.bend = t.bend;
  s.twist = t.twist;
  s.kelvin_voigt = t.kelvin_voigt;
  s.gravity = s.loads = s.colliders = s.rod_contact = false;
  return s;
}

// A stage fused into the solve after each lane group (the collider contacts
// of host/core/step/contact_solve.h ContactsAfterGroup): `Hook::group<Wg>`
// solves the group itself, keeping its factors, and takes its rods' contacts
// through them; `Hook::restored(rod)`: it shifted the rod's reference hold
// back (the solve then does not). NoSolveHook: none.
struct NoSolveHook {};

template <Terms kT, int kLanes, class T, class Hook = NoSolveHook>
void solve_segment(RodBatch<T>& b, T h, const Exec& ex, const Segment& r, int thread, Hook* hook = nullptr);

// One long rod's partitioned solve (kernels/viscous_implicit_partitioned.h):
// its lane groups forwards (shared out over ex.threads), the separators'
// system, the lane groups backwards; k cells per partition (the plan's
// kPartitionCells; tests use others). `buf`: partition_values(cells, W, k)
// values.
template <Terms kT, int W, class T>
MANYRODS_NOINLINE void solve_partitioned(RodBatch<T>& b, T h, const Exec& ex, const RodInfo& rod, T* buf,
                                         int k = kPartitionCells) {
  const int first = rod.offset + 1, cells = rod.elements + 1;
  const int parts = (cells + k - 1) / k, groups = (parts + W - 1) / W;
  const T stiff_h = rod.stiff_implicit ? h : T(0);
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  const std::size_t lane_values = std::size_t(k + 1) * W, group_values = 78 * lane_values;
  T* const out = buf + group_values * std::size_t(groups);
  T* const work = out + std::size_t(kPartitionOut) * std::size_t(parts);
  T* const xs = work + 78 * std::size_t(parts);
  T* x[6];
  for (int i = 0; i < 6; ++i) x[i] = xs + std::size_t(i) * std::size_t(parts);
  auto view = [&](int g) {
    PartitionScratchView<T> v{};
    T* const at = buf + group_values * std::size_t(g);
    for (int i = 0; i < 36; ++i) v.e.G[i] = at + std::size_t(i) * lane_values;
    for (int i = 0; i < 6; ++i) v.e.g[i] = at + std::size_t(36 + i) * lane_values;
    for (int i = 0; i < 36; ++i) v.H[i] = at + std::size_t(42 + i) * lane_values;
    for (int i = 0; i < kPartitionOut; ++i) v.out[i] = out + std::size_t(i) * std::size_t(parts);
    return v;
  };
  auto lanes_of = [&](int g, int (&part)[W]) {
    for (int l = 0; l < W; ++l) part[l] = std::min(g * W + l, parts - 1);
  };
  // (one compiled copy of each pass for both branches below: see solve_segment)
  auto forward = [&](int g) MANYRODS_NOINLINE {
    int part[W];
    lanes_of(g, part);
    partitioned_forward<kT, W>(first, cells, k, part, h, stiff_h, m, s, view(g));
  };
  auto back = [&](int g) MANYRODS_NOINLINE {
    int part[W];
    lanes_of(g, part);
    partitioned_back<W>(first, cells, k, part, s, view(g), x);
  };
  auto each_group = [&](auto&& pass) {
    if (ex.threads > 1 && groups > 1) {
      const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/core/step/fp_env.h)
#pragma omp parallel num_threads(ex.threads)
      {
        const RegionFpScope fp(mode);
#pragma omp for schedule(static)
        for (int g = 0; g < groups; ++g) pass(g);
      }
    } else {
      for (int g = 0; g < groups; ++g) pass(g);
    }
  };
  each_group(forward);
  partitioned_reduced(first, cells, k, m, s, view(0), x, work);
  each_group(back);
}

}  // namespace detail

// The implicit stage on the rods of segment r. kLanes = 0: the batch's plan
// (kImplicitLanes<T> rods per lane group). The segment is planned on the fly
// instead (an allocation per call, for tests and analysis) for another lane
// count (1: every rod by the scalar viscous_implicit_rod), for a segment
// that is not one of the batch's (e.g. whole(b)), or when the buffer was
// reserved larger than the plan assumed (reserve_implicit_scratch with
// min_cells), so that the groups are always those the buffer allows. Lanes and scalar kernel agree to
// round-off, not bit for bit (tests/test_implicit_lanes.cpp).
//
// `thread` picks the elimination buffer (reserve_implicit_scratch first);
// every solve uses it from its start. With ex.threads > 1 (a segment stepped
// by all threads) the groups are shared out, each thread using its own buffer.
// reads: model, state  writes: state.node_v, elem_w (scratch: the thread's buffer)
template <Terms kT, int kLanes = 0, class T>
void viscous_update(RodBatch<T>& b, T h, const Exec& ex, const Segment& r, int thread) {
  detail::solve_segment<detail::solve_kernel_terms(kT), kLanes>(b, h, ex, r, thread);
}

namespace detail {

template <Terms kT, int kLanes, class T, class Hook>
void solve_segment(RodBatch<T>& b, T h, const Exec& ex, const Segment& r, int thread, Hook* hook) {
  constexpr int W = kLanes > 0 ? kLanes : kImplicitLanes<T>;
  constexpr int kv = kT.kelvin_voigt ? 1 : 0;
  const SolvePlan* plan = &b.workspace->solve_plan[kv];
  int g0 = r.groups_begin[kv], g1 = r.groups_end[kv];
  const std::less<const Segment*> before;  // (defined for any two pointers)
  const bool own = !before(&r, b.segments.data()) && before(&r, b.segments.data() + b.segments.size());
  SolvePlan other;
  if (!own || plan->lanes != W || plan->buffer_cells != b.workspace->visc_cells) {
    std::tie(g0, g1) =
        plan_segment(other, b.rods, r, W, b.workspace->visc_cells, kT.kelvin_voigt, segments_alone(b.segments));
    plan = &other;
  }
  if (g0 == g1) return;
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  const bool driven = r.driven_end > r.driven_begin;  // (a scene without them skips both passes)
  if (driven) detail::shift_reference_holds(b, r, kT.kelvin_voigt, T(-1));
  // One compiled copy of the kernels for both branches below (not inlined
  // twice: two copies may contract a·b + c into FMAs differently, and the
  // results would then depend on the branch, i.e. on the thread count).
  constexpr int W2 = W >= 4 ? W / 2 : 1;
  // a float batch's stiff rods: in double, kImplicitLanes<double> lanes at a
  // time (a group of W float lanes in two halves; a rod alone in one lane)
  constexpr int kWide = kImplicitLanes<double>;
  const bool wide = sizeof(T) < sizeof(double) && r.stiff && ex.stiff_solve_in_double && W >= kWide && W % kWide == 0;
  auto solve = [&](int group, int t) MANYRODS_NOINLINE {
    const SolveGroup& grp = plan->groups[group];
    if (grp.parts > 0) return;  // below
    const int* rods = plan->rods.data() + grp.first;
    const ImplicitScratchView<T> sc = b.implicit_scratch_view(t, 0);
    // the scalar kernel: every rod at kLanes = 1 (the tests' reference); a
    // float rod alone that is not solved in double (the delta form keeps
    // float's precision in the slow modes, docs/model.md)
    if (W == 1 || (grp.count == 1 && sizeof(T) < sizeof(double) && !wide)) {
      const RodInfo& rod = b.rods[rods[0]];
      viscous_implicit_rod<kT>(rod.offset + 1, rod.elements + 1, h, rod.stiff_implicit ? h : T(0), m, s, sc);
      return;
    }
    int first[W], cells[W];
    T stiff_h[W];
    for (int j = 0; j < W; ++j) {
      const RodInfo& rod = b.rods[rods[j < grp.count ? j : grp.count - 1]];
      first[j] = rod.offset + 1;
      cells[j] = rod.elements + 1;
      stiff_h[j] = rod.stiff_implicit ? h : T(0);
    }
    if constexpr (W >= kWide && W % kWide == 0 && sizeof(T) < sizeof(double))
      if (wide) {
        const ImplicitScratchView<double> wsc = b.wide_implicit_scratch_view(t);
        if (grp.count == 1) {
          if (grp.lift)
            viscous_implicit_lanes<kT, 1, false, true>(first, cells, h, stiff_h, m, s, wsc);
          else
            viscous_implicit_lanes<kT, 1>(first, cells, h, stiff_h, m, s, wsc);
          return;
        }
        for (int j = 0; j < grp.count; j += kWide)
          if (grp.lift)
            viscous_implicit_lanes<kT, kWide, false, true>(first + j, cells + j, h, stiff_h + j, m, s, wsc);
          else
            viscous_implicit_lanes<kT, kWide>(first + j, cells + j, h, stiff_h + j, m, s, wsc);
        return;
      }
    // a double rod alone in one lane (about 3× faster than the scalar
    // kernel: the lane kernel's symmetric, structured elimination), a half or
    // a full group; with a hook, it solves them
    // (rods with prescribed velocities: kLift, full groups or one lane)
    if constexpr (!std::is_same_v<Hook, NoSolveHook>) {
      if (grp.lift && grp.count == 1)
        hook->template group<1, true>(first, cells, stiff_h, rods, 1, sc, t);
      else if (grp.lift)
        hook->template group<W, true>(first, cells, stiff_h, rods, grp.count, sc, t);
      else if (grp.count == 1)
        hook->template group<1>(first, cells, stiff_h, rods, 1, sc, t);
      else if (W2 > 1 && grp.half)
        hook->template group<W2>(first, cells, stiff_h, rods, grp.count, sc, t);
      else
        hook->template group<W>(first, cells, stiff_h, rods, grp.count, sc, t);
      return;
    }
    if (grp.lift && grp.count == 1)
      viscous_implicit_lanes<kT, 1, false, true>(first, cells, h, stiff_h, m, s, sc);
    else if (grp.lift)
      viscous_implicit_lanes<kT, W, false, true>(first, cells, h, stiff_h, m, s, sc);
    else if (grp.count == 1)
      viscous_implicit_lanes<kT, 1>(first, cells, h, stiff_h, m, s, sc);
    else if (W2 > 1 && grp.half)
      viscous_implicit_lanes<kT, W2>(first, cells, h, stiff_h, m, s, sc);
    else
      viscous_implicit_lanes<kT, W>(first, cells, h, stiff_h, m, s, sc);
  };
  // the groups on ex.threads threads, or a fused segment's solve_threads
  // (Exec: the schedule runs it alone; its plan has cut it into groups that
  // share out, host/core/step/implicit_plan.h)
  const int threads = std::max({ex.threads, ex.solve_threads, 1});
  if (threads > 1 && g1 - g0 > 1) {
    const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/core/step/fp_env.h)
#pragma omp parallel num_threads(std::min(threads, g1 - g0))
    {
      const RegionFpScope fp(mode);
#pragma omp for schedule(dynamic, 1)
      for (int g = g0; g < g1; ++g) solve(g, omp_get_thread_num());
    }
  } else {
    for (int g = g0; g < g1; ++g) solve(g, thread);
  }
  // long rods, each with all of ex.threads (a plan made here has its own buffer)
  std::vector<T> own_partition;
  if constexpr (W > 1)
    for (int g = g0; g < g1; ++g) {
      const SolveGroup& grp = plan->groups[g];
      if (grp.parts == 0) continue;
      T* buf = nullptr;
      if (plan == &other) {
        own_partition.assign(partition_values(b.rods[plan->rods[grp.first]].elements + 1, W), T(0));
        buf = own_partition.data();
      } else {
        buf = b.workspace->visc_partition.data() + grp.offset;
      }
      solve_partitioned<kT, W>(b, h, ex, b.rods[plan->rods[grp.first]], buf);
    }
  if (driven) {
    if constexpr (std::is_same_v<Hook, NoSolveHook>)
      detail::shift_reference_holds(b, r, kT.kelvin_voigt, T(1));
    else
      detail::shift_reference_holds(b, r, kT.kelvin_voigt, T(1), [&](int rod) { return hook->restored(rod); });
  }
}

}  // namespace detail

// The implicit stage on the whole batch (every segment).
template <Terms kT, int kLanes = 0, class T>
void viscous_update(RodBatch<T>& b, T h, const Exec& ex) {
  b.reserve_implicit_scratch(ex.threads);
  for_each_segment(b, ex, [&](const Segment& r, const Exec& e, int thread) {
    viscous_update<kT, kLanes>(b, h, e, r, thread);
  });
}

}  // namespace manyrods
