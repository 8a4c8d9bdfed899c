// host/core/step/contact_stage.h — the contact stage of a step (kernels/contact.h) and
// the rod–rod broad phase (docs/contact.md).
//
//   place_colliders     each collider's lab placement and velocity field over a step
//   update_neighbours   the rod–rod candidate lists, rebuilt when a node moved
//                       farther than the skin allows (a sorted uniform grid)
//   contact_stage       count → impulses → apply, over a range of slots
//   contact_step        the stage of a step: the variant its Terms choose (below)
//
// Determinism: every pass is a gather over slots (no atomics, no float
// reduction across threads); the grid is sorted by (cell, slot), and each
// element visits its 27 cells in a fixed order, so the candidate lists, and
// with them every sum, do not depend on the thread count.
#pragma once

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <utility>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/core/model/view_of.h"
#include "host/core/step/fp_env.h"
#include "host/core/step/schedule.h"
#include "kernels/contact.h"
#include "kernels/views.h"
#include "manyrods/batch.h"
#include "manyrods/step.h"

namespace manyrods {

// Kernel view of the batch's contact data with the colliders placed by `frames`.
// solve_kv: the implicit solve integrates the Kelvin–Voigt term (its damped
// rods meet the colliders there, ContactView::colliders_in_solve); self_terms:
// the step has rod contact (with ContactSpec::self, the rods the solve steps
// meet themselves there, ContactView::self_solved).
template <class T>
ContactView<T> contact_view(RodBatch<T>& b, const ColliderFrame<T>* frames, bool solve_kv = false,
                            bool self_terms = false) {
  ContactData<T>& c = b.contact;
  ContactView<T> v;
  v.colliders = frames;  // (nullptr: the step's Terms have no colliders, and it meets none)
  v.collider_count = frames ? int(c.spec.colliders.size()) : 0;
#define MANYRODS_CONTACT_VIEW_OF(type, name, view, n, fill, doc) view_of(v.view, c.name);
  MANYRODS_CONTACT_VIEW_FIELDS(MANYRODS_CONTACT_VIEW_OF)
#undef MANYRODS_CONTACT_VIEW_OF
  v.rod_near = c.rod_near.data();
  v.rod_mu = c.rod_mu.data();
  v.rod_mu_own = c.rod_mu_own.data();
  v.rod_stiff = c.rod_stiff.data();
  v.rod_in_solve = c.rod_in_solve[solve_kv ? 1 : 0].data();
  v.self_in_solve = self_terms && c.spec.self ? 1 : 0;
  v.rods_in_solve = self_terms && c.spec.rod_rod ? 1 : 0;
  v.neighbours = c.neighbours.data();
  v.capacity = c.capacity;
  v.hardness = T(c.spec.hardness);
  v.damping_ratio = T(c.spec.damping_ratio);
  return v;
}

// Collider frames for the step [t, t + h]: the pose at t + h/2 places the
// geometry; the velocity field is that of the motion over the step,
// v(p) = (R(t+h) − R(t)) R(t+h/2)ᵀ (p − c(t+h/2))/h + (c(t+h) − c(t))/h.
// (host/core/model/contact.cpp)
template <class T>
void place_colliders(const ContactData<T>& c, double t, double h, ColliderFrame<T>* out);

// Rebuilds the rod–rod candidate lists when needed (host/core/step/broad_phase.cpp);
// throws std::runtime_error naming the element when one overflows.
template <class T>
void update_neighbours(RodBatch<T>& b, T h, const Exec& ex);

namespace detail {
template <class F>
void for_slots(int begin, int end, const Exec& ex, F&& f) {
  if (ex.threads > 1 && end - begin > 2 * kGuard) {
    const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/core/step/fp_env.h)
#pragma omp parallel num_threads(ex.threads)
    {
      const RegionFpScope fp(mode);
#pragma omp for schedule(static, kGuard)
      for (int k = begin; k < end; ++k) f(k);
    }
  } else {
    for (int k = begin; k < end; ++k) f(k);
  }
}
}  // namespace detail

// The contact stage on the slots of r (after the implicit solve, before the
// last drift): every element counts its contacts in range, then computes
// their impulses with the counts of its and its partners' nodes, then every
// node and element applies what its elements gathered. With rod contact r
// must be the whole batch (partners may be anywhere).
// reads: model, state, contact data  writes: state.node_v, elem_w, contact scratch and work
// solve_kv: as contact_view's (the colliders of the rods the solve steps
// were met in host/core/step/contact_solve.h).
template <Terms kT, class T>
void contact_stage(RodBatch<T>& b, T h, const ColliderFrame<T>* frames, const Exec& ex, const Segment& r,
                   bool solve_kv = false) {
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  const ConstStateView<T> cs = std::as_const(b).state_view();
  const ContactView<T> cv = contact_view(b, frames, solve_kv, kT.rod_contact);
  constexpr bool kC = kT.colliders, kR = kT.rod_contact;
  detail::for_slots(r.begin, r.end, ex, [&](int k) { element_contacts<kC, kR, false>(k, h, m, cs, cv); });
  detail::for_slots(r.begin, r.end, ex, [&](int k) { element_contacts<kC, kR, true>(k, h, m, cs, cv); });
  detail::for_slots(r.begin, r.end, ex, [&](int k) { apply_contact(k, m, s, cv); });
}

// The velocities at the step's start on the slots of r, before its first
// drift (the contact work's mean velocity, kernels/contact.h apply_contact).
// reads: state.node_v, elem_w  writes: contact.v_start, w_start
template <class T>
void contact_start_stage(RodBatch<T>& b, const Exec& ex, const Segment& r) {
  const ConstStateView<T> cs = std::as_const(b).state_view();
  const ContactView<T> cv = contact_view(b, static_cast<const ColliderFrame<T>*>(nullptr));
  detail::for_slots(r.begin, r.end, ex, [&](int k) { save_start_velocities(k, cs, cv); });
}

// ---- the contact stage of a step: the variant its Terms choose ----------------
// Without contact Terms there is nothing to do and nothing is compiled; with
// colliders only, each segment meets them on its own (temporal blocking
// holds); rod–rod contact couples the rods (contact_couples_rods): the
// driver runs the stage on the whole batch, the broad phase first.

template <Terms kT>
constexpr bool contact_couples_rods() {
  return kT.rod_contact;
}

// Colliders placed for each of `count` steps from the batch's time (a
// segment's steps read their step's row, step_frames: the placements are
// computed once, not per segment); none without Terms::colliders.
template <Terms kT, class T>
std::vector<ColliderFrame<T>> collider_frames(const RodBatch<T>& b, T dt, std::int64_t count) {
  std::vector<ColliderFrame<T>> f;
  if constexpr (kT.colliders) {
    const std::size_t nc = b.contact.spec.colliders.size();
    f.resize(nc * std::size_t(count));
    double t = b.state.time;
    for (std::int64_t i = 0; i < count; ++i, t += double(dt))
      place_colliders(b.contact, t, double(dt), f.data() + nc * std::size_t(i));
  }
  return f;
}
// Step i's row of collider_frames (nc colliders a step); nullptr without colliders.
template <class T>
const ColliderFrame<T>* step_frames(const std::vector<ColliderFrame<T>>& f, std::size_t nc, std::int64_t i) {
  return f.empty() ? nullptr : f.data() + nc * std::size_t(i);
}

// std::invalid_argument when the Terms have contact and the batch has none.
template <Terms kT, class T>
void check_contact(const RodBatch<T>& b) {
  if constexpr (kT.colliders || kT.rod_contact)
    if (!b.contact.on)
      throw std::invalid_argument("step: the Terms have contact on but the batch has none (set_contact first)");
}
// std::invalid_argument for contact Terms in an integrator without the stage.
template <Terms kT>
void refuse_contact(const char* integrator) {
  if constexpr (kT.colliders || kT.rod_contact)
    throw std::invalid_argument(std::string(integrator) +
                                ": contact (Terms::colliders, Terms::rod_contact) is stepped by Position Verlet "
                                "only; use step/step_n/advance with Integrator::position_verlet");
}

// The stage: [broad phase,] contact impulses on segment r (the whole batch
// when contact_couples_rods), with the colliders placed by `frames`.
template <Terms kT, class T>
void contact_step(RodBatch<T>& b, T h, const ColliderFrame<T>* frames, const Exec& ex, const Segment& r, int thread,
                  bool solve_kv) {
  if constexpr (contact_couples_rods<kT>())
    timed(ex, thread, Stage::broad_phase, [&] { update_neighbours(b, h, ex); });
  if constexpr (kT.colliders || kT.rod_contact)
    timed(ex, thread, Stage::contact, [&] { contact_stage<kT>(b, h, frames, ex, r, solve_kv); });
}

}  // namespace manyrods
