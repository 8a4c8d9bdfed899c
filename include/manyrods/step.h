// include/manyrods/step.h — stepping a batch, and what a step reports.
//
//   step<Terms, Viscous>(batch, dt, exec)             one Position Verlet step
//   step_n<Terms, Viscous>(batch, dt, count, exec)    `count` of them, temporally blocked
//   step_pefrl<Terms, Viscous>(batch, dt, exec)       one PEFRL step (4th order)
//   advance<Terms, Viscous, Integrator>(batch, dt, steps, exec, options)
//                                                     many steps with a non-finite watch
//   energies<Terms>(batch, rod)                       kinetic, elastic, potential, 2·D_v
//   find_non_finite(batch)                            the first non-finite state entry
//
// The integrators, their order and stability are described in docs/model.md
// "Time stepping"; how a step is scheduled over segments and threads in
// docs/architecture.md. Results are bit-identical for any thread count.
//
// Which Terms are compiled. The library holds these functions for float and
// double and for the Terms the scene runner selects: kAllTerms with the
// Kelvin–Voigt term and gravity each on or off (kAllTerms, kNoKelvinVoigt,
// kNoGravity, kNoKelvinVoigtNoGravity), with Viscous::implicit and both
// integrators. Other combinations (e.g. shear off at compile time, or
// Viscous::explicit_rate) are templates in host/core/advanced.h, which code
// built against the source tree includes instead of this header.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "manyrods/batch.h"
#include "manyrods/profile.h"
#include "manyrods/terms.h"

namespace manyrods {

// Execution settings come from the caller; no global state.
struct Exec {
  int threads = 1;             // OpenMP threads for this call
  Profile* profile = nullptr;  // per-stage times (include/manyrods/profile.h), or none
  // Float steps run with subnormals flushed to zero (x86-64 FTZ/DAZ, for the
  // call only, on every thread of the step): a rod at rest makes subnormal
  // floats, which Intel cores compute in microcode, several times slower.
  // false keeps IEEE gradual underflow (last bits may differ; the physics
  // does not: a subnormal is below 1.2e-38). Double steps ignore it.
  bool flush_subnormals = true;
  // A float batch's stiff rods (RodSpec::stiff_implicit) have their implicit
  // solve in double: in float its ill-conditioned system (h²ω² ≈ 10⁵ for
  // hair at frame-rate steps) loses the slow motion within a second
  // (docs/model.md "Stiff rods in float"). false: the solve in float, for
  // comparison only. Double batches ignore it.
  bool stiff_solve_in_double = true;
  // Set by the step itself, not by callers: where the segment schedule runs
  // a batch's fused segments one at a time (a batch of one or two of them:
  // a small sweep, a calibration's generation; host/core/step/schedule.h),
  // each segment's stages run on one thread but its implicit solve shares
  // its lane groups over this many (the results are the same bit for bit:
  // the groups, and so each rod's kernel, do not depend on the thread count).
  int solve_threads = 1;
};

// Runs task(i) for every i in [0, count) on OpenMP threads (a dynamic
// schedule over the default team), each thread in the calling thread's
// floating-point mode (subnormal flushing included), as a step's threads
// are: independent tasks give the same numbers on any thread count. For
// set-up work over independent rods (static pre-load solves); task must
// not throw.
void parallel_tasks(std::size_t count, const std::function<void(std::size_t)>& task);

// How the Kelvin–Voigt force is integrated.
//   implicit:      backward Euler in the velocities after the elastic kick
//                  (kernels/viscous_implicit.h): stable for any τ, one
//                  block-tridiagonal solve per rod and step.
//   explicit_rate: the viscous resultants use the rates at the start of the
//                  kick; stable only for dt ≲ 2/(τ ω_max²). The accuracy
//                  reference.
enum class Viscous { implicit, explicit_rate };

enum class Integrator { position_verlet, pefrl };

// The Terms the library is compiled for (see above).
inline constexpr Terms kNoKelvinVoigt{true, true, true, true, false, true, true};
inline constexpr Terms kNoGravity{true, true, true, true, true, false, true};
inline constexpr Terms kNoKelvinVoigtNoGravity{true, true, true, true, false, false, true};
inline constexpr Terms kColliders{true, true, true, true, true, true, true, true, false};
inline constexpr Terms kRodContact{true, true, true, true, true, true, true, false, true};
inline constexpr Terms kAllContact{true, true, true, true, true, true, true, true, true};
inline constexpr Terms kCollidersNoKelvinVoigt{true, true, true, true, false, true, true, true, false};
inline constexpr Terms kRodContactNoKelvinVoigt{true, true, true, true, false, true, true, false, true};
inline constexpr Terms kAllContactNoKelvinVoigt{true, true, true, true, false, true, true, true, true};

// Energies of rod `rod` (or of the whole batch when rod < 0), summed in
// double in index order (deterministic).
// The energies of a batch or a rod, one entry each:
//   X(name, dataset, unit, written, meaning)
// name: the member of Energies, the key of Python's Batch.energies() and the
// member of the C API's mr_energies (checked member by member when the C API
// compiles); dataset: its /energy dataset in an output file (h5io.h EnergyRow,
// the writer, the reader and Python's read_output()["energy"]); written:
// every frame (always) or only in scenes with contact (contact). An entry
// added here appears in all of them.
// contact_work: the work done on the rods by contact and friction impulses
// since set_contact (≤ 0 where they only dissipate; with moving colliders
// also a source): kinetic + elastic + potential − contact_work + ∫2·D_v dt
// is constant (docs/contact.md "Energy"); zero without contact Terms.
#define MANYRODS_ENERGY_FIELDS(X)                                                            \
  X(kinetic, "kinetic", "J", always, "translational + rotational")                           \
  X(elastic, "elastic", "J", always, "stretch, shear, bend, twist")                          \
  X(potential, "potential", "J", always, "gravity and dead point forces")                    \
  X(dissipation, "dissipation_rate", "W", always, "2·D_v: the rate of viscous energy loss") \
  X(contact_work, "contact_work", "J", contact, "work of the contact and friction impulses")

struct Energies {
#define MANYRODS_ENERGY_MEMBER(name, dataset, unit, written, doc) double name = 0;
  MANYRODS_ENERGY_FIELDS(MANYRODS_ENERGY_MEMBER)
#undef MANYRODS_ENERGY_MEMBER
  double total() const { return kinetic + elastic + potential; }
};

// The first non-finite entry of the state, if any: rod, what and index.
struct NonFinite {
  bool found = false;
  int rod = -1;
  std::string field;  // "node" or "element"
  int index = -1;
};

// Thrown by advance() when the state stops being finite.
struct NonFiniteError : std::runtime_error {
  NonFiniteError(const std::string& what, NonFinite where_, std::int64_t step_, double time_)
      : std::runtime_error(what), where(where_), step(step_), time(time_) {}
  NonFinite where;    // first rod and node/element not finite after `step`
  std::int64_t step;  // the batch's step count (State::steps) after the offending step
  double time;        // simulated time after it, s
};

struct AdvanceOptions {
  int check_every = 64;  // steps between checks (≥ 1); a check also follows the last step
};

// The step functions take dt in the batch's precision T, and dt does not
// take part in deducing T (std::type_identity_t): the batch decides, so a
// float batch steps with a double dt such as 0.5 * stable_dt(b).elastic.
//
// `count` Position Verlet steps of length dt for every rod in the batch, the
// same result as `count` calls of step (docs/architecture.md "The segment
// schedule": each segment runs all `count` steps while it is in cache).
template <Terms kT = kAllTerms, Viscous kV = Viscous::implicit, class T>
void step_n(RodBatch<T>& b, std::type_identity_t<T> dt, std::int64_t count, const Exec& ex = {});

// One Position Verlet step of length dt for every rod in the batch.
template <Terms kT = kAllTerms, Viscous kV = Viscous::implicit, class T>
void step(RodBatch<T>& b, std::type_identity_t<T> dt, const Exec& ex = {}) {
  step_n<kT, kV>(b, dt, 1, ex);
}

// One PEFRL step of length dt (Omelyan, Mryglod & Folk 2002; 4th order for
// the conservative part; kEulerOrder: the order of the rigid-body sub-flow
// in its kicks, 4 keeps the method 4th order in 3-D). Throws
// std::invalid_argument for a batch with stiff rods (Position Verlet only).
template <Terms kT = kAllTerms, Viscous kV = Viscous::implicit, int kEulerOrder = 4, class T>
void step_pefrl(RodBatch<T>& b, std::type_identity_t<T> dt, const Exec& ex = {});

// Advances every rod of the batch by `steps` steps of length dt with the
// chosen integrator. The state is checked every opt.check_every steps and
// after the last; when it stops being finite, the steps since the last good
// check are replayed to find the first bad one, the batch is left there and
// NonFiniteError names the rod, node or element, step and time. Throws
// std::invalid_argument for steps < 0 or check_every < 1.
template <Terms kT = kAllTerms, Viscous kV = Viscous::implicit, Integrator kI = Integrator::position_verlet,
          class T>
void advance(RodBatch<T>& b, std::type_identity_t<T> dt, std::int64_t steps, const Exec& ex = {}, const AdvanceOptions& opt = {});

template <Terms kT = kAllTerms, class T>
Energies energies(const RodBatch<T>& b, int rod = -1);

template <class T>
NonFinite find_non_finite(const RodBatch<T>& b);

// ---- what the library holds (host/core/step/instantiate_float.cpp, instantiate_double.cpp)------------------------
#define MANYRODS_STEP_DECLARATIONS(EXTERN, T, TERMS)                                                     \
  EXTERN template void step_n<TERMS, Viscous::implicit, T>(RodBatch<T>&, T, std::int64_t, const Exec&);  \
  EXTERN template void step_pefrl<TERMS, Viscous::implicit, 4, T>(RodBatch<T>&, T, const Exec&);         \
  EXTERN template void advance<TERMS, Viscous::implicit, Integrator::position_verlet, T>(                \
      RodBatch<T>&, T, std::int64_t, const Exec&, const AdvanceOptions&);                                \
  EXTERN template void advance<TERMS, Viscous::implicit, Integrator::pefrl, T>(                          \
      RodBatch<T>&, T, std::int64_t, const Exec&, const AdvanceOptions&);                                \
  EXTERN template Energies energies<TERMS, T>(const RodBatch<T>&, int);
// The Terms lists, each named once: the library's explicit instantiations,
// the extern declarations below and the run-time step paths
// (include/manyrods/isa.h) are all built from them. X(ARGS..., TERMS).
#define MANYRODS_PLAIN_TERMS(X, ...) \
  X(__VA_ARGS__, kAllTerms) X(__VA_ARGS__, kNoKelvinVoigt) X(__VA_ARGS__, kNoGravity) X(__VA_ARGS__, kNoKelvinVoigtNoGravity)
// With contact (include/manyrods/contact.h): colliders, rod–rod/self, both;
// each with and without the Kelvin–Voigt term, with gravity (a scene without
// gravity sets it to zero). Position Verlet only.
#define MANYRODS_CONTACT_TERMS(X, ...)                                                          \
  X(__VA_ARGS__, kColliders) X(__VA_ARGS__, kRodContact) X(__VA_ARGS__, kAllContact)           \
  X(__VA_ARGS__, kCollidersNoKelvinVoigt) X(__VA_ARGS__, kRodContactNoKelvinVoigt)             \
  X(__VA_ARGS__, kAllContactNoKelvinVoigt)

#define MANYRODS_STEP_ALL_TERMS(EXTERN, T) MANYRODS_PLAIN_TERMS(MANYRODS_STEP_DECLARATIONS, EXTERN, T)
#define MANYRODS_STEP_CONTACT_DECLARATIONS(EXTERN, T, TERMS)                                             \
  EXTERN template void step_n<TERMS, Viscous::implicit, T>(RodBatch<T>&, T, std::int64_t, const Exec&);  \
  EXTERN template void advance<TERMS, Viscous::implicit, Integrator::position_verlet, T>(                \
      RodBatch<T>&, T, std::int64_t, const Exec&, const AdvanceOptions&);                                \
  EXTERN template Energies energies<TERMS, T>(const RodBatch<T>&, int);
#define MANYRODS_STEP_CONTACT_TERMS(EXTERN, T) MANYRODS_CONTACT_TERMS(MANYRODS_STEP_CONTACT_DECLARATIONS, EXTERN, T)

// (host/core/isa/isa_variant.cpp compiles the step for another instruction set and
// must instantiate it itself)
#ifndef MANYRODS_ISA_VARIANT
MANYRODS_STEP_ALL_TERMS(extern, float)
MANYRODS_STEP_ALL_TERMS(extern, double)
MANYRODS_STEP_CONTACT_TERMS(extern, float)
MANYRODS_STEP_CONTACT_TERMS(extern, double)
extern template NonFinite find_non_finite<float>(const RodBatch<float>&);
extern template NonFinite find_non_finite<double>(const RodBatch<double>&);
#endif

}  // namespace manyrods
