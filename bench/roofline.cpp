// bench/roofline.cpp — this machine's ceilings, measured in the same run as
// the step: FMA peak (GFLOP/s) and stream bandwidth (bytes/s), 1 and 2
// threads. bench/RESULTS.md divides the step's FLOP and byte rates by these.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <cstddef>
#include <vector>

#include "host/core/isa/roofline.h"

namespace {

using namespace manyrods;

// Register-resident fused multiply-adds (host/core/isa/roofline.h), compiled with
// the benchmark's flags.
template <class T>
void BM_peak_fma(benchmark::State& state) {
  const int threads = int(state.range(0));
  volatile T sink = 0;
  double flops = 0;
  for (auto _ : state) flops += roofline::fma_burst<T>(threads, 1000, &sink);
  state.SetItemsProcessed(int64_t(flops));  // items_per_second = FLOP/s
  state.SetLabel("items are FLOPs");
}

// STREAM triad a = b + s·c over arrays far larger than the caches
// (host/core/isa/roofline.h; 3 arrays counted, no write-allocate).
template <class T>
void BM_stream_triad(benchmark::State& state) {
  const int threads = int(state.range(0));
  const std::size_t n = std::size_t(1) << 25;  // 32 Mi entries per array
  std::vector<T> a(n, T(0)), b(n, T(1)), c(n, T(2));
  double bytes = 0;
  for (auto _ : state) {
    bytes += roofline::triad(threads, a.data(), b.data(), c.data(), n);
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(int64_t(bytes));
}

BENCHMARK_TEMPLATE(BM_peak_fma, float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime();
BENCHMARK_TEMPLATE(BM_peak_fma, double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime();
BENCHMARK_TEMPLATE(BM_stream_triad, float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime();
BENCHMARK_TEMPLATE(BM_stream_triad, double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime();

}  // namespace
