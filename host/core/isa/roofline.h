// host/core/isa/roofline.h — this machine's ceilings: register-resident fused
// multiply-adds (the FMA peak) and the STREAM triad (memory bandwidth).
// Used by `manyrods bench` (host/scene/run/bench.cpp; the FMA loop through the step
// path's table, host/core/isa/isa_table.h, so that it runs the same instruction set
// as the step) and by the Google Benchmark ceilings (bench/roofline.cpp).
#pragma once

#include <omp.h>

#include <cstddef>

namespace manyrods::roofline {

// `inner` rounds of 12 independent 64-byte vector accumulators (enough to
// cover FMA latency × throughput) on each of `threads` threads. Returns
// the FLOPs done (an FMA counts 2); `sink` keeps the result alive.
template <class T>
double fma_burst(int threads, int inner, volatile T* sink) {
  constexpr int kLanes = 64 / sizeof(T), kAcc = 12;
  typedef T vec __attribute__((vector_size(64)));
  double flops = 0;
#pragma omp parallel num_threads(threads) reduction(+ : flops)
  {
    vec acc[kAcc], m, a;
    for (int l = 0; l < kLanes; ++l) {
      m[l] = T(0.999999);
      a[l] = T(1e-7);
    }
    for (int i = 0; i < kAcc; ++i) acc[i] = m * T(i);
    for (int it = 0; it < inner; ++it)
      for (int i = 0; i < kAcc; ++i) acc[i] = acc[i] * m + a;
    T s = 0;
    for (int i = 0; i < kAcc; ++i)
      for (int l = 0; l < kLanes; ++l) s += acc[i][l];
    if (omp_get_thread_num() == 0) *sink = s;
    flops += 2.0 * kLanes * kAcc * inner;
  }
  return flops;
}

// a = b + s·c over n entries; returns the bytes moved as STREAM counts them
// (3 arrays, no write-allocate).
template <class T>
double triad(int threads, T* a, const T* b, const T* c, std::size_t n) {
  const T s = T(0.5);
#pragma omp parallel for simd num_threads(threads) schedule(static)
  for (std::size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
  return 3.0 * double(n) * sizeof(T);
}

}  // namespace manyrods::roofline
