// host/core/step/broad_phase.cpp — the rod–rod broad phase of a step, update_neighbours
// (host/core/step/contact_stage.h, docs/contact.md): whether the candidate lists
// are stale, the elements' skins, a sorted uniform grid of element midpoints,
// every element's candidates gathered from it, the wide elements' hand-over, and
// the finished lists in slot order.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "host/core/step/contact_stage.h"
#include "kernels/views.h"
#include "manyrods/isa.h"

namespace manyrods {
namespace {

// Element k's share of a pair's contact range: the kernel's
// δ_ab = h (1 + 2ζ/Ω)(v_a + v_b) + ½ (r_a + r_b) = need_a + need_b
// (kernels/contact.h element_contacts), v_k its fastest node.
template <class T>
double contact_need(const ContactData<T>& c, const ConstStateView<T>& s, int k, double reach) {
  return reach * double(contact_detail::max_speed(s, k)) + 0.5 * double(c.elem_radius[k]);
}

// how far element k's nodes moved since the last build
template <class T>
double moved_since_build(const ContactData<T>& c, const ConstStateView<T>& s, int k) {
  double m = 0;
  for (int i = k; i <= k + 1; ++i) {
    const vec3<T> d = load3(s.node_x, i) - vec3<T>{c.node_x_ref[0][i], c.node_x_ref[1][i], c.node_x_ref[2][i]};
    m = std::max(m, double(norm(d)));
  }
  return m;
}

// Whether the built lists must be rebuilt (reach = h (1 + 2ζ/Ω)).
// The lists stay valid while every element's nodes moved less than its
// skin's margin: a pair left out at the build had gap ≥ s_a + s_b, so now
// gap ≥ s_a + s_b − moved_a − moved_b ≥ need_a + need_b = δ_ab.
template <class T>
bool lists_stale(const ContactData<T>& c, const ConstStateView<T>& s, int n, double reach, const Exec& ex) {
  int stale = 0;
  const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/core/step/fp_env.h)
#pragma omp parallel num_threads(ex.threads) reduction(max : stale) if (ex.threads > 1)
  {
    const RegionFpScope fp(mode);
#pragma omp for
    for (int k = 0; k < n; ++k)
      if (c.elem_rod[k] >= 0 && moved_since_build(c, s, k) + contact_need(c, s, k, reach) > double(c.elem_skin[k]))
        stale = 1;
  }
  return stale != 0;
}

// One build's reaches: what sizes the grid and each element's search.
struct Reaches {
  double lmax = 0;   // m: the longest element
  double s_max = 0;  // m: the widest reach s_k
  double s_thr = 0;  // m: the 99th percentile of the s_k; an element reaching beyond it is wide
};

template <class T>
bool wide(const ContactData<T>& c, const Reaches& re, int k) {
  return double(c.elem_skin[k]) > re.s_thr;
}

// The margin of a moving element, in steps of its own motion: a list
// rebuilt every few steps costs more than the longer lists of the fast
// elements (the 1,000-hair groom with hair–hair contact: 2 steps rebuilt
// 0.85 times a step, 8 steps 0.29 times, the step 1.3× faster;
// bench/RESULTS.md).
constexpr double kMarginSteps = 8;

// Sets each element's reach s_k (ContactData::elem_skin) and returns the
// build's Reaches; none when the batch has no element.
//
// Each element's reach s_k: its contact range now plus a margin for the
// motion until the next build (ContactSpec::skin, by default half its
// radius, and at least kMarginSteps h (1 + 2ζ/Ω) v_k, eight steps of its motion:
// one element's speed widens its own list, not everyone's). Pairs with
// gap < s_a + s_b are kept (at rest: 2 r for equal radii).
template <class T>
std::optional<Reaches> set_skins(ContactData<T>& c, const ConstStateView<T>& s, int n, double reach) {
  std::vector<double> reach_of;  // the s_k of the real elements, for the threshold
  double lmax = 0;
  for (int k = 0; k < n; ++k) {
    if (c.elem_rod[k] < 0) continue;
    const double v = double(contact_detail::max_speed(s, k)), r = double(c.elem_radius[k]);
    const double margin = std::max(c.spec.skin > 0 ? c.spec.skin : 0.5 * r, kMarginSteps * reach * v);
    c.elem_skin[k] = T(contact_need(c, s, k, reach) + margin);
    reach_of.push_back(double(c.elem_skin[k]));
    lmax = std::max(lmax, double(norm(load3(s.node_x, k + 1) - load3(s.node_x, k))));
  }
  if (reach_of.empty()) return std::nullopt;
  // Elements reaching beyond the 99th percentile are "wide" (whipping tips):
  // the grid's cell is sized for the others, a wide element searches as many
  // cells as its own reach needs and hands its pairs to its narrow partners.
  const double s_max = *std::max_element(reach_of.begin(), reach_of.end());
  const std::size_t q = (reach_of.size() * 99) / 100;
  std::nth_element(reach_of.begin(), reach_of.begin() + std::ptrdiff_t(q), reach_of.end());
  const double s_thr = reach_of[q];
  return Reaches{lmax, s_max, s_thr};
}

// element k's midpoint along an axis
template <class T>
double midpoint(const ConstStateView<T>& s, int k, int axis) {
  return 0.5 * (double(s.node_x[axis][k]) + double(s.node_x[axis][k + 1]));
}

// The grid holds element midpoints: its cells' elements are
// ContactData::cell_slot[cell_start[i] .. cell_start[i+1]), and `lo`, `hi`
// their segments' boxes grown by their radius and skin, in that order (the
// box test streams them).
struct CellGrid {
  double gmin[3] = {1e300, 1e300, 1e300}, gmax[3] = {-1e300, -1e300, -1e300};  // the midpoints' bounding box
  std::int64_t dim[3] = {};                                                      // cells per axis
  double inv = 0;                                                                // 1 / the cell's edge
  int real = 0;                                                                  // the elements it holds
  std::array<std::vector<double>, 3> lo, hi;  // the segments' boxes, grown by r + skin, in grid order

  std::int64_t cell_at(double x, int a) const {
    const double i = std::floor((x - gmin[a]) * inv);
    return i >= 0 ? (i < double(dim[a] - 1) ? std::int64_t(i) : dim[a] - 1) : std::int64_t(0);  // NaN: 0
  }
  std::size_t index(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return std::size_t((z * dim[1] + y) * dim[0] + x);
  }
};

// The grid's shape: the midpoints' bounding box, and over it a dense grid,
// at most ~4 cells per element (coarser cells only add candidates the tests
// drop).
template <class T>
CellGrid shape_grid(const ContactData<T>& c, const ConstStateView<T>& s, int n, const Reaches& re) {
  CellGrid g;
  for (int k = 0; k < n; ++k) {
    if (c.elem_rod[k] < 0) continue;
    ++g.real;
    for (int a = 0; a < 3; ++a) {
      g.gmin[a] = std::min(g.gmin[a], midpoint(s, k, a));
      g.gmax[a] = std::max(g.gmax[a], midpoint(s, k, a));
    }
  }
  double cell = 0.5 * (re.lmax + 2 * c.max_radius + 2 * re.s_thr);
  for (;;) {
    double total = 1;
    for (int a = 0; a < 3; ++a) {
      g.dim[a] = std::int64_t(std::floor((g.gmax[a] - g.gmin[a]) / cell)) + 1;
      total *= double(g.dim[a]);
    }
    if (total <= 4.0 * g.real + 64) break;
    cell *= 1.25;
  }
  g.inv = 1 / cell;
  return g;
}

// Fills the shaped grid: a counting sort by cell, each cell's elements in
// slot order (ContactData::cell_start, cell_slot), then the midpoints in
// grid order.
template <class T>
void fill_grid(ContactData<T>& c, const ConstStateView<T>& s, int n, CellGrid& g) {
  c.cell_start.assign(std::size_t(g.dim[0] * g.dim[1] * g.dim[2]) + 1, 0);
  c.cell_slot.resize(std::size_t(g.real));
  std::vector<std::size_t> cell_of(std::size_t(n), 0);
  for (int k = 0; k < n; ++k) {
    if (c.elem_rod[k] < 0) continue;
    cell_of[std::size_t(k)] =
        g.index(g.cell_at(midpoint(s, k, 0), 0), g.cell_at(midpoint(s, k, 1), 1), g.cell_at(midpoint(s, k, 2), 2));
    ++c.cell_start[cell_of[std::size_t(k)] + 1];
  }
  for (std::size_t i = 1; i < c.cell_start.size(); ++i) c.cell_start[i] += c.cell_start[i - 1];
  {
    std::vector<int> fill(c.cell_start.begin(), c.cell_start.end() - 1);
    for (int k = 0; k < n; ++k)
      if (c.elem_rod[k] >= 0) c.cell_slot[std::size_t(fill[cell_of[std::size_t(k)]]++)] = k;
  }
  for (int a = 0; a < 3; ++a) {
    g.lo[a].resize(std::size_t(g.real));
    g.hi[a].resize(std::size_t(g.real));
    for (int i = 0; i < g.real; ++i) {
      const int k = c.cell_slot[std::size_t(i)];
      const double x0 = double(s.node_x[a][k]), x1 = double(s.node_x[a][k + 1]);
      const double grow = double(c.elem_radius[k]) + double(c.elem_skin[k]);
      g.lo[a][std::size_t(i)] = std::min(x0, x1) - grow;
      g.hi[a][std::size_t(i)] = std::max(x0, x1) + grow;
    }
  }
}

// Element a's (k's) partners b with gap < s_a + s_b among the midpoints in
// its box (a narrow a: the narrow b; a wide a: all b), each passed to take.
// A partner b with gap < s_a + s_b has its closest point within
// s_a + s_b + r_a + r_b of a's segment and its midpoint ½ l_b beyond that:
// per axis inside a's bounding box grown by
// D_a = s_a + s_b,max + r_a + r_max + ½ l_max. Each element visits the
// cells that box covers (a long, thin element visits a slab, not a cube),
// row by row along x, and tests their elements' grown segment boxes against
// its own (overlapping boxes imply a midpoint in its box).
template <class T, class Take>
void gather(const ContactData<T>& c, const ConstStateView<T>& s, const Reaches& re, const CellGrid& g, int k,
            Take&& take) {
  const int ra = c.elem_rod[k];
  const double D = double(c.elem_skin[k]) + (wide(c, re, k) ? re.s_max : re.s_thr) + double(c.elem_radius[k]) +
                   c.max_radius + 0.5 * re.lmax;
  const double grow = double(c.elem_radius[k]) + double(c.elem_skin[k]);
  double lo[3], hi[3], own_lo[3], own_hi[3];  // own: a's segment box grown by r_a + s_a
  std::int64_t c0[3], c1[3];
  for (int a = 0; a < 3; ++a) {
    const double x0 = double(s.node_x[a][k]), x1 = double(s.node_x[a][k + 1]);
    lo[a] = std::min(x0, x1) - D;
    hi[a] = std::max(x0, x1) + D;
    own_lo[a] = std::min(x0, x1) - grow;
    own_hi[a] = std::max(x0, x1) + grow;
    c0[a] = g.cell_at(lo[a], a);
    c1[a] = g.cell_at(hi[a], a);
  }
  for (std::int64_t cz = c0[2]; cz <= c1[2]; ++cz)
    for (std::int64_t cy = c0[1]; cy <= c1[1]; ++cy) {
      const int first = c.cell_start[g.index(c0[0], cy, cz)], last = c.cell_start[g.index(c1[0], cy, cz) + 1];
      for (int i = first; i < last; ++i) {
        const std::size_t u = std::size_t(i);
        // grown segment boxes apart: the segments are at least r_a + s_a +
        // r_b + s_b apart, so the gap test below would drop b too (one
        // branch: most of the cells' elements are not near a)
        const bool near = (g.lo[0][u] < own_hi[0]) & (own_lo[0] < g.hi[0][u]) & (g.lo[1][u] < own_hi[1]) &
                          (own_lo[1] < g.hi[1][u]) & (g.lo[2][u] < own_hi[2]) & (own_lo[2] < g.hi[2][u]);
        if (!near) continue;
        const int kb = c.cell_slot[u], rb = c.elem_rod[kb];
        if (!wide(c, re, k) && wide(c, re, kb)) continue;  // handed over by kb
        if (!rod_pair_allowed(k, ra, kb, rb, c.spec.rod_rod, c.spec.self)) continue;
        // (the gap at r_a + r_b: a near pair's is larger, so the list holds it early)
        const T gap = pair_geometry(std::min(k, kb), std::max(k, kb), s.node_x, c.elem_radius.data()).gap;
        if (double(gap) < double(c.elem_skin[k]) + double(c.elem_skin[kb])) take(kb);
      }
    }
}

// element k's candidate list (cap = ContactSpec::capacity entries)
template <class T>
int* neighbour_list(ContactData<T>& c, int k, int cap) {
  return c.neighbours.data() + std::size_t(k) * std::size_t(cap);
}

// Every element's candidates into its list, the first `capacity` of them;
// returns how many each found (may exceed the capacity).
template <class T>
std::vector<int> gather_candidates(ContactData<T>& c, const ConstStateView<T>& s, int n, const Reaches& re,
                                   const CellGrid& g, const Exec& ex) {
  const int cap = c.capacity;
  std::vector<int> count(std::size_t(n), 0);  // candidates found (may exceed cap)
  const RegionFpMode mode = RegionFpMode::of_caller();
#pragma omp parallel num_threads(ex.threads) if (ex.threads > 1)
  {
    const RegionFpScope fp(mode);
#pragma omp for schedule(dynamic, kGuard)
    for (int k = 0; k < n; ++k) {
      int m = 0;
      if (c.elem_rod[k] >= 0)
        gather(c, s, re, g, k, [&](int kb) {
          if (m < cap) neighbour_list(c, k, cap)[m] = kb;
          ++m;
        });
      count[std::size_t(k)] = m;
    }
  }
  return count;
}

// the wide elements' narrow partners, handed over in (partner, wide) order
template <class T>
void hand_over(ContactData<T>& c, int n, const Reaches& re, std::vector<int>& count) {
  const int cap = c.capacity;
  std::vector<std::pair<int, int>> handed;
  for (int k = 0; k < n; ++k) {
    if (c.elem_rod[k] < 0 || !wide(c, re, k)) continue;
    const int m = std::min(count[std::size_t(k)], cap);
    for (int j = 0; j < m; ++j)
      if (!wide(c, re, neighbour_list(c, k, cap)[j])) handed.push_back({neighbour_list(c, k, cap)[j], k});
  }
  std::sort(handed.begin(), handed.end());
  for (const auto& [kb, k] : handed) {
    int& m = count[std::size_t(kb)];
    if (m < cap) neighbour_list(c, kb, cap)[m] = k;
    ++m;
  }
}

// the error for element k's list, which found more candidates than the lists
// may hold (max_capacity, or the machine's memory: `limit`)
template <class T>
std::runtime_error list_overflow(const RodBatch<T>& b, int k, int found, const std::string& limit) {
  const ContactData<T>& c = b.contact;
  const int r = c.elem_rod[k];
  std::ostringstream os;
  os << "contact: element " << k - b.rods[r].offset - 1 << " of rod " << r << " ('" << b.rods[r].name << "') has "
     << found << " rod-rod candidates within its skin (" << double(c.elem_skin[k]) << " m), more than " << limit
     << ", at step " << b.state.steps << " (t = " << b.state.time << " s): lower the skin ([contact] skin) or "
     << "raise [contact] max_capacity";
  return std::runtime_error(os.str());
}

// The capacity for lists of up to `most` candidates: at least double the
// present one (so that a pile that keeps packing grows the lists a few
// times, not every step), at most spec.max_capacity; throws list_overflow
// when `most` does not fit in max_capacity or in the machine's memory.
template <class T>
int grown_capacity(const RodBatch<T>& b, int n, const std::vector<int>& count) {
  const ContactData<T>& c = b.contact;
  int k_most = 0;
  for (int k = 1; k < n; ++k)
    if (count[std::size_t(k)] > count[std::size_t(k_most)]) k_most = k;
  const int most = count[std::size_t(k_most)];
  if (most > c.spec.max_capacity)
    throw list_overflow(b, k_most, most, "max_capacity = " + std::to_string(c.spec.max_capacity));
  const int cap = std::max(most, int(std::min<std::int64_t>(2 * std::int64_t(c.capacity), c.spec.max_capacity)));
  const double bytes = double(n) * double(cap) * double(sizeof(int));
  const double memory = double(physical_memory());
  if (memory > 0 && bytes > 0.5 * memory) {
    std::ostringstream os;
    os.precision(3);
    os << "the memory for lists of " << cap << " (" << bytes / 1e9 << " GB, over half of this machine's "
       << memory / 1e9 << " GB)";
    throw list_overflow(b, k_most, most, os.str());
  }
  return cap;
}

// Finishes the lists (every count within the capacity): their lengths, and
// each list in slot order (the contact sums do not depend on the grid, the
// skins, the capacity or when the lists were built, docs/contact.md); records
// the positions the lists were built at.
template <class T>
void finish_lists(RodBatch<T>& b, const ConstStateView<T>& s, int n, const std::vector<int>& count) {
  ContactData<T>& c = b.contact;
  const int cap = c.capacity;
  for (int k = 0; k < n; ++k) {
    c.neighbour_count[k] = count[std::size_t(k)];
    std::sort(neighbour_list(c, k, cap), neighbour_list(c, k, cap) + c.neighbour_count[k]);
  }
  for (int d = 0; d < 3; ++d)
    for (int k = 0; k < n; ++k) c.node_x_ref[d][k] = s.node_x[d][k];
  c.built = true;
  ++c.rebuilds;
}

}  // namespace

template <class T>
void update_neighbours(RodBatch<T>& b, T h, const Exec& ex) {
  ContactData<T>& c = b.contact;
  if (!(c.spec.rod_rod || c.spec.self)) return;
  const ConstStateView<T> s = std::as_const(b).state_view();
  const int n = b.slots();
  const double reach = double(h) * (1 + 2 * c.spec.damping_ratio / c.spec.hardness);
  if (c.built && !lists_stale(c, s, n, reach, ex)) return;
  const std::optional<Reaches> re = set_skins(c, s, n, reach);
  if (!re) return;  // no element to list
  CellGrid g = shape_grid(c, s, n, *re);
  fill_grid(c, s, n, g);
  std::vector<int> count = gather_candidates(c, s, n, *re, g, ex);
  hand_over(c, n, *re, count);
  while (*std::max_element(count.begin(), count.end()) > c.capacity) {
    // a list overflowed: all grow, and are gathered again (the same lists,
    // so the same step, as with this capacity from the start; again if a
    // wide element's list, cut short, had not handed over all its partners)
    c.capacity = grown_capacity(b, n, count);
    c.neighbours.resize(std::size_t(n) * std::size_t(c.capacity), -1);
    ++c.list_growths;
    count = gather_candidates(c, s, n, *re, g, ex);
    hand_over(c, n, *re, count);
  }
  finish_lists(b, s, n, count);
}

#define MANYRODS_BROAD_PHASE_INSTANTIATE(T) template void update_neighbours<T>(RodBatch<T>&, T, const Exec&);
MANYRODS_BROAD_PHASE_INSTANTIATE(float)
MANYRODS_BROAD_PHASE_INSTANTIATE(double)

}  // namespace manyrods
