// host/core/step/workspace.h — the step's own data in a batch: the plans
// of the implicit solve (host/core/step/implicit_plan.h), its buffers, the
// driven roots' velocities it keeps, and the fallback flags of the
// branch-free kernels (host/core/step/launch.h). RodBatch holds it behind
// an opaque handle (include/manyrods/batch.h RodBatch::workspace), so none
// of it is public API; copied with the batch. Built with the batch
// (host/core/model/batch.cpp), the buffers grown on first use
// (RodBatch::reserve_implicit_scratch).
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "kernels/contact_solve.h"
#include "manyrods/array.h"
#include "manyrods/batch.h"

namespace manyrods {

// Values kept per driven hold across the implicit solve
// (StepWorkspace::driven_root_velocity).
inline constexpr int kHoldSaved = 9;

// The rods of one call of the implicit per-rod solve: `count` rods of
// SolvePlan::rods from `first`, longest first, solved one per SIMD lane
// (count ≥ 2; `half`: at half the lane width, because a full group of its
// longest rod does not fit a thread's buffer), or one rod alone (count = 1:
// in one lane in double, by the scalar kernel in float unless solved in
// double), or — one long rod (count = 1, parts > 0) — cut into `parts`
// partitions solved one per lane (kernels/viscous_implicit_partitioned.h),
// with its values at `offset` in StepWorkspace::visc_partition. `lift`:
// rods with prescribed velocities (RodInfo::prescribed), full groups or one
// rod, never partitioned, solved by the lane kernel with kLift.
// docs/architecture.md "The implicit-solve plan".
struct SolveGroup {
  int first = 0, count = 0;
  bool half = false;
  int parts = 0;
  std::size_t offset = 0;
  bool lift = false;  // rods with prescribed velocities (the lane kernel's kLift)
};

// One rod's contacts in the contact solve (host/core/step/contact_solve.h),
// one lane of a group: its collider and self contacts, its nodes' contact
// weights (cells), its Delassus operator over the contacts in the solve
// (members, in the order they joined; each contact's place among them;
// 9 × cap² values, and a spare for its growth), the contacts joining next
// (from `next`); the rod (−1: none acts), its first slot and cells, the
// group cell of its cell 0 (start), its lowest contact cell, the contacts'
// velocity scale, and whether it is still being solved.
template <class T>
struct RodContacts {
  std::vector<SolveContact<T>> contacts;
  std::vector<T> weight, delassus, spare;
  std::vector<int> members, place, joining;
  int next = 0, cap = 0, rod = -1, first = 0, cells = 0, start = 0, low = 0;
  int pairs = 0;  // of the contacts, those with another rod (kernels/contact_solve.h (S4))
  T scale = T(0);
  bool open = false;
  // rod–rod contacts in the solve (sweeps over all rods): its largest move
  // in this sweep, its smallest so far and when, and whether it stalled
  T worst = T(0), best = T(0);
  int best_at = -1;
  bool frozen = false;
  bool respond = false, joined = false;  // its impulses changed since its last response; contacts joined
  // each contact's impulse at the rod's last solve where it was found again
  // (0: none; ContactData::solve_impulses), the sweeps' first guess
  std::vector<vec3<T>> last_p;
};

// One thread's buffers of the contact solve (host/core/step/contact_solve.h):
// the rods' contacts of a lane group (lanes, one per lane), the factors of
// their systems (kernels/viscous_implicit.h kKeepValues × lanes
// × cells; keep_wide: a float batch's stiff rods, solved in double) and the
// right-hand sides (18 × lanes × cells); the calling thread's: which rods
// of the segment have a contact that acts (kind), those rods and the jobs
// they make ({kind, first, count}).
template <class T>
struct ContactSolveBuffer {
  std::vector<RodContacts<T>> lanes;
  std::vector<T> keep;
  std::vector<double> keep_wide, x;
  std::vector<char> kind;
  std::vector<int> rods;
  std::vector<std::array<int, 3>> jobs;
  // the sweeps over all rods' contacts (rod_contacts_in_solve): each rod's
  // place among those taking part (−1: none), the places still to visit in
  // this sweep (a min-heap), those whose largest move this sweep was set,
  // and each place's marks (1: queued, 2: touched)
  std::vector<int> place_of, visit, touched;
  std::vector<char> marks;
  RodContacts<T>* lanes_for(int w) {
    if (int(lanes.size()) < w) lanes.resize(std::size_t(w));
    return lanes.data();
  }
};

// Which rods the implicit solve visits, grouped once when the batch is built.
struct SolvePlan {
  int lanes = 0;            // rods per lane group it was built for
  int buffer_cells = 0;     // cells per thread of the buffer it was built for
  std::vector<int> rods;    // per segment, longest first (then by index)
  std::vector<SolveGroup> groups;
  std::size_t partition_values = 0;  // StepWorkspace::visc_partition it needs
};

template <class T>
struct StepWorkspace {
  // The rods of the implicit solve in lane groups, [0] without and [1] with
  // the Kelvin–Voigt term (stiff rods always; damped rods with it), built
  // with the batch; each segment owns a range of groups
  // (Segment::groups_begin, groups_end).
  std::array<SolvePlan, 2> solve_plan;
  // Block elimination of the implicit viscous update (kernels/viscous_implicit.h):
  // one buffer of `visc_cells` cells per thread (a segment's worth, not the
  // batch's), allocated on first use only.
  std::array<Array<T>, 36> visc_G;
  std::array<Array<T>, 6> visc_g;
  std::array<Array<T>, 21> visc_L;  // the lane solve's factors (ImplicitScratchView::L)
  int visc_cells = 0, visc_threads = 0;
  // The same buffer in double, for a float batch's stiff rods (solved in
  // double: kernels/viscous_implicit_lanes.h); empty otherwise: G, g, L.
  std::array<Array<double>, 63> visc_wide;
  // the partitioned solves of long rods (SolveGroup::parts), one block per rod
  std::vector<T> visc_partition;
  // [kHoldSaved × driven holds] the velocity and clamp angular velocity of
  // each reference hold, and its rod's tip clamp frame's angular velocity,
  // kept across the implicit solve (which runs on velocities relative to the
  // hold's rigid motion, host/core/step/implicit_solve.h shift_hold); entry
  // i belongs to RodBatch::driven[i]
  std::vector<T> driven_root_velocity;
  // one per thread (host/core/step/contact_solve.h), grown on first use
  std::vector<ContactSolveBuffer<T>> contact_solve;
  // [rods] 1: the rod's collider contacts were solved in the implicit solve
  // itself (host/core/step/contact_solve.h viscous_update_with_contacts),
  // from there to the contact solve stage after it, which clears it
  std::vector<char> contact_fused;
  // [rods] the rod's reference hold in the segment being solved (−1: none),
  // for viscous_update_with_contacts (−1 outside it)
  std::vector<int> contact_hold;
  // Rod–rod contacts in the solve (host/core/step/contact_solve.h
  // rod_contacts_in_solve): [rods] each rod's contacts, kept over the
  // sweeps through all rods' contacts (rod −1: not taking part), and each
  // lane group's kept factors (keep, then G: 88 × lanes × cells; in double
  // for a float batch's stiff rods)
  std::vector<RodContacts<T>> rod_contacts;
  struct KeptFactors {
    std::vector<T> f;
    std::vector<double> wide;
    int n = 0;
  };
  std::vector<KeptFactors> kept_factors;
  // Slots whose rotation exceeded the branch-free kernels' range in the
  // current stage (host/core/step/launch.h launch_with_fallback).
  Array<int> flags;  // int, not char: a char store may alias the view pointers and stops vectorization
};

}  // namespace manyrods
