// host/launch.h — runs a per-index kernel over all slots of a batch.
//
// The slot range is cut into blocks of kGuard (64) indices; OpenMP threads take
// whole blocks and each block is one `omp simd` loop of fixed length. Every
// index is therefore computed by the same instruction sequence whatever the
// thread count, and nothing is reduced across threads: results are
// bit-identical for any number of threads (DESIGN.md §4).
#pragma once

#include "manyrods/array.h"

namespace manyrods {

// Execution settings come from the caller; no global state.
struct Exec {
  int threads = 1;  // OpenMP threads for this call
};

template <class F>
inline void launch(int slots, const Exec& ex, F&& kernel) {
  const int blocks = slots / kGuard;
  if (ex.threads <= 1 || blocks < 2) {
    for (int b = 0; b < blocks; ++b) {
#pragma omp simd
      for (int i = 0; i < kGuard; ++i) kernel(b * kGuard + i);
    }
    return;
  }
#pragma omp parallel for num_threads(ex.threads) schedule(static)
  for (int b = 0; b < blocks; ++b) {
#pragma omp simd
    for (int i = 0; i < kGuard; ++i) kernel(b * kGuard + i);
  }
}

}  // namespace manyrods
