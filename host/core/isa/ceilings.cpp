// host/core/isa/ceilings.cpp — this machine's ceilings, measured
// (include/manyrods/isa.h peak_flops, triad_bandwidth, and its memory,
// physical_memory): the FMA peak on the
// active step path's instruction set (its table's loop, isa_table.h) and
// the STREAM triad (roofline.h).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <memory>

#include "host/core/isa/isa_table.h"
#include "host/core/isa/roofline.h"
#include "manyrods/isa.h"

namespace manyrods {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace

// The FMA peak in T with `threads` threads, on the active step path's
// instruction set: the best of 5 bursts of about 0.05 s.
template <class T>
double peak_flops(int threads) {
  const isa::StepTable* t = isa::active_table();
  const auto burst = t ? isa::fns<T>(*t).fma_burst : &roofline::fma_burst<T>;
  volatile T sink = 0;
  int inner = 1000;
  double best = 0;
  for (int i = 0; i < 8; ++i) {
    const auto t0 = Clock::now();
    const double flops = burst(threads, inner, &sink);
    const double s = seconds_since(t0);
    if (s < 0.02) {  // too short to time: longer bursts first
      inner *= 4;
      --i;
      continue;
    }
    if (i >= 3) best = std::max(best, flops / s);
  }
  return best;
}

// The STREAM triad in T over 3 × 32 Mi entries (far beyond the caches): the
// best of 5.
template <class T>
double triad_bandwidth(int threads) {
  const std::size_t n = std::size_t(1) << 25;
  std::unique_ptr<T[]> a(new T[n]), b(new T[n]), c(new T[n]);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::size_t i = 0; i < n; ++i) a[i] = 0, b[i] = 1, c[i] = 2;  // first touch by the threads that use them
  double best = 0;
  for (int i = 0; i < 6; ++i) {
    const auto t0 = Clock::now();
    const double bytes = roofline::triad(threads, a.get(), b.get(), c.get(), n);
    if (i > 0) best = std::max(best, bytes / seconds_since(t0));
  }
  return best;
}

std::uint64_t physical_memory() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? std::uint64_t(pages) * std::uint64_t(page) : 0;
}

template double peak_flops<float>(int);
template double peak_flops<double>(int);
template double triad_bandwidth<float>(int);
template double triad_bandwidth<double>(int);

}  // namespace manyrods
