// bench/big_batch.cpp — does a batch of 1,000,000 hair strands × 32 elements
// fit and step on this machine? Builds it in float (the human hair of
// docs/validation.md "0a Test rods: the seed cantilever and human hair",
// gravity), reports bytes per element (batch arrays, the implicit solve's
// per-thread buffers included) and the process's peak resident memory, and
// times a few steps at half of stable_dt. Modes:
//   nokv   Kelvin–Voigt off (the plain explicit step);
//   kv     Kelvin–Voigt on, implicit (τS = τE = 1 ms);
//   stiff  stiff rods (RodSpec::stiff_implicit) with Kelvin–Voigt on: the
//          frame-rate configuration (dt ≈ 2.8e-4 s instead of 2e-8 s).
//
// usage: manyrods-bigbatch [rods] [steps] [nokv|kv|stiff]   (defaults 1000000, 8, nokv)
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "scenes.h"

using namespace manyrods;

int main(int argc, char** argv) {
  const int rods = argc > 1 ? std::atoi(argv[1]) : 1000000;
  const int steps = argc > 2 ? std::atoi(argv[2]) : 8;
  const char* mode = argc > 3 ? argv[3] : "nokv";
  const bool kv = !std::strcmp(mode, "kv") || !std::strcmp(mode, "stiff"), stiff = !std::strcmp(mode, "stiff");
  if (!kv && std::strcmp(mode, "nokv")) {
    std::fprintf(stderr, "usage: manyrods-bigbatch [rods] [steps] [nokv|kv|stiff]\n");
    return 2;
  }
  constexpr Terms kNoKV{true, true, true, true, false, true, true};
  auto t0 = std::chrono::steady_clock::now();
  RodBatch<float> b;
  {
    bench::Scene sc = bench::make_scene("hair", kv, rods);
    for (RodSpec& r : sc.rods) r.stiff_implicit = stiff;
    b = build_batch<float>(sc.rods, sc.gravity);
  }  // the specs are freed here
  const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const float dt = float(0.5 * (kv ? stable_dt(b).elastic : stable_dt<kNoKV>(b).elastic));
  b.reserve_implicit_scratch(2);  // what the step allocates, counted in bytes()
  t0 = std::chrono::steady_clock::now();
  if (kv)
    step_n(b, dt, steps, Exec{2});
  else
    step_n<kNoKV>(b, dt, steps, Exec{2});
  const double step_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("mode = %s\ndt = %.3g\n", mode, double(dt));
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
