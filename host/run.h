// host/run.h — advancing a batch many steps with a watch for non-finite
// states (issue 5: "when a state goes non-finite the step stops and reports
// the first rod and element, the step and the time").
//
// advance() steps the batch and checks the state with find_non_finite every
// `check_every` steps and after the last one. A check costs about one pass
// over the state arrays; at the default of 64 steps it is a small fraction
// of the stepping. At each passed check the state is kept (one copy of the
// State arrays). When a check fails, the steps since the last good check are
// replayed one by one from that copy (the step is deterministic, so the
// replay is the same run) to find the FIRST step whose result is not
// finite; the batch is left in that state, and NonFiniteError names the
// rod (index and name), the first node or element that is not finite at
// that step, the step number and the simulated time. Locating the first
// step matters: a few steps later the NaNs have spread along the whole rod,
// and the first non-finite entry no longer says where the trouble began.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>

#include "host/step.h"

namespace manyrods {

// Thrown by advance() when the state stops being finite.
struct NonFiniteError : std::runtime_error {
  NonFiniteError(const std::string& what, NonFinite where_, std::int64_t step_, double time_)
      : std::runtime_error(what), where(where_), step(step_), time(time_) {}
  NonFinite where;    // first rod and node/element not finite after `step`
  std::int64_t step;  // the batch's step count (State::steps) after the offending step
  double time;        // simulated time after it, s
};

enum class Integrator { position_verlet, pefrl };

struct AdvanceOptions {
  int check_every = 64;  // steps between checks (≥ 1); a check also follows the last step
};

namespace detail {

template <class T, std::size_t N>
void copy_arrays(std::array<Array<T>, N>& dst, const std::array<Array<T>, N>& src) {
  for (std::size_t i = 0; i < N; ++i) {
    if (dst[i].size() != src[i].size()) {
      dst[i] = src[i];
    } else if (src[i].size() > 0) {  // guards included, no reallocation
      std::memcpy(dst[i].data() - kGuard, src[i].data() - kGuard, src[i].bytes());
    }
  }
}

template <class T>
void copy_state(State<T>& dst, const State<T>& src) {
  copy_arrays(dst.node_x, src.node_x);
  copy_arrays(dst.node_v, src.node_v);
  copy_arrays(dst.elem_Q, src.elem_Q);
  copy_arrays(dst.elem_w, src.elem_w);
  copy_arrays(dst.node_xc, src.node_xc);
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

// Advances every rod of the batch by `steps` steps of length dt with the
// chosen integrator (Position Verlet: step; PEFRL: step_pefrl). Throws
// NonFiniteError (batch left at the first non-finite step) if the state
// stops being finite; throws std::invalid_argument for steps < 0 or
// check_every < 1.
template <Terms kT = kAllTerms, Viscous kV = Viscous::implicit, Integrator kI = Integrator::position_verlet,
          class T>
void advance(RodBatch<T>& b, T dt, std::int64_t steps, const Exec& ex = {}, const AdvanceOptions& opt = {}) {
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
