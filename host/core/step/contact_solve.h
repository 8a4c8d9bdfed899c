// host/core/step/contact_solve.h — collider, self and rod–rod contacts
// inside the implicit solve (kernels/contact_solve.h; docs/contact.md "Contact inside
// the implicit solve"):
//
//   contact_solve_save           the velocities before the solve (u⁻), per slot
//   viscous_update_with_contacts the implicit solve with the collider
//                                contacts of its lane groups' rods: each
//                                group solved with its factors kept, its
//                                rods' contacts found at once and, where one
//                                acts, solved through the factors, the
//                                group's rods together (one per SIMD lane)
//   contact_solve_stage          after the solve, the rest: each rod the solve
//                                steps that it did not take (a float
//                                batch's stiff rod, a partitioned
//                                long rod; every rod with
//                                self contact, whose lists the broad phase
//                                builds after the solve) finds its collider
//                                and self contacts at the solve's geometry
//                                and, if one acts, is solved again from u⁻
//                                keeping its factors, and its contacts'
//                                impulses are solved with its Delassus
//                                operator and taken through the factors;
//                                with rod–rod contact, on the whole batch,
//   rod_contacts_in_solve        every rod with a contact that acts and the
//                                rods pairs join to it, solved again keeping
//                                its factors, their contacts (colliders,
//                                self, other rods) swept together
//
// A rod no collider reaches pays one pass over its elements. A rod with a
// reference hold (a driven root) is solved relative to the hold's rigid
// motion, as the solve does (host/core/step/implicit_solve.h shift_hold);
// the contacts' response leaves that motion alone, so they are solved in
// the lab frame. Each rod's contacts are solved in a fixed order, its own
// arithmetic in its lane: the result does not depend on the thread count.
#pragma once

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <functional>
#include <stdexcept>
#include <type_traits>

#include "host/core/step/contact_stage.h"
#include "host/core/step/implicit_solve.h"
#include "kernels/contact_solve.h"

namespace manyrods {

// u⁻ of the slots of r, before the implicit solve.
// (and the solve's contact impulses cleared)
// reads: state.node_v, elem_w  writes: contact.v_solve, w_solve, q0, q1
template <class T>
void contact_solve_save(RodBatch<T>& b, const Exec& ex, const Segment& r) {
  const ConstStateView<T> cs = std::as_const(b).state_view();
  const ContactView<T> cv = contact_view(b, static_cast<const ColliderFrame<T>*>(nullptr));
  const vec3<T> zero{T(0), T(0), T(0)};
  detail::for_slots(r.begin, r.end, ex, [&](int k) {
    store3(cv.v_solve, k, load3(cs.node_v, k));
    store3(cv.w_solve, k, load3(cs.elem_w, k));
    store3(cv.q0, k, zero);
    store3(cv.q1, k, zero);
  });
}

namespace detail {

// Rod `ri`'s collider contacts and (ContactView::self_solved) self contacts
// in range at the solve's geometry, into buf.contacts (its first slot and
// cells into buf.first, buf.cells; kernels/
// contact_solve.h): the ranges and geometry of the stage's
// (kernels/contact.h element_contacts), each self pair once, from its lower
// element's list. Returns whether one acts on its own at the velocities the
// first solve gave (if none does, none acts).
template <class T>
bool find_solve_contacts(RodBatch<T>& b, int ri, T h, const ContactView<T>& cv, RodContacts<T>& buf) {
  using namespace contact_detail;
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> st = std::as_const(b).state_view();
  const RodInfo& rod = b.rods[std::size_t(ri)];
  const int first = rod.offset + 1, cells = rod.elements + 1;
  buf.first = first;
  buf.cells = cells;
  buf.contacts.clear();
  buf.pairs = 0;
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
        sc.collider = i;
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
    if (cv.rods_in_solve != 0 && cv.colliders_in_solve(ri)) {
      // another rod's elements the solve steps too (S4): each pair's geometry
      // from its lower slot (pair_geometry), the same on both sides; in range
      // where it can push within the step (the stage's test, kernels/
      // contact.h element_contacts, with its guard); the partner's velocity
      // predicted by the free solve's
      const int* list = cv.neighbours + std::size_t(k) * std::size_t(cv.capacity);
      for (int j = 0; j < cv.neighbour_count[k]; ++j) {
        const int kb = list[j], rb = cv.elem_rod[kb];
        if (!cv.pair_solved(ri, rb)) continue;
        const int lo = k < kb ? k : kb, hi = k < kb ? kb : k;
        const PairGeometry<T> g = pair_geometry(lo, hi, st.node_x, cv.elem_radius, 0);
        if (!(g.gap < reach * (va + max_speed(st, kb)) + T(1e-3) * (cv.elem_radius[lo] + cv.elem_radius[hi])))
          continue;
        const vec3<T> n_lo = unit_or(g.d, g.len, any_orthogonal(g.e_lo));  // towards lo's point
        SolveContact<T> sc;
        sc.k = k;
        sc.s = k == lo ? g.s : g.t;
        sc.kb = kb;
        sc.partner = rb;
        sc.t = k == lo ? g.t : g.s;
        sc.gap = g.gap;
        sc.n = k == lo ? n_lo : T(-1) * n_lo;
        sc.axis = axis;
        sc.vp = (T(1) - sc.t) * load3(st.node_v, kb) + sc.t * load3(st.node_v, kb + 1);
        rod_pair_mu(cv, ri, rb, sc.mu);
        if (sc.s < T(1)) buf.weight[std::size_t(k - first)] += T(1);
        if (sc.s > T(0)) buf.weight[std::size_t(k + 1 - first)] += T(1);
        buf.contacts.push_back(sc);
        ++buf.pairs;
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
  auto same_law = [](const SolveContact<T>& p, const SolveContact<T>& q) {
    return p.k2 < 0 && q.k2 < 0 && p.kb < 0 && q.kb < 0 && p.gap == q.gap && p.n.x == q.n.x && p.n.y == q.n.y && p.n.z == q.n.z && p.vp.x == q.vp.x &&
           p.vp.y == q.vp.y && p.vp.z == q.vp.z && p.mu[0] == q.mu[0] && p.mu[1] == q.mu[1] && p.mu[2] < T(0) &&
           q.mu[2] < T(0);
  };
  for (SolveContact<T>& c : buf.contacts) {
    T w = contact_compliance(c.s, m.node_inv_mass[c.k], m.node_inv_mass[c.k + 1],
                             buf.weight[std::size_t(c.k - first)], buf.weight[std::size_t(c.k + 1 - first)]);
    if (c.k2 >= 0)
      w += contact_compliance(c.t, m.node_inv_mass[c.k2], m.node_inv_mass[c.k2 + 1],
                              buf.weight[std::size_t(c.k2 - first)], buf.weight[std::size_t(c.k2 + 1 - first)]);
    if (c.kb >= 0) {  // its mass once both sides are known (pair_contacts); kept on a held point too
      c.own_compliance = w;
      any = any || contact_acts(c, point_velocity(c, st.node_v), h, cv.hardness, cv.damping_ratio);
      buf.contacts[kept++] = c;
      continue;
    }
    if (!(w > T(0))) continue;
    c.a = T(1) / w;
    // acting on its own at the free solve's velocities
    any = any || contact_acts(c, point_velocity(c, st.node_v), h, cv.hardness, cv.damping_ratio);
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
  if (!any) b.contact.solve_impulses[std::size_t(ri)].clear();  // (none acts: no guess for the next step)
  return any;
}

template <class T>
bool nonzero(vec3<T> v) {
  return v.x != T(0) || v.y != T(0) || v.z != T(0);
}

// Rod rc's contacts' impulses at the end of its last solve, where the same
// contact is found again (ContactData::solve_impulses: the same element and
// what it touches, the normal within 60°, the point on the element the
// nearest: a rod lying on a plane touches it at both ends of an element), into
// rc.last_p (0: none); the rod's record emptied (its finish writes this
// step's). Both lists are in element order (find_solve_contacts, finish).
template <class T>
void take_last_impulses(RodBatch<T>& b, RodContacts<T>& rc) {
  std::vector<SolveImpulse<T>>& last = b.contact.solve_impulses[std::size_t(rc.rod)];
  rc.last_p.assign(rc.contacts.size(), vec3<T>{T(0), T(0), T(0)});
  std::size_t from = 0;
  for (std::size_t i = 0; i < rc.contacts.size(); ++i) {
    const SolveContact<T>& c = rc.contacts[i];
    while (from < last.size() && last[from].k < c.k) ++from;
    T nearest = T(2);
    for (std::size_t e = from; e < last.size() && last[e].k == c.k; ++e) {
      const SolveImpulse<T>& l = last[e];
      if (l.collider != c.collider || l.k2 != c.k2 || l.kb != c.kb || l.partner != c.partner) continue;
      if (!(l.n[0] * c.n.x + l.n[1] * c.n.y + l.n[2] * c.n.z > T(0.5))) continue;
      const T apart = std::abs(l.s - c.s);
      if (apart < nearest) {
        nearest = apart;
        rc.last_p[i] = vec3<T>{l.p[0], l.p[1], l.p[2]};
      }
    }
  }
  last.clear();
}

// W_ij of rod contacts i, j in the solve (RodContacts::delassus: the
// block of members at places a = place[i], b = place[j] at 9 (a cap + b),
// row-major), where it is stored and as a matrix.
template <class T>
T* delassus_at(RodContacts<T>& rc, int i, int j) {
  return rc.delassus.data() + 9 * (std::ptrdiff_t(rc.place[std::size_t(i)]) * rc.cap + rc.place[std::size_t(j)]);
}
template <class T>
mat3<T> delassus_block(RodContacts<T>& rc, int i, int j) {
  mat3<T> r;
  const T* w = delassus_at(rc, i, j);
  for (int e = 0; e < 9; ++e) r.m[e] = w[e];
  return r;
}

// Rod rc's contact velocities after an impulse change dp at contact j:
// v_q += W_qj dp for every contact q in the solve. W_qj is read as W_jqᵀ,
// which is stored as its exact transpose (group_contacts_through_factors
// join_round: W_jj symmetrized, W_ji copied from W_ij), so the result is
// the same to the bit; W_jq for all q is row j, contiguous (the members
// in the order of their places), where column j is strided by the capacity.
template <class T>
void add_delassus_column(RodContacts<T>& rc, int j, vec3<T> dp) {
  if (!nonzero(dp)) return;
  for (const int q : rc.members)
    rc.contacts[std::size_t(q)].v = rc.contacts[std::size_t(q)].v + mul_transpose(delassus_block(rc, j, q), dp);
}

// One Gauss–Seidel update of rod rc's contact i (a collider or self
// contact in the solve): its impulse from its law (kernels/contact_solve.h
// (S1)–(S3)) with the others' fixed, the rod's contact velocities through
// W's column i; returns how far its own velocity moved.
template <class T>
T sweep_contact(RodContacts<T>& rc, int i, T h, const ContactView<T>& cv) {
  SolveContact<T>& c = rc.contacts[std::size_t(i)];
  const mat3<T> wii = delassus_block(rc, i, i);
  const vec3<T> v0 = c.v;
  const vec3<T> p = contact_local_impulse(c, wii, c.v - mul(wii, c.p), h, cv.hardness, cv.damping_ratio);
  add_delassus_column(rc, i, p - c.p);
  c.p = p;
  return norm(c.v - v0);
}

// What a call of group_contacts_through_factors does: solo, all of it (the
// rods' contacts solved, their response taken); with rod–rod contacts in the
// solve (rod_contacts_in_solve, which sweeps all rods' contacts together),
// its parts: begin (the contacts that act at the free velocities join:
// their columns of W), join (the joining contacts' columns), check (the
// response to the impulses so far, and the contacts it makes act marked
// joining) and finish (the response taken).
enum class GroupMode { solo, begin, join, check, finish };

// Pointers to a thread buffer's first w lanes (ContactSolveBuffer::lanes_for).
template <class T, int W>
std::array<RodContacts<T>*, W> lane_pointers(ContactSolveBuffer<T>& buf) {
  std::array<RodContacts<T>*, W> p;
  RodContacts<T>* l = buf.lanes_for(W);
  for (int j = 0; j < W; ++j) p[std::size_t(j)] = l + j;
  return p;
}

// The contacts of the rods of one lane group (their RodContacts in
// buf.lanes, filled by find_solve_contacts; lanes[l].rod < 0: none acts)
// through the group's kept factors (keep, and G in the scratch; group cell
// c of lane l: kernels/viscous_implicit_lanes.h viscous_solve_factored_lanes,
// rod cell c of lane l at group cell lanes[l].start + c): each rod's
// Delassus operator over its contacts in the solve, their impulses by
// projected block Gauss–Seidel (kernels/contact_solve.h), the rod's
// response to them from the factors (added to its velocities, the free
// solve's on entry), their work into contact.work. The rods are independent;
// their columns and responses are solved together, one rod per lane, so
// that each load of the factors serves every lane. A rod's result is that
// of solving it alone (each lane's arithmetic is the one-rod solve's).
template <int Wg, class Tc, class T>
void group_contacts_through_factors(RodBatch<T>& b, T h, const ContactView<T>& cv, ContactSolveBuffer<T>& buf,
                                    RodContacts<T>* const* lanes, Tc* const* keep, Tc* const* G, int n,
                                    GroupMode mode = GroupMode::solo) {
  const StateView<T> s = b.state_view();
  // The contacts in the solve of a rod (in: those that act on their own at
  // the free velocities, then any the others' impulses make act) are its
  // `members`, in the order they joined; W over them only: W_ij = J_i A⁻¹ J_jᵀ
  // (delassus_at). A contact in range that never acts costs no
  // column and no row (a coiled rod has hundreds of near self pairs in
  // range, a tenth of them acting).
  auto block = [](RodContacts<T>& rc, int i, int j) { return delassus_at(rc, i, j); };
  auto reserve = [](RodContacts<T>& rc, int need) {  // room for `need` members (grown by doubling, kept across rods)
    if (need <= rc.cap) return;
    const int grown = std::max({need, 2 * rc.cap, 16});
    if (rc.spare.size() < std::size_t(9) * std::size_t(grown) * std::size_t(grown))
      rc.spare.resize(std::size_t(9) * std::size_t(grown) * std::size_t(grown));
    const int in = int(rc.members.size());
    for (int r = 0; r < in; ++r)
      std::copy(rc.delassus.data() + 9 * std::ptrdiff_t(r) * rc.cap,
                rc.delassus.data() + 9 * (std::ptrdiff_t(r) * rc.cap + in),
                rc.spare.data() + 9 * std::ptrdiff_t(r) * grown);
    std::swap(rc.delassus, rc.spare);
    rc.cap = grown;
  };
  // x: 3 columns per lane (a joining contact's) or 1 (the response), lane
  // innermost (viscous_solve_factored_lanes); value (cell c, unknown i,
  // column j, lane l) of the 3-column x at ((6c + i)·3 + j)·Wg + l
  buf.x.resize(std::size_t(18) * std::size_t(Wg) * std::size_t(n));
  double* const x = buf.x.data();
  auto x3 = [&](int l, int c, int i, int j) -> double& { return x[((6 * std::ptrdiff_t(c) + i) * 3 + j) * Wg + l]; };
  auto x1 = [&](int l, int c, int i) -> double& { return x[(6 * std::ptrdiff_t(c) + i) * Wg + l]; };
  const T b_law = cv.hardness * cv.hardness + T(2) * cv.damping_ratio * cv.hardness;
  auto acts = [&](const SolveContact<T>& c, vec3<T> v) { return contact_acts(c, v, h, cv.hardness, cv.damping_ratio); };
  // the node cells (group cells) and weights of a contact's point, its
  // partner's for a self contact (weight −)
  auto points = [](const RodContacts<T>& rc, const SolveContact<T>& c, int (&cell)[4], double (&w)[4]) {
    const int base = rc.start - rc.first;
    cell[0] = base + c.k, cell[1] = base + c.k + 1, w[0] = 1 - double(c.s), w[1] = double(c.s);
    if (c.k2 >= 0) {
      cell[2] = base + c.k2, cell[3] = base + c.k2 + 1, w[2] = -(1 - double(c.t)), w[3] = -double(c.t);
      return 4;
    }
    return 2;
  };
  // J_i of lane l's solved columns: 3×3, row-major
  auto project = [&](int l, const RodContacts<T>& rc, const SolveContact<T>& c, T* out) {
    int cell[4];
    double w[4];
    const int np = points(rc, c, cell, w);
    for (int d = 0; d < 3; ++d)
      for (int e = 0; e < 3; ++e) {
        double v = 0;
        for (int q = 0; q < np; ++q) v += w[q] * x3(l, cell[q], d, e);
        out[3 * d + e] = T(v);
      }
  };
  // the lanes' next joining contacts (rc.joining[rc.next]), one per lane,
  // their three columns solved together; each row is its column's
  // transpose (W is symmetric)
  auto joins = [](const RodContacts<T>& rc) { return rc.rod >= 0 && rc.next < int(rc.joining.size()); };
  auto join_round = [&]() {
    int from = n, to = n, any = 0;
    for (int l = 0; l < Wg; ++l) {
      RodContacts<T>& rc = *lanes[l];
      if (!joins(rc)) continue;
      const SolveContact<T>& cj = rc.contacts[std::size_t(rc.joining[std::size_t(rc.next)])];
      from = std::min(from, rc.start + cj.k - rc.first);
      to = std::min(to, rc.start + rc.low);
      any = 1;
    }
    if (!any) return false;
    std::fill(x + std::ptrdiff_t(18) * Wg * std::min(from, to), x + std::ptrdiff_t(18) * Wg * n, 0.0);
    for (int l = 0; l < Wg; ++l) {
      RodContacts<T>& rc = *lanes[l];
      if (!joins(rc)) continue;
      int cell[4];
      double w[4];
      const int np = points(rc, rc.contacts[std::size_t(rc.joining[std::size_t(rc.next)])], cell, w);
      for (int q = 0; q < np; ++q)
        for (int d = 0; d < 3; ++d) x3(l, cell[q], d, d) += w[q];
    }
    viscous_solve_factored_lanes<3, Wg>(keep, G, n, from, to, x);
    for (int l = 0; l < Wg; ++l) {
      RodContacts<T>& rc = *lanes[l];
      if (!joins(rc)) continue;
      const int j = rc.joining[std::size_t(rc.next++)];
      reserve(rc, int(rc.members.size()) + 1);
      rc.place[std::size_t(j)] = int(rc.members.size());
      rc.members.push_back(j);
      rc.contacts[std::size_t(j)].in = true;
      for (const int i : rc.members) {
        project(l, rc, rc.contacts[std::size_t(i)], block(rc, i, j));
        if (i == j) {  // symmetric in exact arithmetic
          T* wjj = block(rc, j, j);
          for (int e = 0; e < 3; ++e)
            for (int d = e + 1; d < 3; ++d) wjj[3 * e + d] = wjj[3 * d + e] = T(0.5) * (wjj[3 * e + d] + wjj[3 * d + e]);
        } else {
          const T* wij = block(rc, i, j);
          T* wji = block(rc, j, i);
          for (int e = 0; e < 3; ++e)
            for (int d = 0; d < 3; ++d) wji[3 * d + e] = wij[3 * e + d];
        }
      }
    }
    return true;
  };
  // the rods' responses to their impulses, Δu = A⁻¹ Σ J_iᵀ p_i, into x
  // (1 column), for the lanes in `open`
  auto response = [&]() {
    int from = n, to = n;
    for (int l = 0; l < Wg; ++l)
      if (lanes[l]->rod >= 0 && lanes[l]->open) {
        from = std::min(from, lanes[l]->start + lanes[l]->low);
        to = std::min(to, lanes[l]->start);
      }
    std::fill(x + std::ptrdiff_t(6) * Wg * to, x + std::ptrdiff_t(6) * Wg * n, 0.0);
    for (int l = 0; l < Wg; ++l) {
      RodContacts<T>& rc = *lanes[l];
      if (rc.rod < 0 || !rc.open) continue;
      for (const int i : rc.members) {
        const SolveContact<T>& c = rc.contacts[std::size_t(i)];
        const double p3[3] = {double(c.p.x), double(c.p.y), double(c.p.z)};
        int cell[4];
        double w[4];
        const int np = points(rc, c, cell, w);
        for (int q = 0; q < np; ++q)
          for (int d = 0; d < 3; ++d) x1(l, cell[q], d) += w[q] * p3[d];
      }
    }
    viscous_solve_factored_lanes<1, Wg>(keep, G, n, from, to, x);
  };
  // projected block Gauss–Seidel over a rod's contacts in the solve, in
  // their order, until a sweep moves no contact point's velocity by more
  // than the tolerance of the contacts' velocity scale (the impulses' split
  // between contacts that a stiff rod joins rigidly may converge far more
  // slowly: it moves nothing), or until the sweeps cycle (their largest move
  // has not halved in kContactStallSweeps sweeps: kernels/contact_solve.h)
  auto sweeps = [&](RodContacts<T>& rc) {
    const int nc = int(rc.contacts.size());
    T best = T(0);  // the smallest largest move so far, halving
    int best_at = 0;
    for (int sweep = 0; sweep < kMaxContactSweeps; ++sweep) {
      T moved = T(0);
      for (int i = 0; i < nc; ++i)
        if (rc.contacts[std::size_t(i)].in) moved = std::max(moved, sweep_contact(rc, i, h, cv));
      if (!(moved > kContactSweepTolerance<T> * rc.scale)) break;
      if (sweep == 0 || moved < T(0.5) * best) {
        best = moved;
        best_at = sweep;
      }
      if (sweep - best_at >= kContactStallSweeps) break;
    }
  };
  // the rod's response into its velocities: u⁺ = u_f + A⁻¹ Σ J_iᵀ p_i; the
  // work of the impulses, P·(v_n + v_{n+1})/2 at the point (a self contact:
  // on both of its points, with the relative velocity)
  auto finish = [&](int l) {
    RodContacts<T>& rc = *lanes[l];
    for (int c = 0; c < rc.cells; ++c)
      for (int d = 0; d < 3; ++d) {
        s.node_v[d][rc.first + c] += T(x1(l, rc.start + c, d));
        s.elem_w[d][rc.first + c] += T(x1(l, rc.start + c, 3 + d));
      }
    std::vector<SolveImpulse<T>>& last = b.contact.solve_impulses[std::size_t(rc.rod)];
    last.clear();
    for (const SolveContact<T>& c : rc.contacts)
      if (nonzero(c.p)) {
        last.push_back({c.k, c.collider, c.k2, c.kb, c.partner, c.s, {c.n.x, c.n.y, c.n.z}, {c.p.x, c.p.y, c.p.z}});
        cv.work[c.k] += T(0.5) * dot(c.p, point_velocity(c, cv.v_start) + point_velocity(c, s.node_v));
        store3(cv.q0, c.k, load3(cv.q0, c.k) + (T(1) - c.s) * c.p);  // (reported, as the stage's elem_p0, p1)
        store3(cv.q1, c.k, load3(cv.q1, c.k) + c.s * c.p);
        if (c.k2 >= 0) {
          store3(cv.q0, c.k2, load3(cv.q0, c.k2) - (T(1) - c.t) * c.p);
          store3(cv.q1, c.k2, load3(cv.q1, c.k2) - c.t * c.p);
        }
      }
    rc.open = false;
  };
  // the sweeps start from the last step's impulses (a warm start) of the
  // rod's collider and self contacts: c.v = v_free + Σ_j W_ij p_j
  // (rod_contacts_in_solve starts the pairs, both sides at once)
  auto start_from_last = [&]() {
    for (int l = 0; l < Wg; ++l) {
      RodContacts<T>& rc = *lanes[l];
      if (rc.rod < 0) continue;
      for (const int j : rc.members) {
        SolveContact<T>& c = rc.contacts[std::size_t(j)];
        const vec3<T> p = rc.last_p[std::size_t(j)];
        if (c.kb >= 0 || !nonzero(p)) continue;
        c.p = p;
        add_delassus_column(rc, j, p);
      }
    }
  };
  if (mode == GroupMode::finish) {  // the rods' responses to their impulses, into their velocities
    for (int l = 0; l < Wg; ++l) lanes[l]->open = lanes[l]->rod >= 0 && !lanes[l]->members.empty();
    response();
    for (int l = 0; l < Wg; ++l)
      if (lanes[l]->rod >= 0 && lanes[l]->open) finish(l);
    return;
  }
  // start: every rod's contacts that act at the free velocities join
  for (int l = 0; l < (mode == GroupMode::solo || mode == GroupMode::begin ? Wg : 0); ++l) {
    RodContacts<T>& rc = *lanes[l];
    if (rc.rod < 0) continue;
    const int nc = int(rc.contacts.size());
    rc.low = rc.cells;
    for (const SolveContact<T>& c : rc.contacts) rc.low = std::min(rc.low, c.k - rc.first);
    rc.members.clear();
    rc.joining.clear();
    rc.next = 0;
    rc.cap = 0;
    rc.place.assign(std::size_t(nc), -1);
    rc.scale = T(0);
    for (SolveContact<T>& c : rc.contacts) {
      c.p = vec3<T>{T(0), T(0), T(0)};
      c.v = point_velocity(c, s.node_v);  // the free solve's (kept for those not in the solve)
      c.in = false;
      // its approach speed and, if it overlaps, the normal law's push-out
      // speed (a contact in range but apart adds no speed of its own)
      rc.scale = std::max(rc.scale, norm(c.v - c.vp) + cv.hardness * cv.hardness * std::max(T(0), -c.gap) / (h * b_law));
    }
    // those that act, and those with an impulse at the last step (their
    // first guess; rod_contacts_in_solve took them for its rods)
    if (mode == GroupMode::solo) take_last_impulses(b, rc);
    for (int j = 0; j < nc; ++j)
      if (nonzero(rc.last_p[std::size_t(j)]) || acts(rc.contacts[std::size_t(j)], rc.contacts[std::size_t(j)].v))
        rc.joining.push_back(j);
    rc.open = !rc.joining.empty();
    for (SolveContact<T>& c : rc.contacts) c.v_now = c.v;
  }
  // the contacts not in the solve of the open rods: their velocities from
  // the response in x (kept in v_now), those that act join
  auto check = [&](int l) {
    RodContacts<T>& rc = *lanes[l];
    const int nc = int(rc.contacts.size());
    if (int(rc.members.size()) < nc)
      for (int j = 0; j < nc; ++j) {
        SolveContact<T>& c = rc.contacts[std::size_t(j)];
        if (c.in) continue;
        int cell[4];
        double w[4];
        const int np = points(rc, c, cell, w);
        double dv[3] = {0, 0, 0};
        for (int q = 0; q < np; ++q)
          for (int d = 0; d < 3; ++d) dv[d] += w[q] * x1(l, cell[q], d);
        const vec3<T> v = c.v + vec3<T>{T(dv[0]), T(dv[1]), T(dv[2])};
        c.v_now = v;
        if (!acts(c, v)) continue;
        c.v = v;
        if (rc.joining.empty()) rc.next = 0;
        rc.joining.push_back(j);
      }
  };
  if (mode == GroupMode::begin || mode == GroupMode::join) {
    while (join_round()) {
    }
    if (mode == GroupMode::begin) start_from_last();
    for (int l = 0; l < Wg; ++l) {
      lanes[l]->joining.clear();
      lanes[l]->next = 0;
    }
    return;
  }
  if (mode == GroupMode::check) {  // (the rods whose impulses changed since their last check)
    for (int l = 0; l < Wg; ++l) {
      lanes[l]->open = lanes[l]->rod >= 0 && !lanes[l]->members.empty() && lanes[l]->respond;
      lanes[l]->respond = false;
    }
    response();
    for (int l = 0; l < Wg; ++l)
      if (lanes[l]->rod >= 0 && lanes[l]->open) check(l);
    return;
  }
  // rounds: the joining contacts' columns; each open rod's sweeps; the
  // responses; then any contact that a rod's impulses make act joins (its
  // velocity from the response) and that rod's sweeps go on; a rod with
  // none joining is done, with this response
  for (bool first = true;; first = false) {
    while (join_round()) {
    }
    if (first) start_from_last();
    bool open = false;
    for (int l = 0; l < Wg; ++l) {
      RodContacts<T>& rc = *lanes[l];
      if (rc.rod < 0 || !rc.open) continue;
      rc.joining.clear();
      rc.next = 0;
      sweeps(rc);
      open = true;
    }
    if (!open) break;
    response();
    for (int l = 0; l < Wg; ++l) {
      RodContacts<T>& rc = *lanes[l];
      if (rc.rod < 0 || !rc.open) continue;
      check(l);
      if (rc.joining.empty()) finish(l);
    }
  }
}

// Kept factors' pointers into buf (kKeepValues arrays of n values).
template <class Tf>
void keep_pointers(std::vector<Tf>& buf, int n, Tf* (&kp)[kKeepValues]) {
  buf.resize(std::size_t(kKeepValues) * std::size_t(n));
  for (int a = 0; a < kKeepValues; ++a) kp[a] = buf.data() + std::size_t(a) * std::size_t(n);
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

// A lane group solved with its factors kept: one compiled copy for the
// solve's fused contacts (ContactsAfterGroup) and the stage's second solve
// (solve_group_with_contacts), so that a rod's velocities do not depend on
// which of them solved it (two inlined copies may contract a·b + c into FMAs
// differently).
// kLift: rods with prescribed velocities (SolveGroup::lift).
template <Terms kKernel, int W, bool kLift = false, class Tc, class T>
MANYRODS_NOINLINE void solve_lanes_kept(const int* first, const int* cells, T h, const T* stiff_h, const ModelView<T>& m,
                                        const StateView<T>& s, const ImplicitScratchView<Tc>& sc, Tc* const* keep) {
  viscous_implicit_lanes<kKernel, W, true, kLift>(first, cells, h, stiff_h, m, s, sc, keep);
}

// Rods rods[0 … count) (count ≤ W) solved again from u⁻ as one lane group
// of W lanes in Tc (kernels/viscous_implicit_lanes.h, as the solve does; a
// group short of W fills up with its last rod), each rod relative to its
// reference hold hold_of(rod) (−1: none), the factors kept in `keep`
// (pointers kp); returns the group's cells (with the root ghost), each
// lane's cells in `cells`. lift: rods with prescribed velocities, as the
// solve takes them (SolveGroup::lift).
template <Terms kKernel, int W, class Tc, class T, class HoldOf>
int solve_group_again(RodBatch<T>& b, const int* rods, int count, T h, const ContactView<T>& cv, std::vector<Tc>& keep,
                      const ImplicitScratchView<Tc>& sc, Tc* (&kp)[kKeepValues], int (&cells)[W], bool lift,
                      HoldOf&& hold_of) {
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  int first[W], hold[W], n = 0;  // hold: each rod's reference hold, or −1
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
    hold[j] = hold_of(rods[j]);
    if (hold[j] >= 0) shift_hold(b, hold[j], T(-1));
  }
  keep_pointers(keep, W * n, kp);
  if (lift)
    solve_lanes_kept<kKernel, W, true>(first, cells, h, stiff_h, m, s, sc, kp);
  else
    solve_lanes_kept<kKernel, W>(first, cells, h, stiff_h, m, s, sc, kp);
  for (int j = 0; j < count; ++j)
    if (hold[j] >= 0) shift_hold(b, hold[j], T(1));
  return n;
}

// Rods rods[0 … count) (count ≤ W, each with a contact that acts)
// solved again from u⁻ as one lane group of W lanes in Tc (kernels/
// viscous_implicit_lanes.h, as the solve does, its factors kept), then each
// rod's contacts through its lane's factors.
template <Terms kKernel, int W, class Tc, class T>
void solve_group_with_contacts(RodBatch<T>& b, const int* rods, int count, T h, const ContactView<T>& cv,
                               ContactSolveBuffer<T>& buf, std::vector<Tc>& keep, const ImplicitScratchView<Tc>& sc,
                               const Segment& r, bool lift) {
  int cells[W];
  Tc* kp[kKeepValues];
  const int n = solve_group_again<kKernel, W>(b, rods, count, h, cv, keep, sc, kp, cells, lift,
                                              [&](int ri) { return reference_hold(b, r, ri); });
  RodContacts<T>* lanes = buf.lanes_for(W);
  bool any = false;
  for (int j = 0; j < W; ++j) {
    lanes[j].rod = j < count && find_solve_contacts(b, rods[j], h, cv, lanes[j]) ? rods[j] : -1;
    lanes[j].start = n - cells[j];
    any = any || lanes[j].rod >= 0;
  }
  if (any) group_contacts_through_factors<W>(b, h, cv, buf, lane_pointers<T, W>(buf).data(), kp, sc.G, n);
}

// The collider contacts fused into the implicit solve (its Hook,
// host/core/step/implicit_solve.h solve_segment): each lane group is solved
// with its factors kept, then each of its rods whose contacts the solve
// meets (ContactView::colliders_in_solve) gets its reference hold's rigid
// motion back (if the solve ran it relative to one), finds its contacts
// and, if one acts, takes them through its lane's factors, at once: no
// second solve, no second search. Those rods are marked in StepWorkspace::
// contact_fused; the stage after the solve takes the others (a float
// batch's stiff rod solved in double, a long rod's partitioned solve, the
// scalar kernel) as before. A rod's result is the
// stage's to the bit: the same kept solve (solve_lanes_kept), the same
// shifts, the same contacts, in the same order.
// With a profile, the contacts' time moves from the implicit_solve stage to
// contact_solve, as thread-seconds of the thread that ran them.
template <Terms kKernel, class T>
struct ContactsAfterGroup {
  RodBatch<T>& b;
  T h;
  const ContactView<T>& cv;
  const Segment& r;
  Profile* profile;

  template <int Wg, bool kLift = false, class Tc>
  void group(const int* first, const int* cells, const T* stiff_h, const int* rods, int count,
             const ImplicitScratchView<Tc>& sc, int thread) {
    ContactSolveBuffer<T>& buf = b.workspace->contact_solve[std::size_t(thread)];
    int n = 0;
    for (int j = 0; j < Wg; ++j) n = std::max(n, cells[j]);
    n += 1;  // the root ghost cell
    Tc* kp[kKeepValues];
    keep_pointers(buf.keep, Wg * n, kp);
    solve_lanes_kept<kKernel, Wg, kLift>(first, cells, h, stiff_h, b.model_view(), b.state_view(), sc, kp);
    std::chrono::steady_clock::time_point t0;
    if (profile) t0 = std::chrono::steady_clock::now();
    char* fused = b.workspace->contact_fused.data();
    const int* hold_of = b.workspace->contact_hold.data();
    const bool holds = r.driven_end > r.driven_begin;
    RodContacts<T>* lanes = buf.lanes_for(Wg);
    bool any = false;
    for (int j = 0; j < Wg; ++j) {
      lanes[j].rod = -1;
      lanes[j].start = n - cells[j];
      const int ri = rods[j];
      if (j >= count || !cv.colliders_in_solve(ri)) continue;
      fused[ri] = 1;
      // a rod solved relative to its reference hold's rigid motion: that
      // motion back first (the solve's last step for it, done here:
      // restored), the contacts in the lab frame
      if (holds && hold_of[ri] >= 0) shift_hold(b, hold_of[ri], T(1));
      if (find_solve_contacts(b, ri, h, cv, lanes[j])) lanes[j].rod = ri;
      any = any || lanes[j].rod >= 0;
    }
    if (any) group_contacts_through_factors<Wg>(b, h, cv, buf, lane_pointers<T, Wg>(buf).data(), kp, sc.G, n);
    if (profile) {
      const std::chrono::duration<double> d = std::chrono::steady_clock::now() - t0;
      profile->move(thread, Stage::implicit_solve, Stage::contact_solve, d.count());
    }
  }
  bool restored(int rod) const {
    return b.workspace->contact_fused[std::size_t(rod)] != 0 && b.workspace->contact_hold[std::size_t(rod)] >= 0;
  }
};


// How the contact solve takes rod ri (a job kind): 1 in a lane group, 2 in
// a lane group in double (a float batch's stiff rod); 4, 5: as 1, 2 but
// alone in one lane (a rod too long for a group in the thread's buffer, as
// the solve's partitioned ones); plus kLiftedJob for a rod with prescribed
// velocities (in jobs of their own, solved with SolveGroup::lift's kernel).
inline constexpr char kLiftedJob = 8;

template <class T>
char solve_job_kind(const RodBatch<T>& b, int ri, const Exec& ex) {
  constexpr int W = kImplicitLanes<T>, kWide = kImplicitLanes<double>;
  const RodInfo& rod = b.rods[std::size_t(ri)];
  const bool wide = sizeof(T) < sizeof(double) && rod.stiff_implicit && ex.stiff_solve_in_double;
  const bool fits = (wide ? kWide : W) * (rod.elements + 2) <= b.workspace->visc_cells;
  return char((wide ? (fits ? 2 : 5) : (fits ? 1 : 4)) | (rod.prescribed ? kLiftedJob : 0));
}

// The jobs of the rods of r by their kind (own.kind, 0: none): {kind, first
// in own.rods, count}, each kind's rods in their order, in groups of its width.
template <class T>
void make_solve_jobs(ContactSolveBuffer<T>& own, const Segment& r) {
  constexpr int W = kImplicitLanes<T>, kWide = kImplicitLanes<double>;
  own.rods.clear();
  own.jobs.clear();
  for (const int kind : {1, 2, 4, 5, 1 | kLiftedJob, 2 | kLiftedJob, 4 | kLiftedJob, 5 | kLiftedJob}) {
    const int base = kind & ~kLiftedJob, width = base == 1 ? W : base == 2 ? kWide : 1;
    for (int ri = r.rod_begin; ri < r.rod_end; ++ri) {
      if (own.kind[std::size_t(ri - r.rod_begin)] != kind) continue;
      if (own.jobs.empty() || own.jobs.back()[0] != kind || own.jobs.back()[2] == width)
        own.jobs.push_back({kind, int(own.rods.size()), 0});
      own.rods.push_back(ri);
      ++own.jobs.back()[2];
    }
  }
}

// f(i, thread) for i in [0, count): over the threads (dynamic chunks of
// `chunk`) when `parallel`, each call's arithmetic its own.
template <class F>
void for_each_index(int count, bool parallel, const Exec& ex, int thread, int chunk, F&& f) {
  if (parallel && count > 1) {
    const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/core/step/fp_env.h)
#pragma omp parallel num_threads(ex.threads)
    {
      const RegionFpScope fp(mode);
#pragma omp for schedule(dynamic, chunk)
      for (int i = 0; i < count; ++i) f(i, omp_get_thread_num());
    }
  } else {
    for (int i = 0; i < count; ++i) f(i, thread);
  }
}

// ---- rod–rod contacts in the solve ---------------------------------------------
// Two rods the solve steps meet each other inside it (kernels/
// contact_solve.h (S4)): every rod with a contact that acts or a rod–rod
// pair in range is solved again keeping its factors (one lane group a job,
// in parallel; the factors kept for the whole stage: StepWorkspace::
// kept_factors) and its acting contacts' columns of W are computed; then
// projected Gauss–Seidel sweeps run over all those rods' contacts together
// (one thread, rod by rod: a pair by its lower rod, both sides' contact
// velocities updated), until no update moves a contact velocity by more
// than kContactSweepTolerance of its rods' scale or the sweeps stall (their
// largest move has not halved in kContactStallSweeps); each rod's response
// (in parallel) may make more contacts act, which join with their other
// side and the sweeps go on; then each rod takes its impulses through its
// factors. Gauss–Seidel on the whole problem converges where the per-rod
// problems with the partners' motion lagged (block Jacobi) need not: a hair
// pressed by many others on a head took the sum of their pushes at once.

inline constexpr int kKeptFactorValues = kKeepValues + 36;  // keep, then G

// A job's kept factors: keep and G, each lanes × n values, in `store`.
template <class Tc>
void kept_factor_pointers(Tc* store, std::size_t per, Tc* (&kp)[kKeepValues], Tc* (&G)[36]) {
  for (int a = 0; a < kKeepValues; ++a) kp[a] = store + std::size_t(a) * per;
  for (int i = 0; i < 36; ++i) G[i] = store + std::size_t(kKeepValues + i) * per;
}

// One job (rods[0 … count), W lanes, solved in Tc) of the rod–rod contact
// solve in mode gm: begin solves the rods again from u⁻ (their reference
// holds in StepWorkspace::contact_hold; as solve_group_with_contacts;
// lift: rods with prescribed velocities), keeps the factors in `store` (n:
// the group's cells) and joins the contacts that act; join, check and
// finish take them from there (group_contacts_through_factors, GroupMode).
template <Terms kKernel, int W, class Tc, class T>
void rod_contacts_job(RodBatch<T>& b, const int* rods, int count, T h, const ContactView<T>& cv,
                      ContactSolveBuffer<T>& buf, std::vector<Tc>& keep, const ImplicitScratchView<Tc>& sc,
                      std::vector<Tc>& store, int& n, GroupMode gm, bool lift) {
  std::vector<RodContacts<T>>& rcs = b.workspace->rod_contacts;
  std::array<RodContacts<T>*, W> lanes;
  RodContacts<T>* pad = buf.lanes_for(1);  // a lane short of a rod
  pad->rod = -1;
  for (int j = 0; j < W; ++j) lanes[std::size_t(j)] = j < count ? &rcs[std::size_t(rods[j])] : pad;
  if (gm == GroupMode::begin) {
    Tc* kp[kKeepValues];
    int cells[W];
    n = solve_group_again<kKernel, W>(b, rods, count, h, cv, keep, sc, kp, cells, lift,
                                      [&](int ri) { return b.workspace->contact_hold[std::size_t(ri)]; });
    for (int j = 0; j < count; ++j) lanes[std::size_t(j)]->start = n - cells[j];
    const std::size_t per = std::size_t(W) * std::size_t(n);
    store.resize(std::size_t(kKeptFactorValues) * per);
    for (int a = 0; a < kKeepValues; ++a) std::copy(kp[a], kp[a] + per, store.data() + std::size_t(a) * per);
    for (int i = 0; i < 36; ++i) std::copy(sc.G[i], sc.G[i] + per, store.data() + std::size_t(kKeepValues + i) * per);
  }
  Tc* kp[kKeepValues];
  Tc* G[36];
  kept_factor_pointers(store.data(), std::size_t(W) * std::size_t(n), kp, G);
  group_contacts_through_factors<W>(b, h, cv, buf, lanes.data(), kp, G, n, gm);
}

// The rod–rod contact solve on the rods of r (the whole batch: partners may
// be anywhere), after the broad phase: their collider, self and rod–rod
// contacts, swept together as above. The parallel passes are per rod or per
// job, each writing its own rods; the sweeps run on one thread, in the
// jobs' order of the rods: the result does not depend on the thread count.
// reads: model, state, contact data and lists, colliders  writes: state.node_v,
// elem_w of the rods taking part, contact.work, contact.solve_sweeps
template <Terms kSolve, class T>
void rod_contacts_in_solve(RodBatch<T>& b, T h, const ContactView<T>& cv, const Exec& ex, const Segment& r,
                           int thread) {
  constexpr Terms kKernel = solve_kernel_terms(kSolve);
  constexpr int W = kImplicitLanes<T>;
  [[maybe_unused]] constexpr int kWide = kImplicitLanes<double>;
  StepWorkspace<T>& ws = *b.workspace;
  std::vector<ContactSolveBuffer<T>>& bufs = ws.contact_solve;
  if (ws.rod_contacts.size() < b.rods.size()) ws.rod_contacts.resize(b.rods.size());
  // each rod's reference hold (a driven root: the solve runs relative to its
  // rigid motion), over the whole batch; −1 again at the end
  std::vector<int>& hold_of = ws.contact_hold;
  if (hold_of.size() < b.rods.size()) hold_of.assign(b.rods.size(), -1);
  for (std::size_t i = 0; i < b.driven.size(); ++i) {
    const DrivenHold& d = b.driven[i];
    if (d.reference && needs_implicit_solve(b.rods[std::size_t(d.rod)], kSolve.kelvin_voigt))
      hold_of[std::size_t(d.rod)] = int(i);
  }
  struct Unhold {
    RodBatch<T>& b;
    ~Unhold() {
      for (const DrivenHold& d : b.driven) b.workspace->contact_hold[std::size_t(d.rod)] = -1;
    }
  } unhold{b};
  std::vector<RodContacts<T>>& rcs = ws.rod_contacts;
  const bool parallel = ex.threads > 1;
  const int rods = r.rod_end - r.rod_begin;
  ContactSolveBuffer<T>& own = bufs[std::size_t(thread)];
  own.kind.assign(std::size_t(rods), 0);
  // which rods take part: those with a contact that acts at the free
  // velocities, and every rod a pair in range joins to one of them (its
  // partner may push it, and its partners then: the rods connected to one
  // by pairs in range). A tight bundle at rest with no contact that acts
  // takes no part.
  for_each_index(rods, parallel, ex, thread, 16, [&](int i, int) {
    const int ri = r.rod_begin + i;
    RodContacts<T>& rc = rcs[std::size_t(ri)];
    rc.rod = -1;
    rc.open = false;
    rc.pairs = 0;
    if (!cv.colliders_in_solve(ri)) return;
    if (find_solve_contacts(b, ri, h, cv, rc)) rc.rod = ri;
  });
  std::vector<int>& reach = own.rods;  // (a queue here; the jobs' rods below)
  reach.clear();
  for (int ri = r.rod_begin; ri < r.rod_end; ++ri)
    if (rcs[std::size_t(ri)].rod >= 0) reach.push_back(ri);
  for (std::size_t q = 0; q < reach.size(); ++q)
    for (const SolveContact<T>& c : rcs[std::size_t(reach[q])].contacts)
      if (c.kb >= 0 && rcs[std::size_t(c.partner)].rod < 0) {
        rcs[std::size_t(c.partner)].rod = c.partner;
        reach.push_back(c.partner);
      }
  for (const int ri : reach) own.kind[std::size_t(ri - r.rod_begin)] = solve_job_kind(b, ri, ex);
  make_solve_jobs(own, r);
  const int jobs = int(own.jobs.size());
  if (jobs == 0) return;
  if (int(ws.kept_factors.size()) < jobs) ws.kept_factors.resize(std::size_t(jobs));
  auto job = [&](int i, int t, GroupMode gm) {
    const std::array<int, 3>& jb = own.jobs[std::size_t(i)];
    auto& kf = ws.kept_factors[std::size_t(i)];
    ContactSolveBuffer<T>& buf = bufs[std::size_t(t)];
    const int* jr = own.rods.data() + jb[1];
    const int kind = jb[0] & ~kLiftedJob;
    const bool lift = (jb[0] & kLiftedJob) != 0;
    if (kind == 1) {
      rod_contacts_job<kKernel, W>(b, jr, jb[2], h, cv, buf, buf.keep, b.implicit_scratch_view(t, 0), kf.f, kf.n,
                                   gm, lift);
    } else if (kind == 4) {
      rod_contacts_job<kKernel, 1>(b, jr, 1, h, cv, buf, buf.keep, b.implicit_scratch_view(t, 0), kf.f, kf.n, gm,
                                   lift);
    } else if constexpr (sizeof(T) < sizeof(double)) {
      if (kind == 2)
        rod_contacts_job<kKernel, kWide>(b, jr, jb[2], h, cv, buf, buf.keep_wide, b.wide_implicit_scratch_view(t),
                                         kf.wide, kf.n, gm, lift);
      else
        rod_contacts_job<kKernel, 1>(b, jr, 1, h, cv, buf, buf.keep_wide, b.wide_implicit_scratch_view(t), kf.wide,
                                     kf.n, gm, lift);
    }
  };
  // each pair's two sides: where the other side is, and the contact's mass
  // from both sides' shares (kernels/contact.h contact_compliance); each
  // rod's contacts' impulses at the last step (take_last_impulses)
  const int* part = own.rods.data();
  const int taking = int(own.rods.size());
  for_each_index(taking, parallel, ex, thread, 16, [&](int i, int) {
    RodContacts<T>& rc = rcs[std::size_t(part[i])];
    take_last_impulses(b, rc);
    for (SolveContact<T>& c : rc.contacts) {
      if (c.kb < 0) continue;
      const std::vector<SolveContact<T>>& other = rcs[std::size_t(c.partner)].contacts;
      c.twin = -1;
      for (std::size_t j = 0; j < other.size(); ++j)
        if (other[j].k == c.kb && other[j].kb == c.k) {
          c.twin = int(j);
          break;
        }
      if (c.twin < 0) throw std::logic_error("rod_contacts_in_solve: a rod–rod pair seen from one side only");
      const T w = c.own_compliance + other[std::size_t(c.twin)].own_compliance;
      c.a = w > T(0) ? T(1) / w : T(0);
    }
  });
  // a pair starts from its last impulse where both sides found it (then
  // both join: W's blocks of both are needed), as its lower rod had it
  for (int i = 0; i < taking; ++i) {
    RodContacts<T>& rc = rcs[std::size_t(part[i])];
    for (std::size_t j = 0; j < rc.contacts.size(); ++j) {
      const SolveContact<T>& c = rc.contacts[j];
      if (c.kb < 0 || c.partner < part[i]) continue;
      vec3<T>& tp = rcs[std::size_t(c.partner)].last_p[std::size_t(c.twin)];
      if (c.a > T(0) && nonzero(rc.last_p[j]) && nonzero(tp)) {
        tp = T(-1) * rc.last_p[j];
      } else {
        rc.last_p[j] = tp = vec3<T>{T(0), T(0), T(0)};
      }
    }
  }
  for_each_index(jobs, parallel, ex, thread, 1, [&](int i, int t) { job(i, t, GroupMode::begin); });
  for (int i = 0; i < taking; ++i) {
    RodContacts<T>& rc = rcs[std::size_t(part[i])];
    for (const int j : rc.members) {
      SolveContact<T>& c = rc.contacts[std::size_t(j)];
      const vec3<T> p = rc.last_p[std::size_t(j)];
      if (c.kb < 0 || c.partner < part[i] || !nonzero(p)) continue;
      RodContacts<T>& pr = rcs[std::size_t(c.partner)];
      c.p = p;
      pr.contacts[std::size_t(c.twin)].p = T(-1) * p;
      add_delassus_column(rc, j, p);
      add_delassus_column(pr, c.twin, T(-1) * p);
    }
  }
  // rounds: projected Gauss–Seidel over all the rods' contacts in the solve
  // together, rod by rod in the jobs' order (by kind, then by index), each
  // rod's in the order they joined, a pair by its lower
  // rod (S4: one impulse, +p on it, −p on the partner, each side's contact
  // velocities following through its W), until no update moves a contact
  // velocity by more than the tolerance of its rods' scale, or the sweeps
  // stall; then every rod's response (its factors), and the contacts it
  // makes act join (with their other side), and the sweeps go on
  const T tol = kContactSweepTolerance<T>;
  int sweeps = 0;
  bool converged = true, first_round = true;
  for (int i = 0; i < taking; ++i) rcs[std::size_t(part[i])].respond = true;
  // A sweep visits only the rods that can change: those open, and those
  // with a pair (which they own, as its lower rod) whose partner is open, at
  // their turn. A rod that opens during a sweep (a partner's update moved
  // it) is queued then, with its partners, if their turn is still to come:
  // the same updates in the same order as a sweep over every rod, without
  // the rods at rest (most of a groom, after its first sweeps).
  std::vector<int>& place_of = own.place_of;
  std::vector<int>& visit = own.visit;
  std::vector<int>& touched = own.touched;
  std::vector<char>& marks = own.marks;
  place_of.assign(std::size_t(rods), -1);
  for (int i = 0; i < taking; ++i) place_of[std::size_t(part[i] - r.rod_begin)] = i;
  marks.assign(std::size_t(taking), 0);
  visit.clear();
  touched.clear();
  int at = -1;  // the place being visited
  auto queue = [&](int i) {
    if (i <= at || (marks[std::size_t(i)] & 1)) return;
    marks[std::size_t(i)] |= 1;
    visit.push_back(i);
    std::push_heap(visit.begin(), visit.end(), std::greater<int>());
  };
  auto queue_with_partners = [&](int i) {
    queue(i);
    const RodContacts<T>& rc = rcs[std::size_t(part[i])];
    for (const int j : rc.members) {
      const SolveContact<T>& c = rc.contacts[std::size_t(j)];
      if (c.kb >= 0) queue(place_of[std::size_t(c.partner - r.rod_begin)]);
    }
  };
  auto touch = [&](int i) {
    if (marks[std::size_t(i)] & 2) return;
    marks[std::size_t(i)] |= 2;
    touched.push_back(i);
  };
  for (;;) {
    // a rod's contacts are visited while its contact velocities (or, for a
    // pair, its partner's) moved by more than the tolerance in this sweep
    // or the last: converged rods cost nothing. A rod whose
    // largest move has not halved in kContactStallSweeps sweeps is cycling
    // (friction, as a single rod's sweeps do): its contacts and pairs stand.
    for (int i = 0; i < taking; ++i) {  // the first round every rod, then those with contacts that joined
      RodContacts<T>& rc = rcs[std::size_t(part[i])];
      rc.open = first_round || rc.joined;
      rc.joined = false;
      rc.frozen = false;
      rc.best = T(0);
      rc.best_at = -1;
      rc.worst = T(0);
    }
    first_round = false;
    at = -1;
    for (const int i : visit) marks[std::size_t(i)] &= char(~1);  // (left by a round that ran out of sweeps)
    visit.clear();
    for (int i = 0; i < taking; ++i)
      if (rcs[std::size_t(part[i])].open) queue_with_partners(i);
    bool done = false;
    for (int sweep = 0; sweep < kMaxContactSweeps; ++sweep, ++sweeps) {
      while (!visit.empty()) {
        std::pop_heap(visit.begin(), visit.end(), std::greater<int>());
        const int i = visit.back();
        visit.pop_back();
        marks[std::size_t(i)] &= char(~1);
        at = i;
        RodContacts<T>& rc = rcs[std::size_t(part[i])];
        if (rc.frozen) continue;
        touch(i);
        for (const int j : rc.members) {
          SolveContact<T>& c = rc.contacts[std::size_t(j)];
          if (c.kb < 0) {
            if (!rc.open) continue;
            const vec3<T> p0 = c.p;
            const T moved = sweep_contact(rc, j, h, cv);
            if (c.p.x != p0.x || c.p.y != p0.y || c.p.z != p0.z) rc.respond = true;
            if (moved > tol * rc.scale) rc.worst = std::max(rc.worst, rc.scale > T(0) ? moved / rc.scale : T(1));
            continue;
          }
          if (c.partner < part[i]) continue;  // the lower rod's
          RodContacts<T>& pr = rcs[std::size_t(c.partner)];
          if (pr.frozen || (!rc.open && !pr.open)) continue;
          SolveContact<T>& tw = pr.contacts[std::size_t(c.twin)];
          const mat3<T> wa = delassus_block(rc, j, j), wb = delassus_block(pr, c.twin, c.twin);
          const vec3<T> rel0 = c.v - tw.v;
          vec3<T> p{T(0), T(0), T(0)};
          if (c.a > T(0)) {  // (not two held points)
            c.vp = tw.v - mul(wb, tw.p);  // the partner's point without this impulse
            mat3<T> we = wa;
            for (int e = 0; e < 9; ++e) we.m[e] += wb.m[e];
            p = contact_local_impulse(c, we, c.v - mul(wa, c.p), h, cv.hardness, cv.damping_ratio);
          }
          const vec3<T> dp = p - c.p;
          if (nonzero(dp)) rc.respond = pr.respond = true;
          add_delassus_column(rc, j, dp);
          add_delassus_column(pr, c.twin, T(-1) * dp);
          c.p = p;
          tw.p = T(-1) * p;
          const T moved = norm(c.v - tw.v - rel0), scale = std::max(rc.scale, pr.scale);
          if (moved > tol * scale) {
            const T ratio = scale > T(0) ? moved / scale : T(1);
            rc.worst = std::max(rc.worst, ratio);
            pr.worst = std::max(pr.worst, ratio);
            const int ip = place_of[std::size_t(c.partner - r.rod_begin)];
            touch(ip);
            if (!pr.open) {
              pr.open = true;  // (the partner's later contacts see it in this sweep)
              queue_with_partners(ip);
            }
          }
        }
      }
      at = -1;
      // the rods touched in this sweep (any other has not moved and is not
      // open): open while they moved, frozen when they stall; the open ones
      // and their partners are visited in the next sweep (in any order: each
      // rod's test is its own, and the heap orders the visits)
      bool any = false;
      for (const int i : touched) {
        marks[std::size_t(i)] &= char(~2);
        RodContacts<T>& rc = rcs[std::size_t(part[i])];
        const T worst = rc.worst;
        rc.worst = T(0);
        if (rc.frozen) continue;
        rc.open = worst > T(0);
        if (!rc.open) continue;
        any = true;
        if (rc.best_at < 0 || worst < T(0.5) * rc.best) {
          rc.best = worst;
          rc.best_at = sweep;
        }
        if (sweep - rc.best_at >= kContactStallSweeps) rc.frozen = true;
      }
      if (any)
        for (const int i : touched)
          if (!rcs[std::size_t(part[i])].frozen && rcs[std::size_t(part[i])].open) queue_with_partners(i);
      touched.clear();
      if (!any) {
        done = true;
        for (int i = 0; i < taking; ++i) done = done && !rcs[std::size_t(part[i])].frozen;
        break;
      }
    }
    converged = converged && done;
    // the responses; the contacts they make act join, with their other side
    // (a pair not in the solve is checked against its partner's point as
    // the partner's last response left it)
    for (int i = 0; i < taking; ++i)
      for (SolveContact<T>& c : rcs[std::size_t(part[i])].contacts)
        if (c.kb >= 0 && !c.in) {
          const SolveContact<T>& tw = rcs[std::size_t(c.partner)].contacts[std::size_t(c.twin)];
          c.vp = tw.in ? tw.v : tw.v_now;
        }
    for_each_index(jobs, parallel, ex, thread, 1, [&](int i, int t) { job(i, t, GroupMode::check); });
    bool joining = false;
    for (int i = 0; i < taking; ++i) {
      RodContacts<T>& rc = rcs[std::size_t(part[i])];
      for (std::size_t q = 0; q < rc.joining.size(); ++q) {
        const SolveContact<T>& c = rc.contacts[std::size_t(rc.joining[q])];
        if (c.kb < 0) continue;
        RodContacts<T>& pr = rcs[std::size_t(c.partner)];
        SolveContact<T>& tw = pr.contacts[std::size_t(c.twin)];
        if (tw.in || std::find(pr.joining.begin(), pr.joining.end(), c.twin) != pr.joining.end()) continue;
        if (pr.joining.empty()) pr.next = 0;
        pr.joining.push_back(c.twin);
        tw.v = tw.v_now;  // its velocity from its rod's response
      }
      joining = joining || !rc.joining.empty();
    }
    for (int i = 0; i < taking; ++i) {
      RodContacts<T>& rc = rcs[std::size_t(part[i])];
      rc.joined = !rc.joining.empty();
    }
    if (!joining) break;
    for_each_index(jobs, parallel, ex, thread, 1, [&](int i, int t) { job(i, t, GroupMode::join); });
  }
  b.contact.solve_sweeps += sweeps;
  b.contact.solve_sweeps_max = std::max(b.contact.solve_sweeps_max, sweeps);
  ++b.contact.solve_steps;
  if (!converged) ++b.contact.solve_stalled;
  for_each_index(jobs, parallel, ex, thread, 1, [&](int i, int t) { job(i, t, GroupMode::finish); });
}
}  // namespace detail

// The implicit stage (host/core/step/implicit_solve.h viscous_update) with
// the collider contacts of the rods it solves in lane groups fused into it
// (detail::ContactsAfterGroup); contact_solve_stage after it takes the
// rest. Only where the contact solve does not read the broad phase's lists
// (no self contact in the solve: they are built after the solve).
// reads: model, state, contact data, colliders  writes: state.node_v, elem_w,
// contact.work, the workspace's contact_fused
template <Terms kSolve, class T>
void viscous_update_with_contacts(RodBatch<T>& b, T h, const ColliderFrame<T>* frames, const Exec& ex,
                                  const Segment& r, int thread) {
  constexpr Terms kKernel = detail::solve_kernel_terms(kSolve);
  const ContactView<T> cv = contact_view(b, frames, kSolve.kelvin_voigt, kSolve.rod_contact);
  if (cv.collider_count == 0 || cv.self_in_solve != 0 || cv.rods_in_solve != 0 || b.workspace->contact_solve.size() < std::size_t(std::max({ex.threads, ex.solve_threads, thread + 1})) ||
      b.workspace->contact_fused.size() < b.rods.size() || b.workspace->contact_hold.size() < b.rods.size()) {
    detail::solve_segment<kKernel, 0>(b, h, ex, r, thread);
    return;
  }
  // each rod's reference hold (StepWorkspace::contact_hold, −1 outside
  // this call), for the hook
  std::vector<int>& hold_of = b.workspace->contact_hold;
  for (int i = r.driven_begin; i < r.driven_end; ++i) {
    const DrivenHold& d = b.driven[std::size_t(i)];
    if (d.reference && needs_implicit_solve(b.rods[d.rod], kSolve.kelvin_voigt)) hold_of[std::size_t(d.rod)] = i;
  }
  detail::ContactsAfterGroup<kKernel, T> hook{b, h, cv, r, ex.profile};
  detail::solve_segment<kKernel, 0>(b, h, ex, r, thread, &hook);
  for (int i = r.driven_begin; i < r.driven_end; ++i) hold_of[std::size_t(b.driven[std::size_t(i)].rod)] = -1;
}

// The stage on the rods of segment r that the solve steps (kSolve: the
// solve's Terms), after the solve: which rods have a collider or self
// contact that acts (a pass over the rods), then those rods again in lane groups of the
// solve's width (in double for a float batch's stiff rods; rods with
// prescribed velocities in groups of their own), each group's rods in their order: the result does
// not depend on the thread count.
// reads: model, state, contact data and lists, colliders  writes: state.node_v, elem_w
// of the rods with an acting contact, contact.work
template <Terms kSolve, class T>
void contact_solve_stage(RodBatch<T>& b, T h, const ColliderFrame<T>* frames, const Exec& ex, const Segment& r,
                         int thread) {
  constexpr Terms kKernel = detail::solve_kernel_terms(kSolve);
  constexpr int W = kImplicitLanes<T>;
  [[maybe_unused]] constexpr int kWide = kImplicitLanes<double>;
  const ContactView<T> cv = contact_view(b, frames, kSolve.kelvin_voigt, kSolve.rod_contact);
  if (cv.collider_count == 0 && cv.self_in_solve == 0 && cv.rods_in_solve == 0) return;
  // one buffer per thread, reserved by the driver before its parallel
  // region (host/core/step/integrators.h prepare_solve); a call from
  // elsewhere (one thread) grows them here
  std::vector<ContactSolveBuffer<T>>& bufs = b.workspace->contact_solve;
  const int need = std::max(ex.threads, thread + 1);
  if (int(bufs.size()) < need) {
    if (omp_in_parallel()) throw std::logic_error("contact_solve_stage: buffers not reserved before a parallel region");
    bufs.resize(std::size_t(need));
  }
  if (cv.rods_in_solve != 0) {  // with the rod–rod contacts: on the whole batch
    detail::rod_contacts_in_solve<kSolve>(b, h, cv, ex, r, thread);
    return;
  }
  const bool parallel = ex.threads > 1 && r.rod_end - r.rod_begin > 1;
  const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/core/step/fp_env.h)
  // which rods, and how (detail::solve_job_kind)
  ContactSolveBuffer<T>& own = bufs[std::size_t(thread)];
  own.kind.assign(std::size_t(r.rod_end - r.rod_begin), 0);
  char* fused = b.workspace->contact_fused.size() >= b.rods.size() ? b.workspace->contact_fused.data() : nullptr;
  auto which = [&](int ri, int t) {
    if (fused && fused[ri]) {  // done in the solve (viscous_update_with_contacts)
      fused[ri] = 0;
      return;
    }
    if (!cv.colliders_in_solve(ri) || !detail::find_solve_contacts(b, ri, h, cv, bufs[std::size_t(t)].lanes_for(1)[0]))
      return;
    own.kind[std::size_t(ri - r.rod_begin)] = detail::solve_job_kind(b, ri, ex);
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
  detail::make_solve_jobs(own, r);
  auto job = [&](const std::array<int, 3>& jb, int t) {
    ContactSolveBuffer<T>& buf = bufs[std::size_t(t)];
    const int* rods = own.rods.data() + jb[1];
    const int kind = jb[0] & ~detail::kLiftedJob;
    const bool lift = (jb[0] & detail::kLiftedJob) != 0;
    if (kind == 1) {
      detail::solve_group_with_contacts<kKernel, W>(b, rods, jb[2], h, cv, buf, buf.keep, b.implicit_scratch_view(t, 0),
                                                    r, lift);
    } else if (kind == 2) {
      if constexpr (sizeof(T) < sizeof(double))
        detail::solve_group_with_contacts<kKernel, kWide>(b, rods, jb[2], h, cv, buf, buf.keep_wide,
                                                          b.wide_implicit_scratch_view(t), r, lift);
    } else if (kind == 4) {
      detail::solve_group_with_contacts<kKernel, 1>(b, rods, 1, h, cv, buf, buf.keep, b.implicit_scratch_view(t, 0), r,
                                                    lift);
    } else if constexpr (sizeof(T) < sizeof(double)) {
      detail::solve_group_with_contacts<kKernel, 1>(b, rods, 1, h, cv, buf, buf.keep_wide,
                                                    b.wide_implicit_scratch_view(t), r, lift);
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
