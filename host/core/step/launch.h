// host/core/step/launch.h — runs a per-index kernel over the slots of a batch (or a range of them).
//
// The slot range is cut into blocks of kGuard (64) indices; OpenMP threads take
// whole blocks and each block is one `omp simd` loop of fixed length. Every
// index is therefore computed by the same instruction sequence whatever the
// thread count, and nothing is reduced across threads: results are
// bit-identical for any number of threads (docs/architecture.md "Threads and
// determinism").
#pragma once

#include "host/core/step/fp_env.h"
#include "manyrods/array.h"
#include "manyrods/step.h"  // Exec

namespace manyrods {

// Kernel lambdas passed to launch must be inlined into its `omp simd` loop,
// or the loop calls them once per index and does not vectorize:
//   launch(n, ex, [&](int k) MANYRODS_KERNEL_LAMBDA { ... });
#if defined(__GNUC__)
#define MANYRODS_KERNEL_LAMBDA __attribute__((always_inline))
#else
#define MANYRODS_KERNEL_LAMBDA
#endif

namespace detail {
template <class F>
__attribute__((always_inline)) inline void launch_block(int k0, F kernel) {
#pragma omp simd
  for (int i = 0; i < kGuard; ++i) kernel(k0 + i);
}

// Runs block(k0) for the blocks of [begin, end) (multiples of kGuard): in
// order on one thread, or shared out statically over ex.threads.
template <class F>
inline void for_each_block(int begin, int end, const Exec& ex, F&& block) {
  const int b0 = begin / kGuard, b1 = end / kGuard;
  if (ex.threads <= 1 || b1 - b0 < 2) {
    for (int b = b0; b < b1; ++b) block(b * kGuard);
    return;
  }
  const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/core/step/fp_env.h)
#pragma omp parallel num_threads(ex.threads)
  {
    const RegionFpScope fp(mode);
#pragma omp for schedule(static)
    for (int b = b0; b < b1; ++b) block(b * kGuard);
  }
}
}  // namespace detail

// Runs kernel(k) for k in [begin, end) (multiples of kGuard).
template <class F>
inline void launch(int begin, int end, const Exec& ex, F&& kernel) {
  detail::for_each_block(begin, end, ex, [&](int k0) MANYRODS_KERNEL_LAMBDA { detail::launch_block(k0, kernel); });
}

template <class F>
inline void launch(int slots, const Exec& ex, F&& kernel) {
  launch(0, slots, ex, kernel);
}

// Runs `fast` (branch-free, returns true where its result is not valid) in
// the SIMD loops, records those indices in `flags`, and reruns them with
// `exact` — in the same block, right after, so the order of work per index
// is the same whatever the thread count.
namespace detail {

// flags[k0 + i] ← pred(k0 + i) over the block, in one SIMD loop; whether
// any is set. The kernels here are taken by value: copies that live in
// registers, which no store in the loop can alias (through a captured
// reference the compiler must reload them, and the loop stays scalar).
template <class Pred>
__attribute__((always_inline)) inline bool flag_block(int k0, int* flags, Pred pred) {
#pragma omp simd
  for (int i = 0; i < kGuard; ++i) flags[k0 + i] = pred(k0 + i) ? 1 : 0;
  int any = 0;
  for (int i = 0; i < kGuard; ++i) any |= flags[k0 + i];
  return any != 0;
}

// One block of launch_with_fallback.
template <class Fast, class Exact>
__attribute__((always_inline)) inline void fallback_block(int k0, int* flags, Fast fast, Exact exact) {
  if (flag_block(k0, flags, fast))
    for (int i = 0; i < kGuard; ++i)
      if (flags[k0 + i]) exact(k0 + i);
}

}  // namespace detail

template <class Fast, class Exact>
inline void launch_with_fallback(int begin, int end, const Exec& ex, int* flags, Fast&& fast,
                                 Exact&& exact) {
  detail::for_each_block(begin, end, ex, [&](int k0) MANYRODS_KERNEL_LAMBDA { detail::fallback_block(k0, flags, fast, exact); });
}

// launch_with_fallback for a fast kernel whose results are selects
// (`invalid ? old : new`): GCC turns such a select into a masked store, and
// masked stores are slow on some CPUs (AMD Zen 3: the drift ran 1.7× slower
// in double and 2.9× in float, bench/RESULTS.md). Each block first asks
// `screen(k)` (true exactly where fast(k) would return true) for all its
// indices; a block where none is true runs `plain` (the fast kernel with
// plain stores, the same values), any other block runs as
// launch_with_fallback's. Same results bit for bit.
namespace detail {
// One block of launch_screened.
template <class Screen, class Plain, class Fast, class Exact>
__attribute__((always_inline)) inline void screened_block(int k0, int* flags, Screen screen, Plain plain, Fast fast,
                                                          Exact exact) {
  if (flag_block(k0, flags, screen))
    fallback_block(k0, flags, fast, exact);
  else
    launch_block(k0, plain);
}
}  // namespace detail

template <class Screen, class Plain, class Fast, class Exact>
inline void launch_screened(int begin, int end, const Exec& ex, int* flags, Screen&& screen, Plain&& plain,
                            Fast&& fast, Exact&& exact) {
  detail::for_each_block(begin, end, ex, [&](int k0) MANYRODS_KERNEL_LAMBDA {
    detail::screened_block(k0, flags, screen, plain, fast, exact);
  });
}

}  // namespace manyrods
