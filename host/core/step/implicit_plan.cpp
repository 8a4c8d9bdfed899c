// host/core/step/implicit_plan.cpp — the implicit-solve plan (host/core/step/implicit_plan.h).
#include "host/core/step/implicit_plan.h"

#include <algorithm>
#include <utility>

#include "host/core/step/schedule.h"
#include "kernels/viscous_implicit_partitioned.h"

namespace manyrods {

std::size_t partition_values(int cells, int lanes, int k) {
  const std::size_t parts = std::size_t((cells + k - 1) / k);
  const std::size_t groups = (parts + std::size_t(lanes) - 1) / std::size_t(lanes);
  const std::size_t n = 78 * groups * std::size_t(k + 1) * std::size_t(lanes) +
                        (std::size_t(kPartitionOut) + 78 + 6) * parts;
  return (n + 7) / 8 * 8;
}

std::pair<int, int> plan_segment(SolvePlan& plan, const std::vector<RodInfo>& rods, const Segment& seg,
                                 int lanes, int buffer_cells, bool kelvin_voigt, bool share) {
  plan.lanes = lanes;
  plan.buffer_cells = buffer_cells;
  const int first_rod = int(plan.rods.size()), first_group = int(plan.groups.size());
  for (int i = seg.rod_begin; i < seg.rod_end; ++i)
    if (needs_implicit_solve(rods[i], kelvin_voigt)) plan.rods.push_back(i);
  const auto begin = plan.rods.begin() + first_rod;
  // rods with prescribed velocities (RodInfo::prescribed) go last, in groups
  // of their own: their kernel moves the fixed unknowns' values to the
  // right-hand side (kLift), which the others need not pay for
  const auto lifted = std::stable_partition(begin, plan.rods.end(), [&](int x) { return !rods[x].prescribed; });
  auto by_length = [&](int x, int y) {
    const int ex = rods[x].elements, ey = rods[y].elements;
    return ex != ey ? ex > ey : x < y;
  };
  if (lanes > 1) {
    std::sort(begin, lifted, by_length);
    std::sort(lifted, plan.rods.end(), by_length);
  }
  const int n = int(lifted - plan.rods.begin()), total = int(plan.rods.size());
  const int half_lanes = lanes >= 4 ? lanes / 2 : 1;
  for (int a = first_rod; a < n;) {
    const int cells = rods[plan.rods[a]].elements + 1;
    const bool fits = lanes * (cells + 1) <= buffer_cells;
    const bool fits_half = half_lanes > 1 && half_lanes * (cells + 1) <= buffer_cells;
    const int count = fits ? std::min(lanes, n - a) : fits_half ? std::min(half_lanes, n - a) : 1;
    // a group that half the lanes hold runs at half width (about half the
    // work; the half-width kernel may round differently from the full one,
    // so this depends on the rods only, never on the threads)
    SolveGroup g{a, count, !fits || (half_lanes > 1 && count <= half_lanes)};
    if (count == 1 && lanes > 1 && cells >= kPartitionMinCells) {
      g.half = false;
      g.parts = (cells + kPartitionCells - 1) / kPartitionCells;
      g.offset = plan.partition_values;
      plan.partition_values += partition_values(cells, lanes);
    }
    plan.groups.push_back(g);
    a += count;
  }
  // a segment stepped alone whose groups two threads would not share evenly
  // (one or three of them): its full groups in halves
  const int plain = int(plan.groups.size()) - first_group;
  if (share && half_lanes > 1 && plain % 2 == 1 && plain < 4) {
    std::vector<SolveGroup> cut;
    for (int i = first_group; i < int(plan.groups.size()); ++i) {
      const SolveGroup& g = plan.groups[std::size_t(i)];
      if (g.half || g.parts > 0 || g.count <= half_lanes) {
        cut.push_back(g);
        continue;
      }
      cut.push_back(SolveGroup{g.first, half_lanes, true});
      cut.push_back(SolveGroup{g.first + half_lanes, g.count - half_lanes, true});
    }
    plan.groups.resize(std::size_t(first_group));
    plan.groups.insert(plan.groups.end(), cut.begin(), cut.end());
  }
  // the prescribed ones: full groups, or one rod in one lane (never
  // partitioned)
  for (int a = n; a < total;) {
    const int cells = rods[plan.rods[a]].elements + 1;
    const int count = lanes * (cells + 1) <= buffer_cells ? std::min(lanes, total - a) : 1;
    SolveGroup g{a, count, false};
    g.lift = true;
    plan.groups.push_back(g);
    a += count;
  }
  return {first_group, int(plan.groups.size())};
}

void build_solve_plans(std::array<SolvePlan, 2>& plans, std::vector<Segment>& segments,
                       const std::vector<RodInfo>& rods, int lanes, int buffer_cells) {
  for (int kv = 0; kv < 2; ++kv) {
    plans[kv] = SolvePlan{};
    plans[kv].lanes = lanes;
    plans[kv].buffer_cells = buffer_cells;
    for (Segment& seg : segments) {
      const auto [g0, g1] = plan_segment(plans[kv], rods, seg, lanes, buffer_cells, kv == 1, segments_alone(segments));
      seg.groups_begin[kv] = g0;
      seg.groups_end[kv] = g1;
    }
  }
}

}  // namespace manyrods
