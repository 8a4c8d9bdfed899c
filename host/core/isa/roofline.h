// host/core/isa/roofline.h — this machine's ceilings: register-resident fused
// multiply-adds (the FMA peak) and the STREAM triad (memory bandwidth).
// Used by `manyrods bench` (host/scene/run/bench.cpp; the FMA loop through the step
// path's table, host/core/isa/isa_table.h, so that it runs the same instruction set
// as the step) and by the Google Benchmark ceilings (bench/roofline.cpp).
#pragma once

#include <omp.h>

#include <cstddef>

namespace manyrods::roofline {

// The widest vector the instruction set compiled for has, in bytes.
#if defined(__AVX512F__)
inline constexpr int kVectorBytes = 64;
#elif defined(__AVX__)
inline constexpr int kVectorBytes = 32;
#else
inline constexpr int kVectorBytes = 16;
#endif

// `inner` rounds of 12 independent accumulators of the widest vector
// (enough to cover FMA latency × throughput, and in registers: 12 of the
// 16 AVX2 or 32 AVX-512 ones; wider vectors than the hardware's would be
// split, 24 halves spilled to memory, and the "peak" a third of the real
// one) on each of `threads` threads. Returns the FLOPs done (an FMA counts
// 2); `sink` keeps the result alive.
template <class T>
double fma_burst(int threads, int inner, volatile T* sink) {
  constexpr int kLanes = kVectorBytes / sizeof(T), kAcc = 12;
  typedef T vec __attribute__((vector_size(kVectorBytes)));
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
