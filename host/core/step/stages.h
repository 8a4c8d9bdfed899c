// host/core/step/stages.h — the stages of a step, each one launch of per-index kernels
// over a range of slots (a Segment): drift, resultants, kick, frame
// renormalization. The integrators (host/core/step/integrators.h) compose them; the
// kernels they launch are named in each comment (kernels/*.h).
#pragma once

#include <cstdint>
#include <utility>

#include "host/core/step/launch.h"
#include "host/core/step/schedule.h"
#include "host/core/step/workspace.h"
#include "kernels/energy.h"
#include "kernels/views.h"
#include "manyrods/batch.h"

namespace manyrods {

// Resultants: scratch ← strains and total resultants of the current state
// (element_stage, voronoi_stage_small; joints that turn by more than ½ rad
// are redone by the general voronoi_stage). A stiff segment's bending
// moments also carry bend_tau times the start-of-step bending rate (the
// midpoint correction of kernels/viscous_implicit.h "Stiff rods"; the
// Position Verlet step passes −c h).
// reads: model, state  writes: scratch
template <Terms kT, class T>
void compute_resultants(RodBatch<T>& b, const Exec& ex, const Segment& r, T bend_tau = T(0)) {
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> s = std::as_const(b).state_view();
  const ScratchView<T> sc = b.scratch_view();
  auto launch_stages = [&]<bool kBendRate>() {
    launch_with_fallback(
        r.begin, r.end, ex, b.workspace->flags.data(),
        [&](int k) MANYRODS_KERNEL_LAMBDA {
          element_stage<kT>(k, m, s, sc);
          return voronoi_stage_small<kT, kBendRate>(k, m, s, sc, bend_tau);
        },
        [&](int k) MANYRODS_KERNEL_LAMBDA { voronoi_stage<kT, false, kBendRate>(k, m, s, sc, bend_tau); });
  };
  if (r.stiff && bend_tau != T(0))
    launch_stages.template operator()<true>();
  else
    launch_stages.template operator()<false>();
}

// Drift: x += h v, Q ← exp(−h ω) Q (kinematic_node, kinematic_element_small;
// elements that turn by more than ½ rad are redone by kinematic_element; a
// block where none does stores without selects, element_turn_is_large).
// reads: state  writes: state.node_x, node_xc, elem_Q
template <class T>
void drift(RodBatch<T>& b, T h, const Exec& ex, const Segment& r) {
  const StateView<T> s = b.state_view();
  launch_screened(
      r.begin, r.end, ex, b.workspace->flags.data(),
      [&](int k) MANYRODS_KERNEL_LAMBDA { return element_turn_is_large(k, h, s); },
      [&](int k) MANYRODS_KERNEL_LAMBDA {
        kinematic_node(k, h, s);
        kinematic_element_small<false>(k, h, s);
      },
      [&](int k) MANYRODS_KERNEL_LAMBDA {
        kinematic_node(k, h, s);
        return kinematic_element_small(k, h, s);
      },
      [&](int k) MANYRODS_KERNEL_LAMBDA { kinematic_element(k, h, s); });
}

// Kick: v += h m⁻¹ F, ω += h J⁻¹ C (dynamic_node, dynamic_element).
// kEulerOrder: order of the rigid-body (Jω)×ω sub-flow inside the kick: 2 for
// Position Verlet, 4 for PEFRL. kStiff: the kick of stiff rods (see
// kernels/integrate.h dynamic_element).
// reads: model, loads, scratch, state  writes: state.node_v, elem_w
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

// The Position Verlet kick of segment r: the stiff rods' variant where its
// rods are stiff (segments hold one kind, include/manyrods/batch.h).
template <Terms kT, class T>
void segment_kick(RodBatch<T>& b, T h, const Exec& ex, const Segment& r) {
  if (r.stiff)
    kick<kT, 2, true>(b, h, ex, r);
  else
    kick<kT>(b, h, ex, r);
}

// Float batches: one Newton–Schulz step towards orthonormal frames
// (kernels/integrate.h orthonormalize_element), after every
// kFloatFrameRenormalization-th step counted from the batch's step count, so
// that it falls on the same steps whatever the chunking of the run.
// reads: model, state.elem_Q  writes: state.elem_Q
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

// The stages on the whole batch (one range of slots; for tests and analysis).
template <Terms kT, class T>
void compute_resultants(RodBatch<T>& b, const Exec& ex) {
  compute_resultants<kT>(b, ex, whole(b));
}
template <class T>
void drift(RodBatch<T>& b, T h, const Exec& ex) {
  drift(b, h, ex, whole(b));
}
template <Terms kT, int kEulerOrder = 2, class T>
void kick(RodBatch<T>& b, T h, const Exec& ex) {
  kick<kT, kEulerOrder>(b, h, ex, whole(b));
}

}  // namespace manyrods
