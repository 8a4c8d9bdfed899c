// bench/roofline.cpp — this machine's ceilings, measured in the same run as
// the step: FMA peak (GFLOP/s) and stream bandwidth (bytes/s), 1 and 2
// threads. bench/RESULTS.md divides the step's FLOP and byte rates by these.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <cstddef>
#include <vector>

namespace {

// Register-resident fused multiply-adds: 12 independent vector accumulators
// (enough to cover FMA latency × throughput), 64-byte vectors.
template <class T>
void BM_peak_fma(benchmark::State& state) {
  constexpr int kLanes = 64 / sizeof(T), kAcc = 12, kInner = 1000;
  typedef T vec __attribute__((vector_size(64)));
  const int threads = int(state.range(0));
  double flops = 0;
  for (auto _ : state) {
#pragma omp parallel num_threads(threads) reduction(+ : flops)
    {
      vec acc[kAcc], m, a;
      for (int l = 0; l < kLanes; ++l) {
        m[l] = T(0.999999);
        a[l] = T(1e-7);
      }
      for (int i = 0; i < kAcc; ++i) acc[i] = m * T(i);
      for (int it = 0; it < kInner; ++it)
        for (int i = 0; i < kAcc; ++i) acc[i] = acc[i] * m + a;
      T sink = 0;
      for (int i = 0; i < kAcc; ++i)
        for (int l = 0; l < kLanes; ++l) sink += acc[i][l];
      benchmark::DoNotOptimize(sink);
      flops += 2.0 * kLanes * kAcc * kInner;
    }
  }
  state.SetItemsProcessed(int64_t(flops));  // items_per_second = FLOP/s
  state.SetLabel("items are FLOPs");
}

// STREAM triad a = b + s·c over arrays far larger than the caches;
// bytes counted as 3 arrays (STREAM's convention, no write-allocate).
template <class T>
void BM_stream_triad(benchmark::State& state) {
  const int threads = int(state.range(0));
  const std::size_t n = std::size_t(1) << 25;  // 32 Mi entries per array
  std::vector<T> a(n, T(0)), b(n, T(1)), c(n, T(2));
  const T s = T(0.5);
  for (auto _ : state) {
#pragma omp parallel for simd num_threads(threads) schedule(static)
    for (std::size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(3 * n * sizeof(T)));
}

BENCHMARK_TEMPLATE(BM_peak_fma, float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime();
BENCHMARK_TEMPLATE(BM_peak_fma, double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime();
BENCHMARK_TEMPLATE(BM_stream_triad, float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime();
BENCHMARK_TEMPLATE(BM_stream_triad, double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime();

}  // namespace
