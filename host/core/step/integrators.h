// host/core/step/integrators.h — the integrators as lists of stages (host/core/step/stages.h),
// and advance: Position Verlet (step_n), PEFRL (step_pefrl). The public
// declarations and what each guarantees are in include/manyrods/step.h; the
// schemes in docs/model.md "Time stepping".
//
// Position Verlet (Gazzola et al. 2018; the scheme PyElastica uses), h = dt:
//   0. (driven holds) roots, tips, nodes put on their motion
//      for [t, t + h]                                          apply_motions
//   0b. (contact Terms) v, ω saved for the contact work           contact_start_stage
//   1. drift ½h:  x += ½h v,  Q ← exp(−½h ω) Q                drift
//   2. strains and total resultants at (x, Q)_{n+½} with the
//      rates from (v, ω)_n (stiff rods: and −c h C_M U̇_n)      compute_resultants
//   3. kick h:    v += h m⁻¹ F,  ω += h J⁻¹ C                  segment_kick
//      (a fluid) v saved before the kick                       fluid_save_stage
//   4. (M + hD) u⁺ = M u for damped and stiff rods             viscous_update
//   4a. (colliders, self contact) the rods of 4 that touch one
//      or themselves solved again with their contacts in the
//      system (with rod contact, after the broad phase)          contact_solve_stage
//   4b. (a fluid) kick and solve redone with the drag as an exact flow  fluid_stage
//   4c. (contact Terms) [broad phase,] contact impulses         contact_step
//   5. drift ½h                                                drift
//   6. (float) frames renormalized every 16th step            renormalize_frames
// A float step runs with subnormals flushed to zero on all its threads
// (Exec::flush_subnormals, host/core/step/fp_env.h).
// Second order for the elastic (conservative) part, first order for the
// Kelvin–Voigt part in both treatments: Viscous::explicit_rate evaluates the
// viscous resultants with the velocities at the start of the kick (stable for
// dt ≲ 2/(τ ω_max²)); Viscous::implicit (the default) integrates them by
// backward Euler after the elastic kick (stable for any τ).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "host/core/step/contact_solve.h"
#include "host/core/step/contact_stage.h"
#include "host/core/step/diagnostics.h"
#include "host/core/step/fluid_stage.h"
#include "host/core/step/fp_env.h"
#include "host/core/step/implicit_solve.h"
#include "host/core/isa/isa_table.h"
#include "host/core/step/root_motion.h"
#include "host/core/step/schedule.h"
#include "host/core/step/stages.h"
#include "manyrods/step.h"

namespace manyrods {

namespace detail {
// The Terms of the explicit stages: without the Kelvin–Voigt term when the
// implicit solve integrates it.
template <Terms kT, Viscous kV>
constexpr Terms explicit_terms() {
  Terms t = kT;
  if (kT.kelvin_voigt && kV == Viscous::implicit) t.kelvin_voigt = false;
  return t;
}
// The Terms of the implicit solve: the Kelvin–Voigt term when it integrates it.
template <Terms kT, Viscous kV>
constexpr Terms solve_terms() {
  Terms t = kT;
  t.kelvin_voigt = kT.kelvin_voigt && kV == Viscous::implicit;
  return t;
}

// Which part of the step's stage list a call runs. Every stage runs on
// one segment, except the contact stage with rod–rod contact, which couples
// the rods (partners may be in any segment): then the driver runs the list
// up to it on every segment, it on the whole batch, and the rest on every
// segment. Where the contact solve reads the broad phase's lists (self
// contact: contact_solve_reads_lists), the list up to it stops after the
// implicit solve, and the driver runs the broad phase on the whole batch,
// then the solve's contacts and the fluid on every segment (contact_solve).
enum class Part { all, before_contact, contact_solve, contact, after_contact };

// Whether the step solves contacts inside the implicit solve: colliders, or
// self contact with rod contact (the rods it steps then find theirs there).
template <Terms kT, class T>
bool solves_contacts(const RodBatch<T>& b, bool solve) {
  if constexpr (kT.colliders || kT.rod_contact)
    return solve && ((kT.colliders && !b.contact.spec.colliders.empty()) ||
                     (kT.rod_contact && (b.contact.spec.self || b.contact.spec.rod_rod)));
  return false;
}
// Whether the contact solve reads the broad phase's candidate lists (self
// contact), so that it must wait for the broad phase on the whole batch.
template <Terms kT, class T>
bool contact_solve_reads_lists(const RodBatch<T>& b) {
  return kT.rod_contact && (b.contact.spec.self || b.contact.spec.rod_rod);
}
// Whether rods meet each other in the contact solve (rod–rod contact): it
// then runs on the whole batch, not per segment.
template <Terms kT, class T>
bool rods_meet_in_solve(const RodBatch<T>& b) {
  return kT.rod_contact && b.contact.spec.rod_rod;
}

// One Position Verlet step on segment r at time t, the stages in order (the
// file comment's list). `done`: the batch's step count once the step is
// done (the float renormalization's cadence); `frames`: the colliders
// placed for this step. The contact stage comes after the implicit solve:
// before it, a stiff rod's velocities still hold its unresolved stiff modes
// (h|ω| ≫ 1), which the contact must not see.
template <Terms kT, Viscous kV, class T>
void verlet_stages(RodBatch<T>& b, T dt, double t, std::int64_t done, bool solve, const ColliderFrame<T>* frames,
                   const Exec& e, const Segment& r, int thread, Part part) {
  constexpr Terms kExplicit = detail::explicit_terms<kT, kV>();
  constexpr Terms kSolve = detail::solve_terms<kT, kV>();
  if (part == Part::all || part == Part::before_contact) {
    if (r.driven_end > r.driven_begin)
      timed(e, thread, Stage::root_motion, [&] { apply_motions(b, r, t, double(dt)); });
    if constexpr (kT.colliders || kT.rod_contact)
      timed(e, thread, Stage::contact, [&] { contact_start_stage(b, e, r); });
    timed(e, thread, Stage::drift, [&] { drift(b, T(0.5) * dt, e, r); });
    timed(e, thread, Stage::resultants, [&] { compute_resultants<kExplicit>(b, e, r, T(-kStiffBendingC) * dt); });
    const bool fluid = b.any_fluid();
    if (fluid) timed(e, thread, Stage::fluid, [&] { fluid_save_stage(b, e, r); });
    timed(e, thread, Stage::kick, [&] { segment_kick<kExplicit>(b, dt, e, r); });
    if (solves_contacts<kT>(b, solve)) timed(e, thread, Stage::contact_solve, [&] { contact_solve_save(b, e, r); });
    // with collider contacts (and no self contact in the solve), the solve
    // takes its lane groups' contacts itself, and the stage below the rest
    bool fused = false;
    if constexpr (kT.colliders)
      if (solves_contacts<kT>(b, solve) && !contact_solve_reads_lists<kT>(b)) {
        timed(e, thread, Stage::implicit_solve,
              [&] { viscous_update_with_contacts<kSolve>(b, dt, frames, e, r, thread); });
        fused = true;
      }
    if (solve && !fused) timed(e, thread, Stage::implicit_solve, [&] { viscous_update<kSolve>(b, dt, e, r, thread); });
  }
  const bool late = contact_solve_reads_lists<kT>(b);
  if (part == Part::all || (part == Part::before_contact && !late) || part == Part::contact_solve) {
    if constexpr (kT.colliders || kT.rod_contact)
      if (solves_contacts<kT>(b, solve) && !rods_meet_in_solve<kT>(b))  // (else the driver's, on the whole batch)
        timed(e, thread, Stage::contact_solve, [&] { contact_solve_stage<kSolve>(b, dt, frames, e, r, thread); });
    // after the solve: a stiff rod's kick leaves its unresolved stiff modes in
    // the velocities, which the drag's decay must not scale (the solve would
    // then no longer cancel them); the velocity update of kick and solve
    // together is the drag flow's frozen forcing (the kick's time: mid-step)
    if (b.any_fluid()) timed(e, thread, Stage::fluid, [&] { fluid_stage(b, dt, t + 0.5 * double(dt), kT.gravity, e, r); });
  }
  if (part == Part::all || part == Part::contact) contact_step<kT>(b, dt, frames, e, r, thread, kSolve.kelvin_voigt);
  if (part == Part::all || part == Part::after_contact) {
    timed(e, thread, Stage::drift, [&] { drift(b, T(0.5) * dt, e, r); });
    if (renormalize_after<T>(done)) timed(e, thread, Stage::renormalize, [&] { renormalize_frames(b, e, r); });
  }
}

// Whether the step has an implicit solve (and its buffers reserved).
template <Terms kT, Viscous kV, class T>
bool prepare_solve(RodBatch<T>& b, const Exec& ex) {
  const bool solve = detail::solve_terms<kT, kV>().kelvin_voigt || b.any_stiff();
  if (solve) b.reserve_implicit_scratch(ex.threads);
  // the contact solve's buffers, one per thread (before any parallel region)
  if constexpr (kT.colliders || kT.rod_contact)
    if (solve) {
      if (int(b.workspace->contact_solve.size()) < std::max(ex.threads, 1))
        b.workspace->contact_solve.resize(std::size_t(std::max(ex.threads, 1)));
      if (b.workspace->contact_fused.size() < b.rods.size()) b.workspace->contact_fused.assign(b.rods.size(), 0);
      if (b.workspace->contact_hold.size() < b.rods.size()) b.workspace->contact_hold.assign(b.rods.size(), -1);
    }
  return solve;
}
}  // namespace detail

// `count` Position Verlet steps, the one driver of the stage list
// (detail::verlet_stages). Temporal blocking: each segment runs all stages
// of a block of steps before the next segment is touched (rods do not
// interact, so the order does not change any result); a block is all
// `count` steps, or one step when the contact stage couples the rods
// (rod–rod contact): then each step runs its parts in turn (detail::Part),
// each on every segment or on the whole batch.
template <Terms kT, Viscous kV, class T>
void step_n(RodBatch<T>& b, std::type_identity_t<T> dt, std::int64_t count, const Exec& ex) {
#ifndef MANYRODS_ISA_VARIANT  // the build of the step for the CPU (host/core/isa/isa_table.h)
  constexpr int kSlot = kV == Viscous::implicit ? isa::slot(isa::kStepNTerms, kT) : -1;
  if constexpr (kSlot >= 0)
    if (const isa::StepTable* t = isa::active_table()) return isa::fns<T>(*t).step_n[kSlot](b, dt, count, ex);
#endif
  const FpScope fp(step_fp_mode<T>(ex));  // float: subnormals flushed (host/core/step/fp_env.h)
  check_contact<kT>(b);
  const bool solve = detail::prepare_solve<kT, kV>(b, ex);
  constexpr bool kCoupled = contact_couples_rods<kT>();
  const std::int64_t block = kCoupled ? 1 : count;
  const std::size_t nc = b.contact.spec.colliders.size();
  using detail::Part;
  for (std::int64_t first = 0; first < count; first += block) {
    const std::vector<ColliderFrame<T>> frames = collider_frames<kT>(b, dt, block);
    const double t0 = b.state.time;
    const std::int64_t steps0 = b.state.steps;
    const Part part = kCoupled ? Part::before_contact : Part::all;
    for_each_segment(b, ex, [&](const Segment& r, const Exec& e, int thread) {
      double t = t0;
      for (std::int64_t i = 0; i < block; ++i, t += double(dt))
        detail::verlet_stages<kT, kV>(b, dt, t, steps0 + i + 1, solve, step_frames(frames, nc, i), e, r, thread,
                                      part);
    });
    if constexpr (kCoupled) {
      const ColliderFrame<T>* step_frame = step_frames(frames, nc, 0);  // (block = 1; nullptr: no colliders)
      // the lists the contact solve reads (self contact), at its positions
      // (the contact stage checks them again at its velocities), then it
      if (detail::contact_solve_reads_lists<kT>(b)) {
        if (detail::solves_contacts<kT>(b, solve)) {
          timed(ex, 0, Stage::broad_phase, [&] { update_neighbours(b, dt, ex); });
          // rods meeting each other: the contact solve on the whole batch
          if (detail::rods_meet_in_solve<kT>(b))
            timed(ex, 0, Stage::contact_solve, [&] {
              contact_solve_stage<detail::solve_terms<kT, kV>()>(b, dt, step_frame, ex, whole(b), 0);
            });
        }
        for_each_segment(b, ex, [&](const Segment& r, const Exec& e, int thread) {
          detail::verlet_stages<kT, kV>(b, dt, t0, steps0 + 1, solve, step_frame, e, r, thread, Part::contact_solve);
        });
      }
      detail::verlet_stages<kT, kV>(b, dt, t0, steps0 + 1, solve, step_frame, ex, whole(b), 0, Part::contact);
      for_each_segment(b, ex, [&](const Segment& r, const Exec& e, int thread) {
        detail::verlet_stages<kT, kV>(b, dt, t0, steps0 + 1, solve, step_frame, e, r, thread, Part::after_contact);
      });
    }
    for (std::int64_t i = 0; i < block; ++i) b.state.time += double(dt);  // as `block` step() calls
    b.state.steps += block;
  }
}

// PEFRL coefficients (Omelyan, Mryglod, Folk, Comput. Phys. Commun. 146,
// 188–202, 2002, eq. 20: the position-extended Forest–Ruth-like method with
// the smallest leading error of its family).
struct Pefrl {
  static constexpr double xi = 0.1786178958448091;
  static constexpr double lambda = -0.2123418310626054;
  static constexpr double chi = -0.06626458266981849;
};

// One PEFRL step: the drift and kick stages of Position Verlet, composed as
//   drift ξh, kick (½−λ)h, drift χh, kick λh, drift (1−2(χ+ξ))h,
//   kick λh, drift χh, kick (½−λ)h, drift ξh
// (four resultant evaluations per step; λ, χ < 0, so two kicks and two
// drifts run backwards). Linear stability (undamped): h·ω_max < 2.99, against
// 2 for Position Verlet with a quarter of the force evaluations. Stages run
// over the whole batch (no temporal blocking).
//
// The rigid-body term (Jω)×ω is integrated inside each kick by a 4th-order
// composition of implicit-midpoint steps (kEulerOrder = 4, see
// kernels/integrate.h); with Position Verlet's single midpoint step
// (kEulerOrder = 2) PEFRL is only second order in 3-D
// (tests/test_integrators.cpp measures both).
//
// Order 4 holds for the conservative part. The Kelvin–Voigt term stays FIRST
// order in both treatments:
//   explicit_rate: each kick includes the viscous force with the rates at the
//     start of that kick (as in step); limited to h ≲ 2/(τ ω_max²);
//   implicit: after EACH of the four kicks a backward-Euler update of length
//     h/4 (positive, total h per step), at that kick's geometry: stable for
//     any τ. For one linear mode (frequency ω, viscous rate τω²) the
//     spectral radius of the step stays ≤ 1 for every h ω < 2.985 and
//     h τ ω² from 1e-4 to 1e9 (checked on a grid; the undamped PEFRL limit
//     is h ω < 2.989). Other placements of the update are unstable or wrong
//     for strongly damped modes (bench/RESULTS.md "Design history"):
//     negative sub-steps and dissipation do not mix well (no splitting of
//     order > 2 avoids negative sub-steps, Sheng 1989, Suzuki 1991), so for
//     strongly damped rods Position Verlet is the better choice.
//
// Driven holds follow their motion drift by drift: each drift of length
// c·dt starts the root at its pose of that stage's time and lands on the
// next stage's (so the kicks see the root where it is at their time and
// PEFRL keeps its order; tests/test_drive.cpp).
template <Terms kT, Viscous kV, int kEulerOrder, class T>
void step_pefrl(RodBatch<T>& b, std::type_identity_t<T> dt, const Exec& ex) {
#ifndef MANYRODS_ISA_VARIANT
  constexpr int kSlot = kV == Viscous::implicit && kEulerOrder == 4 ? isa::slot(isa::kPefrlTerms, kT) : -1;
  if constexpr (kSlot >= 0)
    if (const isa::StepTable* t = isa::active_table()) return isa::fns<T>(*t).step_pefrl[kSlot](b, dt, ex);
#endif
  const FpScope fp(step_fp_mode<T>(ex));
  constexpr bool kImplicit = kT.kelvin_voigt && kV == Viscous::implicit;
  constexpr Terms kExplicit = detail::explicit_terms<kT, kV>();
  refuse_contact<kT>("step_pefrl");
  if (b.any_stiff())
    throw std::invalid_argument(
        "step_pefrl: the batch has stiff rods (RodSpec::stiff_implicit), which only Position Verlet "
        "steps stably; use step/step_n/advance with Integrator::position_verlet");
  if (b.any_fluid())
    throw std::invalid_argument(
        "step_pefrl: the batch is in a fluid (set_fluid), whose drag PEFRL's backward kicks would amplify; "
        "use step/step_n/advance with Integrator::position_verlet");
  const T xi = T(Pefrl::xi) * dt, chi = T(Pefrl::chi) * dt;
  const T mid = T(1 - 2 * (Pefrl::chi + Pefrl::xi)) * dt;
  const T outer = T(0.5 - Pefrl::lambda) * dt, inner = T(Pefrl::lambda) * dt;
  const Segment all = whole(b);
  if (ex.profile) ex.profile->reserve(ex.threads);
  auto kick_stage = [&](T h) {
    timed(ex, 0, Stage::resultants, [&] { compute_resultants<kExplicit>(b, ex, all); });
    timed(ex, 0, Stage::kick, [&] { kick<kExplicit, kEulerOrder>(b, h, ex, all); });
    if constexpr (kImplicit)
      timed(ex, 0, Stage::implicit_solve, [&] { viscous_update<kT>(b, T(0.25) * dt, ex); });
  };
  double t = b.state.time;
  const bool driven = !b.driven.empty();
  auto root_drift = [&](T h, double c) {
    if (driven)
      timed(ex, 0, Stage::root_motion, [&] {
        for (const Segment& r : b.segments)
          if (r.driven_end > r.driven_begin) apply_motions(b, r, t, c * double(dt));
      });
    timed(ex, 0, Stage::drift, [&] { drift(b, h, ex, all); });
    t += c * double(dt);
  };
  root_drift(xi, Pefrl::xi);
  kick_stage(outer);
  root_drift(chi, Pefrl::chi);
  kick_stage(inner);
  root_drift(mid, 1 - 2 * (Pefrl::chi + Pefrl::xi));
  kick_stage(inner);
  root_drift(chi, Pefrl::chi);
  kick_stage(outer);
  root_drift(xi, Pefrl::xi);
  if (renormalize_after<T>(b.state.steps + 1))
    timed(ex, 0, Stage::renormalize, [&] { renormalize_frames(b, ex, all); });
  b.state.time += double(dt);
  b.state.steps += 1;
}

namespace detail {

template <class T>
void copy_field(Array<T>& dst, const Array<T>& src) {
  if (dst.size() != src.size()) {
    dst = src;
  } else if (src.size() > 0) {  // guards included, no reallocation
    std::memcpy(dst.data() - kGuard, src.data() - kGuard, src.bytes());
  }
}
template <class T, std::size_t N>
void copy_field(std::array<Array<T>, N>& dst, const std::array<Array<T>, N>& src) {
  for (std::size_t i = 0; i < N; ++i) copy_field(dst[i], src[i]);
}

// dst ← src, every field of MANYRODS_STATE_FIELDS (no reallocation when the
// sizes agree).
template <class T>
void copy_state(State<T>& dst, const State<T>& src) {
#define MANYRODS_COPY_FIELD(name, n, fill, float_only, doc) copy_field(dst.name, src.name);
  MANYRODS_STATE_FIELDS(MANYRODS_COPY_FIELD)
#undef MANYRODS_COPY_FIELD
  dst.time = src.time;
  dst.steps = src.steps;
}

template <Terms kT, Viscous kV, Integrator kI, class T>
void one_step(RodBatch<T>& b, T dt, const Exec& ex) {
  if constexpr (kI == Integrator::pefrl)
    step_pefrl<kT, kV>(b, dt, ex);
  else
    step<kT, kV>(b, dt, ex);
}

template <class T>
[[noreturn]] void throw_non_finite(const RodBatch<T>& b, const NonFinite& nf, T dt) {
  std::ostringstream os;
  os.precision(9);
  os << "non-finite state at step " << b.state.steps << " (t = " << b.state.time << " s, dt = " << double(dt)
     << " s): rod " << nf.rod << " ('" << b.rods[nf.rod].name << "', " << b.rods[nf.rod].elements
     << " elements), " << nf.field << " " << nf.index;
  throw NonFiniteError(os.str(), nf, b.state.steps, b.state.time);
}

}  // namespace detail

// advance(): the state is checked with find_non_finite every check_every
// steps and after the last one. A check costs about one pass over the state
// arrays; at the default of 64 steps it is a small fraction of the stepping.
// At each passed check the state is kept (one copy of the State arrays). When
// a check fails, the steps since the last good check are replayed one by one
// from that copy (the step is deterministic, so the replay is the same run)
// to find the FIRST step whose result is not finite: a few steps later the
// NaNs have spread along the whole rod, and the first non-finite entry no
// longer says where the trouble began.
template <Terms kT, Viscous kV, Integrator kI, class T>
void advance(RodBatch<T>& b, std::type_identity_t<T> dt, std::int64_t steps, const Exec& ex, const AdvanceOptions& opt) {
  if (steps < 0) throw std::invalid_argument("advance: steps must be >= 0");
  if (opt.check_every < 1) throw std::invalid_argument("advance: check_every must be >= 1");
  if (const NonFinite nf = find_non_finite(b); nf.found) detail::throw_non_finite(b, nf, dt);
  State<T> good = b.state;  // last state that passed a check
  std::int64_t done = 0;
  while (done < steps) {
    const std::int64_t chunk = std::min<std::int64_t>(opt.check_every, steps - done);
    if constexpr (kI == Integrator::pefrl) {
      for (std::int64_t i = 0; i < chunk; ++i) detail::one_step<kT, kV, kI>(b, dt, ex);
    } else {
      step_n<kT, kV>(b, dt, chunk, ex);  // temporally blocked, same result as `chunk` steps
    }
    if (const NonFinite nf = find_non_finite(b); nf.found) {
      // Replay from the last good state to the first non-finite step.
      detail::copy_state(b.state, good);
      for (std::int64_t i = 0; i < chunk; ++i) {
        detail::one_step<kT, kV, kI>(b, dt, ex);
        if (const NonFinite first = find_non_finite(b); first.found) detail::throw_non_finite(b, first, dt);
      }
      detail::throw_non_finite(b, nf, dt);  // not reached unless the replay differs
    }
    done += chunk;
    if (done < steps) detail::copy_state(good, b.state);
  }
}

}  // namespace manyrods
