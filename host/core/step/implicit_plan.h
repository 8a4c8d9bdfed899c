// host/core/step/implicit_plan.h — which rods the implicit per-rod solve visits, and in
// which lane groups (docs/architecture.md "The implicit-solve plan"). Built
// once, with the batch (host/core/model/batch.cpp), and stored beside the segments.
//
// A segment's rods that need the solve — stiff rods (RodSpec::stiff_implicit)
// always, damped rods when the step has the Kelvin–Voigt term — are sorted by
// element count (longest first, then by index); the next `lanes` rods form a
// group, run for the longest one's cells (shorter ones idle first, see
// kernels/viscous_implicit_lanes.h: equal counts waste nothing, and a
// segment of equal rods — hair, cables — has only equal groups). A last
// group of fewer rods is filled with copies of its last rod by the solve.
// Where `lanes` lanes of a rod do not fit a thread's buffer
// (lanes × (cells + 1) > buffer cells), lanes/2 lanes run it (the kernel at
// half width), and so do groups of at most lanes/2 rods (about half the
// work); a group of one rod, or one too long for that, holds one rod
// (the solve runs it in one lane in double, by the scalar kernel in float,
// host/core/step/implicit_solve.h). The groups depend only on the rods of the segment, and
// a rod's result only on the kernel that solves it (not on the other rods of
// its group: the kernel's idle and ghost cells add exact zeros), never on
// the thread count. A rod alone in its group that has at least
// kPartitionMinCells cells is cut into partitions instead (SolveGroup::parts).
// Rods with prescribed velocities besides their reference hold
// (RodInfo::prescribed: a driven tip or interior node with another hold)
// come last, in full groups of their own or alone in one lane, never
// partitioned; their kernel keeps the fixed unknowns' values
// (SolveGroup::lift, kernels/viscous_implicit_lanes.h kLift).
#pragma once

#include <array>
#include <utility>
#include <vector>

#include "host/core/step/workspace.h"
#include "manyrods/batch.h"

namespace manyrods {

// Rods per lane group of the implicit solve (kernels/viscous_implicit_lanes.h):
// one 512-bit vector of float or double (bench/RESULTS.md "Design history"
// has the measurements behind the choice).
template <class T>
inline constexpr int kImplicitLanes = sizeof(T) == 4 ? 16 : 8;

// Cells per partition of a long rod's partitioned solve
// (kernels/viscous_implicit_partitioned.h), and the rods it applies to: those
// the plan would give to the scalar kernel alone, from 4 partitions up.
inline constexpr int kPartitionCells = 64;
inline constexpr int kPartitionMinCells = 4 * kPartitionCells;

// The partitioned solve's values for a rod of `cells` cells at `lanes` lanes,
// k cells per partition:
// 78 arrays of (k + 1)·lanes per lane group, the partitions' hand-over values
// (kPartitionOut each), the separators' system (78 each) and solution (6
// each), rounded up to whole 64-byte lines of doubles.
std::size_t partition_values(int cells, int lanes, int k = kPartitionCells);

// Whether rod `rod` is solved implicitly in a step with (kelvin_voigt) or
// without the Kelvin–Voigt term.
inline bool needs_implicit_solve(const RodInfo& rod, bool kelvin_voigt) {
  return rod.stiff_implicit || (kelvin_voigt && rod.damped);
}

// Appends the groups of segment `seg` to `plan` (lanes per group, a buffer
// of buffer_cells cells per thread) and returns their range [first, last).
// `share` (host/core/step/schedule.h segments_alone): where that leaves one or three groups of rods
// without prescribed velocities, its full ones are cut in halves (lanes/2
// each), which two threads share evenly; a rod's values then come from the
// half-width kernel, on any thread count.
std::pair<int, int> plan_segment(SolvePlan& plan, const std::vector<RodInfo>& rods, const Segment& seg,
                                 int lanes, int buffer_cells, bool kelvin_voigt, bool share = false);

// Both plans of a batch ([0] without, [1] with the Kelvin–Voigt term), with
// each segment's group ranges set.
void build_solve_plans(std::array<SolvePlan, 2>& plans, std::vector<Segment>& segments,
                       const std::vector<RodInfo>& rods, int lanes, int buffer_cells);

}  // namespace manyrods
