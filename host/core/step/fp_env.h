// host/core/step/fp_env.h — the floating-point mode a step runs in: subnormal floats
// flushed to zero (FTZ) and read as zero (DAZ) in float steps.
//
// Why: a rod coming to rest makes velocities, rates and strain changes that
// decay below FLT_MIN (1.2e-38) — subnormals. Intel cores compute with them
// in microcode, 100 cycles and more per operation, and the float step then
// ran 3.5–5.6× slower than with the flush (bench/RESULTS.md); AMD cores do
// not show the penalty. A flushed subnormal is below 1e-38 of any quantity
// of a rod, so the physics does not change; the last bits of a state may
// (Exec::flush_subnormals = false keeps IEEE gradual underflow).
//
// How: step_n and step_pefrl set the mode on the calling thread for the
// call (FpScope), and every parallel region of the step hands the caller's
// mode to its threads (RegionFpScope, first in a `parallel` block around
// the `for`); on return the calling thread has its mode back and the pool's
// threads the caller's mode from before the step, so a host application's
// threads are not changed. Double steps run in the caller's mode as it is.
// On CPUs other than x86-64 the mode is not touched (FTZ there is another
// register).
#pragma once

#include <omp.h>

#include <type_traits>

#if defined(__SSE__) || defined(__x86_64__)
#include <immintrin.h>
#define MANYRODS_HAS_MXCSR 1
#else
#define MANYRODS_HAS_MXCSR 0
#endif

#include "manyrods/step.h"  // Exec

namespace manyrods {

// The calling thread's floating-point control word (MXCSR on x86-64; 0
// elsewhere).
inline unsigned fp_mode() {
#if MANYRODS_HAS_MXCSR
  return _mm_getcsr();
#else
  return 0;
#endif
}

namespace detail {
inline void set_fp_mode([[maybe_unused]] unsigned mode) {
#if MANYRODS_HAS_MXCSR
  if (mode != _mm_getcsr()) _mm_setcsr(mode);
#endif
}
// The calling thread's mode outside the outermost step it is in, and how
// deep in steps it is (a step may call another's stages). Defined once, in
// fp_env.cpp: every build of the step (host/core/isa/isa_variant.cpp) shares
// them with the baseline's code (an inline variable would give the variant
// an unshared copy of its own, which its linking also refuses).
extern thread_local unsigned t_outside_mode;
extern thread_local int t_step_depth;
}  // namespace detail

// A step's mode on its calling thread: set for the scope, then restored.
class FpScope {
 public:
  explicit FpScope(unsigned mode) : saved_(fp_mode()) {
    if (detail::t_step_depth++ == 0) detail::t_outside_mode = saved_;
    detail::set_fp_mode(mode);
  }
  ~FpScope() {
    detail::set_fp_mode(saved_);
    --detail::t_step_depth;
  }
  FpScope(const FpScope&) = delete;
  FpScope& operator=(const FpScope&) = delete;

 private:
  unsigned saved_;
};

// What a parallel region hands its threads: the caller's mode now, and the
// mode the caller had outside the step (what a worker is left in).
struct RegionFpMode {
  unsigned during, after;
  static RegionFpMode of_caller() {
    return {fp_mode(), detail::t_step_depth > 0 ? detail::t_outside_mode : fp_mode()};
  }
};

// The first statement of every parallel region of a step: the thread runs
// in the caller's mode. At the end the calling thread (thread 0) has its
// mode back and a worker is left in the caller's mode from outside the step
// — not the worker's own: a pool thread started inside a step inherits the
// step's mode, which is not the host's.
class RegionFpScope {
 public:
  explicit RegionFpScope(const RegionFpMode& m) : after_(omp_get_thread_num() == 0 ? fp_mode() : m.after) {
    detail::set_fp_mode(m.during);
  }
  ~RegionFpScope() { detail::set_fp_mode(after_); }
  RegionFpScope(const RegionFpScope&) = delete;
  RegionFpScope& operator=(const RegionFpScope&) = delete;

 private:
  unsigned after_;
};

// The mode a step of precision T runs in: the caller's, with FTZ and DAZ
// set for float when ex.flush_subnormals.
template <class T>
unsigned step_fp_mode(const Exec& ex) {
  unsigned mode = fp_mode();
#if MANYRODS_HAS_MXCSR
  constexpr unsigned kFlushToZero = 0x8000, kDenormalsAreZero = 0x0040;
  if (std::is_same_v<T, float> && ex.flush_subnormals) mode |= kFlushToZero | kDenormalsAreZero;
#endif
  return mode;
}

}  // namespace manyrods
