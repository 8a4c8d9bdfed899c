// host/core/step/contact_solve.h — collider contacts inside the implicit
// solve (kernels/contact_solve.h; docs/contact.md "Contact inside the
// implicit solve"):
//
//   contact_solve_save    the velocities before the solve (u⁻), per slot
//   contact_solve_stage   after the solve: each rod the solve steps finds
//                         its collider contacts at the solve's geometry and,
//                         if one acts, is solved again from u⁻ with them in
//                         its system until their states settle
//
// A rod no collider reaches pays one pass over its elements. A rod with a
// reference hold (a driven root) is solved relative to the hold's rigid
// motion, as the solve does (host/core/step/implicit_solve.h shift_hold):
// the colliders' velocities are taken into that frame. Each rod is solved
// on its own, by the scalar kernel, in a fixed order of its contacts: the
// result does not depend on the thread count.
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

// Rod `ri`'s collider contacts in range at the solve's geometry, into
// buf.contacts (kernels/contact_solve.h), their initial states from the
// velocities the first solve gave. Returns whether one acts.
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
      const T delta = collider_range(c, x0, x1, r, va, reach);
      Touch<T> touch[3];
      const int nt = collider_touches(c, x0, x1, r, touch);
      for (int j = 0; j < nt; ++j) {
        const Touch<T>& t = touch[j];
        if (!(t.gap < delta)) continue;
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
      }
    }
  }
  bool any = false;
  for (SolveContact<T>& c : buf.contacts) {
    // the contact's mass (kernels/contact.h element_side)
    const T w = contact_compliance(c.s, m.node_inv_mass[c.k], m.node_inv_mass[c.k + 1],
                                   buf.weight[std::size_t(c.k - first)], buf.weight[std::size_t(c.k + 1 - first)]);
    if (!(w > T(0))) continue;  // both nodes held
    c.a = T(1) / w;
    solve_contact_update(c, point_velocity(c, st.node_v), h, cv.hardness, cv.damping_ratio);
    any = any || c.mode != ContactMode::off;
  }
  return any;
}

// Rod ri solved again from u⁻ with its contacts (find_solve_contacts)
// until their states settle; their impulses' work into contact.work.
template <Terms kKernel, class T>
void solve_rod_with_contacts(RodBatch<T>& b, int ri, int hold, T h, const ContactView<T>& cv,
                             ContactSolveBuffer<T>& buf, const ImplicitScratchView<T>& sc) {
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  const RodInfo& rod = b.rods[std::size_t(ri)];
  const int first = rod.offset + 1, cells = rod.elements + 1;
  // u⁻ back, in the solve's frame, kept in buf.u
  for (int c = 0; c < cells; ++c) {
    store3(s.node_v, first + c, load3(cv.v_solve, first + c));
    store3(s.elem_w, first + c, load3(cv.w_solve, first + c));
  }
  if (hold >= 0) {
    shift_hold(b, hold, T(-1));
    // the collider's velocity relative to the hold's rigid motion at the point
    for (SolveContact<T>& c : buf.contacts)
      c.vp = c.vp - (point_velocity(c, cv.v_solve) - point_velocity(c, s.node_v));
  }
  buf.u.resize(6 * std::size_t(cells));
  for (int c = 0; c < cells; ++c)
    for (int d = 0; d < 3; ++d) {
      buf.u[6 * std::size_t(c) + std::size_t(d)] = s.node_v[d][first + c];
      buf.u[6 * std::size_t(c) + 3 + std::size_t(d)] = s.elem_w[d][first + c];
    }
  SolveContactView<T> ccv;
  for (int i = 0; i < 6; ++i) ccv.k[i] = cv.ck[i];
  for (int i = 0; i < 6; ++i) ccv.x[i] = cv.cx[i];
  for (int i = 0; i < 3; ++i) ccv.r[i] = cv.cr[i];
  const T stiff_h = rod.stiff_implicit ? h : T(0);
  for (int it = 0; it < kMaxContactSolves; ++it) {
    for (const SolveContact<T>& c : buf.contacts) {
      T k6[6] = {}, r3[3] = {};
      solve_contact_terms(c, h, cv.hardness, cv.damping_ratio, k6, r3);
      const T w0 = T(1) - c.s, w1 = c.s;
      for (int i = 0; i < 6; ++i) {
        cv.ck[i][c.k] += w0 * w0 * k6[i];
        cv.ck[i][c.k + 1] += w1 * w1 * k6[i];
        cv.cx[i][c.k] += w0 * w1 * k6[i];
      }
      for (int i = 0; i < 3; ++i) {
        cv.cr[i][c.k] += w0 * r3[i];
        cv.cr[i][c.k + 1] += w1 * r3[i];
      }
    }
    for (int c = 0; c < cells; ++c)
      for (int d = 0; d < 3; ++d) {
        s.node_v[d][first + c] = buf.u[6 * std::size_t(c) + std::size_t(d)];
        s.elem_w[d][first + c] = buf.u[6 * std::size_t(c) + 3 + std::size_t(d)];
      }
    viscous_implicit_rod<kKernel>(first, cells, h, stiff_h, m, s, sc, &ccv);
    for (const SolveContact<T>& c : buf.contacts)  // (the blocks are zero outside this loop)
      for (int j = c.k; j <= c.k + 1; ++j) {
        for (int i = 0; i < 6; ++i) cv.ck[i][j] = cv.cx[i][j] = T(0);
        for (int i = 0; i < 3; ++i) cv.cr[i][j] = T(0);
      }
    bool changed = false;
    for (SolveContact<T>& c : buf.contacts)
      if (c.a > T(0))
        changed = solve_contact_update(c, point_velocity(c, s.node_v), h, cv.hardness, cv.damping_ratio) || changed;
    if (!changed) break;
  }
  if (hold >= 0) shift_hold(b, hold, T(1));
  // the work of the impulses of the last solve, P·(v_n + v_{n+1})/2 at the point
  for (const SolveContact<T>& c : buf.contacts)
    if (c.p.x != T(0) || c.p.y != T(0) || c.p.z != T(0))
      cv.work[c.k] += T(0.5) * dot(c.p, point_velocity(c, cv.v_start) + point_velocity(c, s.node_v));
}

}  // namespace detail

// The stage on the rods of segment r that the solve steps (kSolve: the
// solve's Terms), after the solve.
// reads: model, state, contact data, colliders  writes: state.node_v, elem_w
// of the rods with an acting contact, contact.work
template <Terms kSolve, class T>
void contact_solve_stage(RodBatch<T>& b, T h, const ColliderFrame<T>* frames, const Exec& ex, const Segment& r,
                         int thread) {
  constexpr Terms kKernel = detail::solve_kernel_terms(kSolve);
  const ContactView<T> cv = contact_view(b, frames, kSolve.kelvin_voigt);
  if (cv.collider_count == 0) return;
  // one buffer per thread, reserved by the driver before its parallel
  // region (host/core/step/integrators.h prepare_solve); a call from
  // elsewhere (one thread) grows them here
  std::vector<ContactSolveBuffer<T>>& bufs = b.workspace->contact_solve;
  const int need = std::max(ex.threads, thread + 1);
  if (int(bufs.size()) < need) {
    if (omp_in_parallel()) throw std::logic_error("contact_solve_stage: buffers not reserved before a parallel region");
    bufs.resize(std::size_t(need));
  }
  auto one = [&](int ri, int t) {
    if (!cv.colliders_in_solve(ri)) return;
    ContactSolveBuffer<T>& buf = bufs[std::size_t(t)];
    if (!detail::find_solve_contacts(b, ri, h, cv, buf)) return;
    int hold = -1;
    for (int i = r.driven_begin; i < r.driven_end; ++i)
      if (b.driven[std::size_t(i)].rod == ri && b.driven[std::size_t(i)].reference) hold = i;
    detail::solve_rod_with_contacts<kKernel>(b, ri, hold, h, cv, buf, b.implicit_scratch_view(t, 0));
  };
  if (ex.threads > 1 && r.rod_end - r.rod_begin > 1) {
    const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/core/step/fp_env.h)
#pragma omp parallel num_threads(ex.threads)
    {
      const RegionFpScope fp(mode);
#pragma omp for schedule(dynamic, 16)
      for (int ri = r.rod_begin; ri < r.rod_end; ++ri) one(ri, omp_get_thread_num());
    }
  } else {
    for (int ri = r.rod_begin; ri < r.rod_end; ++ri) one(ri, thread);
  }
}

}  // namespace manyrods
