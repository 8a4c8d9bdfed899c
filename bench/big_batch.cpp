// bench/big_batch.cpp — does a batch of 1,000,000 hair strands × 32 elements
// fit and step on this machine? Builds it in float (hair of CASES 5b, no
// Kelvin–Voigt, gravity), reports bytes per element (batch arrays) and the
// process's peak resident memory, and times a few steps.
//
// usage: manyrods-bigbatch [rods] [steps]   (defaults 1000000, 8)
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "scenes.h"

using namespace manyrods;

int main(int argc, char** argv) {
  const int rods = argc > 1 ? std::atoi(argv[1]) : 1000000;
  const int steps = argc > 2 ? std::atoi(argv[2]) : 8;
  constexpr Terms kNoKV{true, true, true, true, false, true, true};
  auto t0 = std::chrono::steady_clock::now();
  RodBatch<float> b;
  {
    bench::Scene sc = bench::make_scene("hair", false, rods);
    b = build_batch<float>(sc.rods, sc.gravity);
  }  // the specs are freed here
  const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const float dt = float(0.5 * stable_dt<kNoKV>(b).elastic);
  t0 = std::chrono::steady_clock::now();
  step_n<kNoKV>(b, dt, steps, Exec{2});
  const double step_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  std::printf("rods = %d\nelements = %lld\nbytes_per_element = %.1f\nbatch_bytes = %.3g\n", rods,
              static_cast<long long>(b.element_count()), double(b.bytes()) / double(b.element_count()),
              double(b.bytes()));
  std::printf("peak_resident_bytes = %.3g\nbuild_s = %.1f\nsteps = %d\nelement_steps_per_s = %.3g\nfinite = %d\n",
              double(ru.ru_maxrss) * 1024.0, build_s, steps, double(steps) * double(b.element_count()) / step_s,
              int(!find_non_finite(b).found));
  return find_non_finite(b).found ? 1 : 0;
}
