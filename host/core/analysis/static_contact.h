// host/core/analysis/static_contact.h — rod–rod and self contact in the static solve.
//
//   touching_pairs      the element pairs of some rods whose gap is below a
//                       margin (a uniform grid over the elements' midpoints)
//   pair_push           one pair's frictionless push on its four nodes
//   each_push           every push among some rods, node by node
//   pass_through_limit  the fraction of a Newton update that carries no rod
//                       through another; overlap_too_deep: one that did
//   contact_groups      the rods whose boxes (rod_boxes, box_union) overlap,
//                       joined into groups solved together (union–find)
//
// The law is collider_push's (host/core/analysis/static_colliders.h): a pair of
// elements whose gap g (kernels/contact.h pair_geometry: |d| − r_a − r_b,
// or the tight-loop chord for near elements of one rod) is negative pushes
// them apart along d/|d| with
//   p(g) = k g²/(2δ)          −δ < g < 0
//        = k (−g − δ/2)       g ≤ −δ
// k = the smaller of the two elements' axial stiffnesses EA/ℓ, δ = 0.1 ×
// the smaller contact radius: once differentiable at g = 0, so that
// Newton's Jacobian does not jump where two rods meet. The push is shared
// by each element's nodes as the closest points divide it: (1 − s, s) on
// the first, (1 − t, t) on the second. Frictionless.
//
// Reads: state.node_x, contact.elem_radius, contact.elem_rod, contact.rod_near,
// model.elem_stiffness[2], model.elem_rest_length. Writes: nothing of the
// batch.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>
#include <vector>

#include "kernels/contact.h"
#include "manyrods/batch.h"

namespace manyrods::detail {

// Whether the batch's rods meet each other or themselves in a static solve.
inline bool static_rod_contact(const RodBatch<double>& b) {
  return b.contact.on && (b.contact.spec.rod_rod || b.contact.spec.self);
}

struct ElementPair {
  int lo = -1, hi = -1;  // element slots, lo < hi
  friend bool operator==(ElementPair, ElementPair) = default;
};

// The element pairs among the rods `rods` that may touch (rod_pair_allowed)
// and whose gap is below `margin` (m), in (lo, hi) order. The grid's cells
// are as wide as the farthest two midpoints of a pair within the margin can
// lie apart (the longest element, both radii and the margin), so the 27
// cells around an element's hold all its partners.
inline std::vector<ElementPair> touching_pairs(const RodBatch<double>& b, const std::vector<int>& rods,
                                               double margin) {
  std::vector<ElementPair> out;
  const ContactData<double>& c = b.contact;
  const ConstStateView<double> s = b.state_view();
  std::vector<int> elems;
  double widest = 0, rmax = 0;
  for (int r : rods) {
    const RodInfo& rod = b.rods[std::size_t(r)];
    for (int e = 0; e < rod.elements; ++e) {
      const int k = rod.offset + 1 + e;
      elems.push_back(k);
      widest = std::max(widest, norm(load3(s.node_x, k + 1) - load3(s.node_x, k)));
      rmax = std::max(rmax, c.elem_radius[k]);
    }
  }
  if (elems.size() < 2) return out;
  const double cell = widest + 2 * rmax + margin;
  auto key_of = [&](std::int64_t i, std::int64_t j, std::int64_t l) {
    return (i & 0x1fffff) | ((j & 0x1fffff) << 21) | ((l & 0x1fffff) << 42);
  };
  auto cell_of = [&](int k, std::int64_t ijk[3]) {
    const vec3<double> mid = 0.5 * (load3(s.node_x, k) + load3(s.node_x, k + 1));
    for (int a = 0; a < 3; ++a) ijk[a] = std::int64_t(std::floor((&mid.x)[a] / cell));
  };
  std::unordered_map<std::int64_t, std::vector<int>> grid;
  for (int k : elems) {
    std::int64_t ijk[3];
    cell_of(k, ijk);
    grid[key_of(ijk[0], ijk[1], ijk[2])].push_back(k);
  }
  const bool rod_rod = c.spec.rod_rod, self = c.spec.self;
  for (int ka : elems) {
    std::int64_t ijk[3];
    cell_of(ka, ijk);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = grid.find(key_of(ijk[0] + dx, ijk[1] + dy, ijk[2] + dz));
          if (it == grid.end()) continue;
          for (int kb : it->second) {
            if (kb <= ka || !rod_pair_allowed(ka, c.elem_rod[ka], kb, c.elem_rod[kb], rod_rod, self)) continue;
            const int near = pair_near(ka, kb, c.elem_rod.data(), c.rod_near.data());
            if (pair_geometry(ka, kb, s.node_x, c.elem_radius.data(), near).gap < margin) out.push_back({ka, kb});
          }
        }
  }
  std::sort(out.begin(), out.end(), [](ElementPair x, ElementPair y) { return x.lo != y.lo ? x.lo < y.lo : x.hi < y.hi; });
  return out;
}

// Pair p's push on nodes lo, lo + 1, hi, hi + 1 (the law above); false, and
// zero forces, where it does not touch.
inline bool pair_push(const RodBatch<double>& b, ElementPair p, vec3<double> force[4]) {
  const ContactData<double>& c = b.contact;
  const ConstStateView<double> s = b.state_view();
  for (int i = 0; i < 4; ++i) force[i] = {0, 0, 0};
  const int near = pair_near(p.lo, p.hi, c.elem_rod.data(), c.rod_near.data());
  const PairGeometry<double> g = pair_geometry(p.lo, p.hi, s.node_x, c.elem_radius.data(), near);
  if (!(g.gap < 0)) return false;
  const double k = std::min(b.model.elem_stiffness[2][p.lo] / b.model.elem_rest_length[p.lo],
                            b.model.elem_stiffness[2][p.hi] / b.model.elem_rest_length[p.hi]);
  const double delta = 0.1 * std::min(c.elem_radius[p.lo], c.elem_radius[p.hi]);
  const double push = g.gap > -delta ? k * g.gap * g.gap / (2 * delta) : k * (-g.gap - delta / 2);
  const vec3<double> n = contact_detail::unit_or(g.d, g.len, contact_detail::any_orthogonal(g.e_lo));
  force[0] = ((1 - g.s) * push) * n;
  force[1] = (g.s * push) * n;
  force[2] = (-(1 - g.t) * push) * n;
  force[3] = (-g.t * push) * n;
  return true;
}

// The nodes pair_push acts on, in its order.
inline std::array<int, 4> pair_nodes(ElementPair p) { return {p.lo, p.lo + 1, p.hi, p.hi + 1}; }

// add(rod, node slot, force) for each push (pair_push) among the rods
// `rods` on each of its pair's four nodes; the pairs that push go to
// `touching` (if given).
template <class Add>
void each_push(const RodBatch<double>& b, const std::vector<int>& rods, Add&& add,
               std::vector<ElementPair>* touching = nullptr) {
  for (const ElementPair& p : touching_pairs(b, rods, 0.0)) {
    vec3<double> push[4];
    if (!pair_push(b, p, push)) continue;
    if (touching) touching->push_back(p);
    const std::array<int, 4> nodes = pair_nodes(p);
    for (int a = 0; a < 4; ++a) add(b.contact.elem_rod[a < 2 ? p.lo : p.hi], nodes[std::size_t(a)], push[a]);
  }
}

// No pair passes through another in one Newton update: the largest
// fraction α ≤ 1 of the update (move(rod, k): node slot k's displacement,
// of rod `rod`; dmax: the largest) after which no pair of elements of `rods` overlaps by more
// than half its two radii. A pair apart (gap g > 0) closes by at most the
// sum of its elements' largest node moves, Δ (the distance of two segments
// changes by no more than their ends move), so α ≤ (g + ½(r_a + r_b))/Δ; a
// pair in touch closes at the first-order rate of its gap,
// ġ = n·(the closest points' moves), α ≤ (g + ½(r_a + r_b))/(−ġ) where
// ġ < 0. Without it a Newton update (up to StaticOptions::max_update of a
// rod's length) can carry a rod through another, where the push then
// points the wrong way.
template <class Move>
double pass_through_limit(const RodBatch<double>& b, const std::vector<int>& rods, Move&& move, double dmax) {
  if (!(dmax > 0)) return 1;
  const ContactData<double>& c = b.contact;
  const ConstStateView<double> s = b.state_view();
  double alpha = 1;
  for (const ElementPair& p : touching_pairs(b, rods, 2 * dmax)) {
    const int near = pair_near(p.lo, p.hi, c.elem_rod.data(), c.rod_near.data());
    const PairGeometry<double> g = pair_geometry(p.lo, p.hi, s.node_x, c.elem_radius.data(), near);
    const double room = g.gap + 0.5 * (c.elem_radius[p.lo] + c.elem_radius[p.hi]);
    const int ra = c.elem_rod[p.lo], rb = c.elem_rod[p.hi];
    const vec3<double> m[4] = {move(ra, p.lo), move(ra, p.lo + 1), move(rb, p.hi), move(rb, p.hi + 1)};
    double closing;
    if (g.gap > 0) {
      closing = std::max(norm(m[0]), norm(m[1])) + std::max(norm(m[2]), norm(m[3]));
    } else {
      const vec3<double> n = contact_detail::unit_or(g.d, g.len, contact_detail::any_orthogonal(g.e_lo));
      closing = -dot(n, ((1 - g.s) * m[0] + g.s * m[1]) - ((1 - g.t) * m[2] + g.t * m[3]));
    }
    if (closing > room) alpha = std::min(alpha, std::max(0.0, room) / closing);
  }
  return alpha;
}

// Whether some pair of elements of `rods` overlaps by more than half its
// two radii (a hold moved through another rod).
inline bool overlap_too_deep(const RodBatch<double>& b, const std::vector<int>& rods) {
  const ContactData<double>& c = b.contact;
  const ConstStateView<double> s = b.state_view();
  for (const ElementPair& p : touching_pairs(b, rods, 0.0)) {
    const int near = pair_near(p.lo, p.hi, c.elem_rod.data(), c.rod_near.data());
    if (pair_geometry(p.lo, p.hi, s.node_x, c.elem_radius.data(), near).gap < -0.5 * (c.elem_radius[p.lo] + c.elem_radius[p.hi]))
      return true;
  }
  return false;
}

// Each rod's bounding box, its nodes' grown by its largest contact radius:
// [rod] {lo x, y, z, hi x, y, z}.
inline std::vector<std::array<double, 6>> rod_boxes(const RodBatch<double>& b) {
  std::vector<std::array<double, 6>> out(std::size_t(b.rod_count()));
  const ConstStateView<double> s = b.state_view();
  for (int r = 0; r < b.rod_count(); ++r) {
    const RodInfo& rod = b.rods[std::size_t(r)];
    double grow = 0;
    for (int e = 0; e < rod.elements; ++e) grow = std::max(grow, b.contact.elem_radius[rod.offset + 1 + e]);
    std::array<double, 6>& box = out[std::size_t(r)];
    for (int a = 0; a < 3; ++a) box[std::size_t(a)] = 1e300, box[std::size_t(a + 3)] = -1e300;
    for (int j = 0; j <= rod.elements; ++j)
      for (int a = 0; a < 3; ++a) {
        const double x = s.node_x[a][rod.offset + 1 + j];
        box[std::size_t(a)] = std::min(box[std::size_t(a)], x - grow);
        box[std::size_t(a + 3)] = std::max(box[std::size_t(a + 3)], x + grow);
      }
  }
  return out;
}

// The smallest boxes holding both x and y.
inline std::vector<std::array<double, 6>> box_union(std::vector<std::array<double, 6>> x,
                                                    const std::vector<std::array<double, 6>>& y) {
  for (std::size_t r = 0; r < x.size(); ++r)
    for (int a = 0; a < 3; ++a) {
      x[r][std::size_t(a)] = std::min(x[r][std::size_t(a)], y[r][std::size_t(a)]);
      x[r][std::size_t(a + 3)] = std::max(x[r][std::size_t(a + 3)], y[r][std::size_t(a + 3)]);
    }
  return x;
}

// The rods a static solve solves together: rods whose boxes overlap (with
// rod–rod contact; each rod alone without it), and every rod with the rods
// of its group in `joined` (earlier groups), by union–find over a sweep of
// the boxes along x; each group's rods in increasing order, the groups by
// their first rod.
inline std::vector<std::vector<int>> contact_groups(const RodBatch<double>& b,
                                                    const std::vector<std::array<double, 6>>& boxes,
                                                    const std::vector<std::vector<int>>& joined = {}) {
  const int n = b.rod_count();
  std::vector<int> parent(static_cast<std::size_t>(n));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int r) {
    while (parent[std::size_t(r)] != r) r = parent[std::size_t(r)] = parent[std::size_t(parent[std::size_t(r)])];
    return r;
  };
  auto join = [&](int x, int y) {
    x = find(x), y = find(y);
    if (x != y) parent[std::size_t(std::max(x, y))] = std::min(x, y);
  };
  for (const std::vector<int>& g : joined)
    for (int r : g) join(g.front(), r);
  if (static_rod_contact(b) && b.contact.spec.rod_rod) {
    std::vector<int> order(static_cast<std::size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int x, int y) { return boxes[std::size_t(x)][0] < boxes[std::size_t(y)][0]; });
    for (std::size_t i = 0; i < order.size(); ++i) {
      const std::array<double, 6>& bi = boxes[std::size_t(order[i])];
      for (std::size_t j = i + 1; j < order.size() && boxes[std::size_t(order[j])][0] <= bi[3]; ++j) {
        const std::array<double, 6>& bj = boxes[std::size_t(order[j])];
        if (bj[1] <= bi[4] && bi[1] <= bj[4] && bj[2] <= bi[5] && bi[2] <= bj[5]) join(order[i], order[j]);
      }
    }
  }
  std::vector<std::vector<int>> groups;
  std::vector<int> index(static_cast<std::size_t>(n), -1);
  for (int r = 0; r < n; ++r) {
    const int root = find(r);
    if (index[std::size_t(root)] < 0) index[std::size_t(root)] = int(groups.size()), groups.emplace_back();
    groups[std::size_t(index[std::size_t(root)])].push_back(r);
  }
  return groups;
}

}  // namespace manyrods::detail
