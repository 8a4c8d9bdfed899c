// host/core/step/contact_solve.h — collider and self contacts inside the
// implicit solve (kernels/contact_solve.h; docs/contact.md "Contact inside
// the implicit solve"):
//
//   contact_solve_save    the velocities before the solve (u⁻), per slot
//   contact_solve_stage   after the solve: each rod the solve steps finds
//                         its collider and self contacts (with rod contact
//                         on, from the broad phase's lists, built before
//                         this stage) at the solve's geometry and,
//                         if one acts, is solved again from u⁻ keeping its
//                         factors, its contacts' impulses are solved with
//                         its Delassus operator and it takes them through
//                         the factors
//
// A rod no collider reaches pays one pass over its elements. A rod with a
// reference hold (a driven root) is solved relative to the hold's rigid
// motion, as the solve does (host/core/step/implicit_solve.h shift_hold);
// the contacts' response leaves that motion alone, so they are solved in
// the lab frame. Each rod is solved on its own, by the scalar kernel, in a
// fixed order of its contacts: the result does not depend on the thread
// count.
#pragma once

#include <omp.h>

#include <algorithm>
#include <cstddef>
#include <stdexcept>

#include "host/core/step/contact_stage.h"
#include "host/core/step/implicit_solve.h"
#include "kernels/contact_solve.h"

namespace manyrods {

// u⁻ of the slots of r, before the implicit solve.
// reads: state.node_v, elem_w  writes: contact.v_solve, w_solve
template <class T>
void contact_solve_save(RodBatch<T>& b, const Exec& ex, const Segment& r) {
  const ConstStateView<T> cs = std::as_const(b).state_view();
  const ContactView<T> cv = contact_view(b, static_cast<const ColliderFrame<T>*>(nullptr));
  detail::for_slots(r.begin, r.end, ex, [&](int k) {
    store3(cv.v_solve, k, load3(cs.node_v, k));
    store3(cv.w_solve, k, load3(cs.elem_w, k));
  });
}

namespace detail {

// Rod `ri`'s collider contacts and (ContactView::self_solved) self contacts
// in range at the solve's geometry, into buf.contacts (kernels/
// contact_solve.h): the ranges and geometry of the stage's
// (kernels/contact.h element_contacts), each self pair once, from its lower
// element's list. Returns whether one acts on its own at the velocities the
// first solve gave (if none does, none acts).
template <class T>
bool find_solve_contacts(RodBatch<T>& b, int ri, T h, const ContactView<T>& cv, ContactSolveBuffer<T>& buf) {
  using namespace contact_detail;
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> st = std::as_const(b).state_view();
  const RodInfo& rod = b.rods[std::size_t(ri)];
  const int first = rod.offset + 1, cells = rod.elements + 1;
  buf.contacts.clear();
  buf.weight.assign(std::size_t(cells), T(0));  // the contacts on each node
  const T reach = h * (T(1) + T(2) * cv.damping_ratio / cv.hardness);
  for (int e = 0; e < rod.elements; ++e) {
    const int k = first + e;
    const vec3<T> x0 = load3(st.node_x, k), x1 = load3(st.node_x, k + 1), ed = x1 - x0;
    const T r = cv.elem_radius[k], el = norm(ed);
    const vec3<T> axis = unit_or(ed, el, vec3<T>{T(0), T(0), T(1)});
    const T va = max_speed(st, k);
    for (int i = 0; i < cv.collider_count; ++i) {
      const ColliderFrame<T>& c = cv.colliders[i];
      touches_in_range(c, x0, x1, r, va, reach, [&](const Touch<T>& t) {
        SolveContact<T> sc;
        sc.k = k;
        sc.s = t.s;
        sc.gap = t.gap;
        sc.n = t.n;
        sc.axis = axis;
        sc.vp = collider_velocity(c, x0 + t.s * ed + (-r) * t.n);
        pair_mu(cv.rod_mu + 4 * ri, cv.rod_mu_own[ri] != 0, c.mu, true, sc.mu);
        if (t.s < T(1)) buf.weight[std::size_t(k - first)] += T(1);
        if (t.s > T(0)) buf.weight[std::size_t(k + 1 - first)] += T(1);
        buf.contacts.push_back(sc);
      });
    }
    if (cv.self_solved(ri)) {
      const int near = cv.rod_near[ri];
      const int* list = cv.neighbours + std::size_t(k) * std::size_t(cv.capacity);
      for (int j = 0; j < cv.neighbour_count[k]; ++j) {
        const int kb = list[j];
        if (kb <= k || cv.elem_rod[kb] != ri) continue;
        const PairGeometry<T> g = pair_geometry(k, kb, st.node_x, cv.elem_radius, near);
        if (!(g.gap < reach * (va + max_speed(st, kb)) + pair_margin(k, kb, near, cv.elem_radius))) continue;
        SolveContact<T> sc;
        sc.k = k;
        sc.s = g.s;
        sc.k2 = kb;
        sc.t = g.t;
        sc.gap = g.gap;
        sc.n = unit_or(g.d, g.len, any_orthogonal(g.e_lo));
        sc.axis = axis;
        rod_pair_mu(cv, ri, ri, sc.mu);
        if (g.s < T(1)) buf.weight[std::size_t(k - first)] += T(1);
        if (g.s > T(0)) buf.weight[std::size_t(k + 1 - first)] += T(1);
        if (g.t < T(1)) buf.weight[std::size_t(kb - first)] += T(1);
        if (g.t > T(0)) buf.weight[std::size_t(kb + 1 - first)] += T(1);
        buf.contacts.push_back(sc);
      }
    }
  }
  // the contacts' masses (kernels/contact.h element_side; a self contact's
  // two sides in series); a contact between two held nodes is none. Two elements' contacts at their shared
  // node with one law (the same gap, normal, collider velocity and
  // friction, isotropic) are one contact of their summed mass: their laws
  // add up to its law exactly, and a pair of identical rows in W would
  // leave the split between them undetermined (the sweeps crawl).
  std::size_t kept = 0;
  bool any = false;
  const T b_law = cv.hardness * cv.hardness + T(2) * cv.damping_ratio * cv.hardness;
  auto same_law = [](const SolveContact<T>& p, const SolveContact<T>& q) {
    return p.k2 < 0 && q.k2 < 0 && p.gap == q.gap && p.n.x == q.n.x && p.n.y == q.n.y && p.n.z == q.n.z && p.vp.x == q.vp.x &&
           p.vp.y == q.vp.y && p.vp.z == q.vp.z && p.mu[0] == q.mu[0] && p.mu[1] == q.mu[1] && p.mu[2] < T(0) &&
           q.mu[2] < T(0);
  };
  for (SolveContact<T>& c : buf.contacts) {
    T w = contact_compliance(c.s, m.node_inv_mass[c.k], m.node_inv_mass[c.k + 1],
                             buf.weight[std::size_t(c.k - first)], buf.weight[std::size_t(c.k + 1 - first)]);
    if (c.k2 >= 0)
      w += contact_compliance(c.t, m.node_inv_mass[c.k2], m.node_inv_mass[c.k2 + 1],
                              buf.weight[std::size_t(c.k2 - first)], buf.weight[std::size_t(c.k2 + 1 - first)]);
    if (!(w > T(0))) continue;
    c.a = T(1) / w;
    // acting on its own at the free solve's velocities ((S1): λ > 0)
    const T vn = dot(c.n, point_velocity(c, st.node_v) - c.vp);
    any = any || c.gap + h * (b_law / (cv.hardness * cv.hardness)) * vn < T(0);
    bool merged = false;
    if (c.s == T(0))
      for (std::size_t i = kept; i-- > 0 && buf.contacts[i].k >= c.k - 1;)
        if (buf.contacts[i].k == c.k - 1 && buf.contacts[i].s == T(1) && same_law(buf.contacts[i], c)) {
          buf.contacts[i].a += c.a;
          merged = true;
          break;
        }
    if (!merged) buf.contacts[kept++] = c;
  }
  buf.contacts.resize(kept);
  return any;
}

// Rod ri's contacts (buf.contacts) through its factored system f: their
// Delassus operator, their impulses by projected block Gauss–Seidel
// (kernels/contact_solve.h), the rod's response to them from the factors
// (added to its velocities, the free solve's on entry), their work into
// contact.work.
template <class Tf, class T>
void contacts_through_factors(RodBatch<T>& b, int ri, T h, const ContactView<T>& cv, ContactSolveBuffer<T>& buf,
                              const FactorView<Tf>& f) {
  const StateView<T> s = b.state_view();
  const RodInfo& rod = b.rods[std::size_t(ri)];
  const int first = rod.offset + 1, cells = rod.elements + 1;
  std::vector<SolveContact<T>>& cs = buf.contacts;
  const int nc = int(cs.size());
  int low = cells;
  for (const SolveContact<T>& c : cs) low = std::min(low, c.k - first);
  buf.x.resize(std::size_t(18) * std::size_t(cells));
  double* const x = buf.x.data();
  // The contacts in the solve (in: those that act on their own at the free
  // velocities, then any the others' impulses make act) are buf.members, in
  // the order they joined; W over them only: W_ij = J_i A⁻¹ J_jᵀ of members
  // at places a = place[i], b = place[j] is the block at 9 (a cap + b),
  // row-major. A contact in range that never acts costs no column and no
  // row (a coiled rod has hundreds of near self pairs in range, a tenth of
  // them acting).
  std::vector<int>& members = buf.members;
  std::vector<int>& place = buf.place;
  members.clear();
  buf.joining.clear();
  place.assign(std::size_t(nc), -1);
  int cap = 0;
  auto block = [&](int i, int j) {
    return buf.delassus.data() + 9 * (std::ptrdiff_t(place[std::size_t(i)]) * cap + place[std::size_t(j)]);
  };
  auto reserve = [&](int need) {  // room for `need` members (grown by doubling, kept across rods)
    if (need <= cap) return;
    const int grown = std::max({need, 2 * cap, 16});
    if (buf.spare.size() < std::size_t(9) * std::size_t(grown) * std::size_t(grown))
      buf.spare.resize(std::size_t(9) * std::size_t(grown) * std::size_t(grown));
    const int in = int(members.size());
    for (int r = 0; r < in; ++r)
      std::copy(buf.delassus.data() + 9 * std::ptrdiff_t(r) * cap, buf.delassus.data() + 9 * (std::ptrdiff_t(r) * cap + in),
                buf.spare.data() + 9 * std::ptrdiff_t(r) * grown);
    std::swap(buf.delassus, buf.spare);
    cap = grown;
  };
  // J_i of the solved columns x (cell c's unknown d of column e at
  // x[3 (6c + d) + e]): 3×3, row-major
  auto project = [&](const SolveContact<T>& c, T* out) {
    const double* x0 = x + 18 * (c.k - first);
    for (int e = 0; e < 9; ++e) out[e] = T((1 - double(c.s)) * x0[e] + double(c.s) * x0[18 + e]);
    if (c.k2 >= 0) {
      const double* x2 = x + 18 * (c.k2 - first);
      for (int e = 0; e < 9; ++e) out[e] -= T((1 - double(c.t)) * x2[e] + double(c.t) * x2[18 + e]);
    }
  };
  // contact j joins: its three columns solved together, back to the first
  // contact's cell; its row is its column's transpose (W is symmetric)
  auto join = [&](int j) {
    reserve(int(members.size()) + 1);
    place[std::size_t(j)] = int(members.size());
    members.push_back(j);
    cs[std::size_t(j)].in = true;
    std::fill(x + 18 * low, x + 18 * cells, 0.0);
    const SolveContact<T>& cj = cs[std::size_t(j)];
    const int kj = cj.k - first;  // (a self contact's partner k2 > k: the solve still starts at k)
    for (int d = 0; d < 3; ++d) {
      x[3 * (6 * kj + d) + d] = double(T(1) - cj.s);
      x[3 * (6 * (kj + 1) + d) + d] = double(cj.s);
      if (cj.k2 >= 0) {
        x[3 * (6 * (cj.k2 - first) + d) + d] = -double(T(1) - cj.t);
        x[3 * (6 * (cj.k2 + 1 - first) + d) + d] = -double(cj.t);
      }
    }
    viscous_solve_factored<3>(f, cells, kj, low, x);
    for (const int i : members) {
      project(cs[std::size_t(i)], block(i, j));
      if (i == j) {  // symmetric in exact arithmetic
        T* w = block(j, j);
        for (int e = 0; e < 3; ++e)
          for (int d = e + 1; d < 3; ++d) w[3 * e + d] = w[3 * d + e] = T(0.5) * (w[3 * e + d] + w[3 * d + e]);
      } else {
        const T* wij = block(i, j);
        T* wji = block(j, i);
        for (int e = 0; e < 3; ++e)
          for (int d = 0; d < 3; ++d) wji[3 * d + e] = wij[3 * e + d];
      }
    }
  };
  auto mat = [&](int i, int j) {
    mat3<T> r;
    const T* w = block(i, j);
    for (int e = 0; e < 9; ++e) r.m[e] = w[e];
    return r;
  };
  const T b_law = cv.hardness * cv.hardness + T(2) * cv.damping_ratio * cv.hardness;
  auto acts = [&](const SolveContact<T>& c, vec3<T> v) {  // (S1): λ > 0 with no impulse of its own
    return c.gap + h * (b_law / (cv.hardness * cv.hardness)) * dot(c.n, v - c.vp) < T(0);
  };
  T scale = T(0);
  for (SolveContact<T>& c : cs) {
    c.p = vec3<T>{T(0), T(0), T(0)};
    c.v = point_velocity(c, s.node_v);  // the free solve's (kept for those not in the solve)
    c.in = false;
    // its approach speed and, if it overlaps, the normal law's push-out
    // speed (a contact in range but apart adds no speed of its own)
    scale = std::max(scale, norm(c.v - c.vp) + cv.hardness * cv.hardness * std::max(T(0), -c.gap) / (h * b_law));
  }
  for (int j = 0; j < nc; ++j)
    if (acts(cs[std::size_t(j)], cs[std::size_t(j)].v)) join(j);
  // the rod's response to the impulses, Δu = A⁻¹ Σ J_iᵀ p_i, into x (6 per cell)
  auto response = [&]() {
    std::fill(x, x + 6 * cells, 0.0);
    for (const int i : members) {
      const SolveContact<T>& c = cs[std::size_t(i)];
      const double p3[3] = {double(c.p.x), double(c.p.y), double(c.p.z)};
      for (int d = 0; d < 3; ++d) {
        x[6 * (c.k - first) + d] += (1 - double(c.s)) * p3[d];
        x[6 * (c.k + 1 - first) + d] += double(c.s) * p3[d];
        if (c.k2 >= 0) {
          x[6 * (c.k2 - first) + d] -= (1 - double(c.t)) * p3[d];
          x[6 * (c.k2 + 1 - first) + d] -= double(c.t) * p3[d];
        }
      }
    }
    viscous_solve_factored<1>(f, cells, low, 0, x);
  };
  // projected block Gauss–Seidel over the contacts in the solve, in their
  // order, until a sweep moves no contact point's velocity by more than the
  // tolerance of the contacts' velocity scale (the impulses' split between
  // contacts that a stiff rod joins rigidly may converge far more slowly:
  // it moves nothing), or until the sweeps cycle (their largest move has
  // not halved in kContactStallSweeps sweeps: kernels/contact_solve.h);
  // then any contact that the impulses make act joins (its velocity from
  // the rod's response), and the sweeps go on
  bool added = !members.empty(), fresh = false;  // fresh: x holds the response to the impulses as they stand
  while (added) {
    T best = T(0);  // the smallest largest move so far, halving
    int best_at = 0;
    for (int sweep = 0; sweep < kMaxContactSweeps; ++sweep) {
      T moved = T(0);
      for (int i = 0; i < nc; ++i) {
        SolveContact<T>& c = cs[std::size_t(i)];
        if (!c.in) continue;
        const mat3<T> wii = mat(i, i);
        const vec3<T> v0 = c.v;
        const vec3<T> p = contact_local_impulse(c, wii, c.v - mul(wii, c.p), h, cv.hardness, cv.damping_ratio);
        const vec3<T> dp = p - c.p;
        if (dp.x != T(0) || dp.y != T(0) || dp.z != T(0))
          for (const int j : members) cs[std::size_t(j)].v = cs[std::size_t(j)].v + mul(mat(j, i), dp);
        c.p = p;
        moved = std::max(moved, norm(c.v - v0));
      }
      if (!(moved > kContactSweepTolerance<T> * scale)) break;
      if (sweep == 0 || moved < T(0.5) * best) {
        best = moved;
        best_at = sweep;
      }
      if (sweep - best_at >= kContactStallSweeps) break;
    }
    if (int(members.size()) == nc) break;
    response();
    fresh = true;
    for (int j = 0; j < nc; ++j) {
      SolveContact<T>& c = cs[std::size_t(j)];
      if (c.in) continue;
      const double* x0 = x + 6 * (c.k - first);
      vec3<T> dv{T((1 - double(c.s)) * x0[0] + double(c.s) * x0[6]), T((1 - double(c.s)) * x0[1] + double(c.s) * x0[7]),
                 T((1 - double(c.s)) * x0[2] + double(c.s) * x0[8])};
      if (c.k2 >= 0) {
        const double* x2 = x + 6 * (c.k2 - first);
        dv = dv - vec3<T>{T((1 - double(c.t)) * x2[0] + double(c.t) * x2[6]),
                          T((1 - double(c.t)) * x2[1] + double(c.t) * x2[7]),
                          T((1 - double(c.t)) * x2[2] + double(c.t) * x2[8])};
      }
      if (!acts(c, c.v + dv)) continue;
      c.v = c.v + dv;
      buf.joining.push_back(j);
    }
    for (const int j : buf.joining) join(j);  // (after every check: a column overwrites x)
    added = !buf.joining.empty();
    fresh = fresh && !added;
    buf.joining.clear();
  }
  // the rod's response: u⁺ = u_f + A⁻¹ Σ J_iᵀ p_i
  if (!fresh) response();
  for (int c = 0; c < cells; ++c)
    for (int d = 0; d < 3; ++d) {
      s.node_v[d][first + c] += T(x[6 * c + d]);
      s.elem_w[d][first + c] += T(x[6 * c + 3 + d]);
    }
  // the work of the impulses, P·(v_n + v_{n+1})/2 at the point (a self
  // contact: on both of its points, with the relative velocity)
  for (const SolveContact<T>& c : cs)
    if (c.p.x != T(0) || c.p.y != T(0) || c.p.z != T(0))
      cv.work[c.k] += T(0.5) * dot(c.p, point_velocity(c, cv.v_start) + point_velocity(c, s.node_v));
}

// Kept factors' pointers into buf (kKeepValues arrays of n values).
template <class Tf>
void keep_pointers(std::vector<Tf>& buf, int n, Tf* (&kp)[kKeepValues]) {
  buf.resize(std::size_t(kKeepValues) * std::size_t(n));
  for (int a = 0; a < kKeepValues; ++a) kp[a] = buf.data() + std::size_t(a) * std::size_t(n);
}

// Lane `lane` of a group of W lanes, its rod's cell c the group's cell start + c.
template <class Tf>
FactorView<Tf> factor_view(Tf* const (&kp)[kKeepValues], const ImplicitScratchView<Tf>& sc, int W, int lane,
                           int start) {
  FactorView<Tf> f;
  for (int a = 0; a < kKeepValues; ++a) f.keep[a] = kp[a];
  for (int i = 0; i < 36; ++i) f.G[i] = sc.G[i];
  f.W = W;
  f.lane = lane;
  f.start = start;
  return f;
}

// Rod ri's reference hold in segment r (its driven root), or −1.
template <class T>
int reference_hold(const RodBatch<T>& b, const Segment& r, int ri) {
  int hold = -1;
  for (int i = r.driven_begin; i < r.driven_end; ++i)
    if (b.driven[std::size_t(i)].rod == ri && b.driven[std::size_t(i)].reference) hold = i;
  return hold;
}

// u⁻ (saved by contact_solve_save) back into rod ri.
template <class T>
void restore_pre_solve(RodBatch<T>& b, int ri, const ContactView<T>& cv) {
  const StateView<T> s = b.state_view();
  const RodInfo& rod = b.rods[std::size_t(ri)];
  for (int c = 0; c <= rod.elements; ++c) {
    store3(s.node_v, rod.offset + 1 + c, load3(cv.v_solve, rod.offset + 1 + c));
    store3(s.elem_w, rod.offset + 1 + c, load3(cv.w_solve, rod.offset + 1 + c));
  }
}

// Rods rods[0 … count) (count ≤ W, each with a contact that acts)
// solved again from u⁻ as one lane group of W lanes in Tc (kernels/
// viscous_implicit_lanes.h, as the solve does, its factors kept), then each
// rod's contacts through its lane's factors.
template <Terms kKernel, int W, class Tc, class T>
void solve_group_with_contacts(RodBatch<T>& b, const int* rods, int count, T h, const ContactView<T>& cv,
                               ContactSolveBuffer<T>& buf, std::vector<Tc>& keep, const ImplicitScratchView<Tc>& sc,
                               const Segment& r) {
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  int first[W], cells[W], hold[W], n = 0;  // hold: each rod's reference hold, or −1
  T stiff_h[W];
  for (int j = 0; j < W; ++j) {  // a group short of W fills up with its last rod
    hold[j] = -1;
    const RodInfo& rod = b.rods[std::size_t(rods[j < count ? j : count - 1])];
    first[j] = rod.offset + 1;
    cells[j] = rod.elements + 1;
    stiff_h[j] = rod.stiff_implicit ? h : T(0);
    n = std::max(n, cells[j]);
  }
  n += 1;  // the root ghost cell (see viscous_implicit_lanes)
  for (int j = 0; j < count; ++j) {
    restore_pre_solve(b, rods[j], cv);
    hold[j] = reference_hold(b, r, rods[j]);
    if (hold[j] >= 0) shift_hold(b, hold[j], T(-1));
  }
  Tc* kp[kKeepValues];
  keep_pointers(keep, W * n, kp);
  viscous_implicit_lanes<kKernel, W, true>(first, cells, h, stiff_h, m, s, sc, kp);
  for (int j = 0; j < count; ++j)
    if (hold[j] >= 0) shift_hold(b, hold[j], T(1));
  for (int j = 0; j < count; ++j)
    if (find_solve_contacts(b, rods[j], h, cv, buf))
      contacts_through_factors(b, rods[j], h, cv, buf, factor_view(kp, sc, W, j, n - cells[j]));
}

// Rod ri with prescribed velocities (the scalar kernel, as the solve takes
// it: its delta form), solved again from u⁻ with its factors kept, then
// its contacts through them.
template <Terms kKernel, class T>
void solve_prescribed_with_contacts(RodBatch<T>& b, int ri, T h, const ContactView<T>& cv, ContactSolveBuffer<T>& buf,
                                    const ImplicitScratchView<T>& sc, const Segment& r) {
  const RodInfo& rod = b.rods[std::size_t(ri)];
  const int hold = reference_hold(b, r, ri);
  restore_pre_solve(b, ri, cv);
  if (hold >= 0) shift_hold(b, hold, T(-1));
  T* kp[kKeepValues];
  keep_pointers(buf.keep, rod.elements + 1, kp);
  viscous_implicit_rod<kKernel>(rod.offset + 1, rod.elements + 1, h, rod.stiff_implicit ? h : T(0), b.model_view(),
                                b.state_view(), sc, kp);
  if (hold >= 0) shift_hold(b, hold, T(1));
  if (find_solve_contacts(b, ri, h, cv, buf)) contacts_through_factors(b, ri, h, cv, buf, factor_view(kp, sc, 1, 0, 0));
}

}  // namespace detail

// The stage on the rods of segment r that the solve steps (kSolve: the
// solve's Terms), after the solve: which rods have a collider or self
// contact that acts (a pass over the rods), then those rods again in lane groups of the
// solve's width (in double for a float batch's stiff rods, one by one with
// prescribed velocities), each group's rods in their order: the result does
// not depend on the thread count.
// reads: model, state, contact data and lists, colliders  writes: state.node_v, elem_w
// of the rods with an acting contact, contact.work
template <Terms kSolve, class T>
void contact_solve_stage(RodBatch<T>& b, T h, const ColliderFrame<T>* frames, const Exec& ex, const Segment& r,
                         int thread) {
  constexpr Terms kKernel = detail::solve_kernel_terms(kSolve);
  constexpr int W = kImplicitLanes<T>, kWide = kImplicitLanes<double>;
  const ContactView<T> cv = contact_view(b, frames, kSolve.kelvin_voigt, kSolve.rod_contact);
  if (cv.collider_count == 0 && cv.self_in_solve == 0) return;
  // one buffer per thread, reserved by the driver before its parallel
  // region (host/core/step/integrators.h prepare_solve); a call from
  // elsewhere (one thread) grows them here
  std::vector<ContactSolveBuffer<T>>& bufs = b.workspace->contact_solve;
  const int need = std::max(ex.threads, thread + 1);
  if (int(bufs.size()) < need) {
    if (omp_in_parallel()) throw std::logic_error("contact_solve_stage: buffers not reserved before a parallel region");
    bufs.resize(std::size_t(need));
  }
  const bool parallel = ex.threads > 1 && r.rod_end - r.rod_begin > 1;
  const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/core/step/fp_env.h)
  // which rods: 1 in a lane group, 2 in a lane group in double (a float
  // batch's stiff rod), 3 prescribed; 4, 5: as 1, 2 but alone in one lane
  // (a rod too long for a group in the thread's buffer, as the solve's
  // partitioned ones)
  ContactSolveBuffer<T>& own = bufs[std::size_t(thread)];
  own.kind.assign(std::size_t(r.rod_end - r.rod_begin), 0);
  const int room = b.workspace->visc_cells;
  auto which = [&](int ri, int t) {
    if (!cv.colliders_in_solve(ri) || !detail::find_solve_contacts(b, ri, h, cv, bufs[std::size_t(t)])) return;
    const RodInfo& rod = b.rods[std::size_t(ri)];
    const bool wide = sizeof(T) < sizeof(double) && rod.stiff_implicit && ex.stiff_solve_in_double;
    const bool fits = (wide ? kWide : W) * (rod.elements + 2) <= room;
    own.kind[std::size_t(ri - r.rod_begin)] = char(rod.prescribed ? 3 : wide ? (fits ? 2 : 5) : (fits ? 1 : 4));
  };
  if (parallel) {
#pragma omp parallel num_threads(ex.threads)
    {
      const RegionFpScope fp(mode);
#pragma omp for schedule(dynamic, 16)
      for (int ri = r.rod_begin; ri < r.rod_end; ++ri) which(ri, omp_get_thread_num());
    }
  } else {
    for (int ri = r.rod_begin; ri < r.rod_end; ++ri) which(ri, thread);
  }
  // the jobs: {kind, first in own.rods, count}
  own.rods.clear();
  own.jobs.clear();
  for (int kind = 1; kind <= 5; ++kind) {
    const int width = kind == 1 ? W : kind == 2 ? kWide : 1;
    for (int ri = r.rod_begin; ri < r.rod_end; ++ri) {
      if (own.kind[std::size_t(ri - r.rod_begin)] != kind) continue;
      if (own.jobs.empty() || own.jobs.back()[0] != kind || own.jobs.back()[2] == width)
        own.jobs.push_back({kind, int(own.rods.size()), 0});
      own.rods.push_back(ri);
      ++own.jobs.back()[2];
    }
  }
  auto job = [&](const std::array<int, 3>& jb, int t) {
    ContactSolveBuffer<T>& buf = bufs[std::size_t(t)];
    const int* rods = own.rods.data() + jb[1];
    if (jb[0] == 1) {
      detail::solve_group_with_contacts<kKernel, W>(b, rods, jb[2], h, cv, buf, buf.keep, b.implicit_scratch_view(t, 0),
                                                    r);
    } else if (jb[0] == 2) {
      if constexpr (sizeof(T) < sizeof(double))
        detail::solve_group_with_contacts<kKernel, kWide>(b, rods, jb[2], h, cv, buf, buf.keep_wide,
                                                          b.wide_implicit_scratch_view(t), r);
    } else if (jb[0] == 3) {
      detail::solve_prescribed_with_contacts<kKernel>(b, rods[0], h, cv, buf, b.implicit_scratch_view(t, 0), r);
    } else if (jb[0] == 4) {
      detail::solve_group_with_contacts<kKernel, 1>(b, rods, 1, h, cv, buf, buf.keep, b.implicit_scratch_view(t, 0), r);
    } else if constexpr (sizeof(T) < sizeof(double)) {
      detail::solve_group_with_contacts<kKernel, 1>(b, rods, 1, h, cv, buf, buf.keep_wide,
                                                    b.wide_implicit_scratch_view(t), r);
    }
  };
  const int jobs = int(own.jobs.size());
  if (parallel && jobs > 1) {
#pragma omp parallel num_threads(ex.threads)
    {
      const RegionFpScope fp(mode);
#pragma omp for schedule(dynamic, 1)
      for (int i = 0; i < jobs; ++i) job(own.jobs[std::size_t(i)], omp_get_thread_num());
    }
  } else {
    for (int i = 0; i < jobs; ++i) job(own.jobs[std::size_t(i)], thread);
  }
}

}  // namespace manyrods
