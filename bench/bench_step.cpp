// bench/bench_step.cpp — throughput of the time step (Google Benchmark).
//
// BM_step_<scene>_<precision>[/threads]: one Position Verlet step per
// iteration (BM_step64_…: 64 steps per call of step_n, temporally blocked); items_per_second = element-steps per second; bytes_per_second
// from the arrays the step streams (kBytesPerSlot below, per slot and step).
// Each benchmark's label carries the state hash after a fixed number of
// steps from the initial state, so a faster variant that changes the answer
// shows (and the hash must not depend on the thread count), and the memory
// held per element (model + state + scratch + loads). Counters stage_* give
// each stage's share of the step's time.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <string>

#include "scenes.h"
#include "stage_counters.h"

using namespace manyrods;
using namespace manyrods::bench;

namespace {

// Arrays (each one value per slot) read or written by one step, counted from
// host/core/step/integrators.h: 2 drifts (read x, v, Q, ω; write x, Q: 18 reads + 12 writes
// each), resultants (read x (6: k and k+1), v (6), Q (18: k and k−1),
// ω (6), 28 model arrays; write 12 scratch), kick (read 12 scratch (+6
// neighbours), 7 model arrays, 6 loads; read/write v, ω (12)). Neighbour
// reads hit cache, so they are counted once: ≈ 2·30 + 58 + 12 + 37 + 12 ≈
// 180 values per slot and step without the implicit viscous solve, whose
// block elimination adds ≈ 42 writes + 42 reads + 28 model + 18 state ≈ 130.
constexpr double kValuesPerSlot = 180, kValuesImplicit = 130;

constexpr Terms kNoKV{true, true, true, true, false, true, true};

// kBlock > 1: step_n with kBlock steps per call (temporal blocking), the way
// advance() steps; items still count element-steps. flush: Exec::flush_subnormals.
template <class T, Terms kT, Viscous kV, int kBlock = 1>
void run_step(benchmark::State& state, const std::string& scene, bool kv, bool flush = true) {
  const int threads = int(state.range(0));
  const Exec ex{threads, nullptr, flush};
  Scene sc = make_scene(scene, kv);
  RodBatch<T> b = build_batch<T>(sc.rods, sc.gravity);
  if (sc.has_fluid) set_fluid(b, sc.fluid);
  // Half the stable step of the chosen scheme (explicit KV: its viscous
  // limit); stiff rods, which have none: the frame-rate step 1/240 s.
  const StableDt lim = stable_dt<kT>(b);
  const bool stiff = b.any_stiff();
  const T dt = stiff ? T(1.0 / 240)
                     : T(0.5 * (kT.kelvin_voigt && kV == Viscous::explicit_rate
                                    ? std::min(lim.elastic, lim.explicit_viscous)
                                    : lim.elastic));
  // hash after 20 steps from the initial state
  RodBatch<T> probe = b;
  for (int i = 0; i < 20; ++i) step<kT, kV>(probe, dt, ex);
  const std::uint64_t h = state_hash(probe);
  char label[128];
  std::snprintf(label, sizeof label, "hash=%016llx bytes_per_element=%.1f", static_cast<unsigned long long>(h),
                double(b.bytes()) / double(b.element_count()));
  for (auto _ : state) step_n<kT, kV>(b, dt, kBlock, ex);
  const double per_slot = kValuesPerSlot + (kT.kelvin_voigt && kV == Viscous::implicit ? kValuesImplicit : 0);
  state.SetItemsProcessed(state.iterations() * kBlock * b.element_count());
  state.SetBytesProcessed(int64_t(double(state.iterations()) * kBlock * b.slots() * per_slot * sizeof(T)));
  state.SetLabel(label);
  // simulated seconds per wall-clock second: what a stiff scene gains
  state.counters["sim_s_per_s"] =
      benchmark::Counter(double(state.iterations()) * kBlock * double(dt), benchmark::Counter::kIsRate);
  stage_counters<kT, kV>(state, b, dt, ex);
}

#define MANYRODS_SCENE(scene)                                                                          \
  void BM_step_##scene##_float(benchmark::State& s) {                                                  \
    run_step<float, kAllTerms, Viscous::implicit>(s, #scene, true);                                    \
  }                                                                                                    \
  void BM_step_##scene##_double(benchmark::State& s) {                                                 \
    run_step<double, kAllTerms, Viscous::implicit>(s, #scene, true);                                   \
  }                                                                                                    \
  void BM_step_##scene##_nokv_float(benchmark::State& s) { run_step<float, kNoKV, Viscous::implicit>(s, #scene, false); } \
  void BM_step_##scene##_nokv_double(benchmark::State& s) { run_step<double, kNoKV, Viscous::implicit>(s, #scene, false); } \
  void BM_step_##scene##_kvexplicit_float(benchmark::State& s) {                                       \
    run_step<float, kAllTerms, Viscous::explicit_rate>(s, #scene, true);                               \
  }                                                                                                    \
  BENCHMARK(BM_step_##scene##_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5); \
  BENCHMARK(BM_step_##scene##_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5); \
  BENCHMARK(BM_step_##scene##_nokv_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5); \
  BENCHMARK(BM_step_##scene##_nokv_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5); \
  void BM_step64_##scene##_nokv_float(benchmark::State& s) {                                           \
    run_step<float, kNoKV, Viscous::implicit, 64>(s, #scene, false);                                   \
  }                                                                                                    \
  void BM_step64_##scene##_nokv_double(benchmark::State& s) {                                          \
    run_step<double, kNoKV, Viscous::implicit, 64>(s, #scene, false);                                  \
  }                                                                                                    \
  void BM_step64_##scene##_float(benchmark::State& s) {                                                \
    run_step<float, kAllTerms, Viscous::implicit, 64>(s, #scene, true);                                \
  }                                                                                                    \
  void BM_step64_##scene##_double(benchmark::State& s) {                                               \
    run_step<double, kAllTerms, Viscous::implicit, 64>(s, #scene, true);                               \
  }                                                                                                    \
  BENCHMARK(BM_step_##scene##_kvexplicit_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5); \
  BENCHMARK(BM_step64_##scene##_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5); \
  BENCHMARK(BM_step64_##scene##_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5); \
  BENCHMARK(BM_step64_##scene##_nokv_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5); \
  BENCHMARK(BM_step64_##scene##_nokv_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);

MANYRODS_SCENE(hair)
MANYRODS_SCENE(cable)
MANYRODS_SCENE(long)
MANYRODS_SCENE(mixed)
MANYRODS_SCENE(fibers)

// One rod of 100,000 elements: the long rod's partitioned solve at 10× the
// length (step64 only).
void BM_step64_longer_float(benchmark::State& s) { run_step<float, kAllTerms, Viscous::implicit, 64>(s, "longer", true); }
void BM_step64_longer_double(benchmark::State& s) { run_step<double, kAllTerms, Viscous::implicit, 64>(s, "longer", true); }
void BM_step64_longer_nokv_float(benchmark::State& s) { run_step<float, kNoKV, Viscous::implicit, 64>(s, "longer", false); }
void BM_step64_longer_nokv_double(benchmark::State& s) { run_step<double, kNoKV, Viscous::implicit, 64>(s, "longer", false); }
BENCHMARK(BM_step64_longer_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_step64_longer_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_step64_longer_nokv_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_step64_longer_nokv_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);

// Hair as stiff rods at frame-rate steps (Kelvin–Voigt on, solved with the
// stiff terms): compare sim_s_per_s with BM_step_hair_*.
void BM_step_hairstiff_float(benchmark::State& s) { run_step<float, kAllTerms, Viscous::implicit>(s, "hairstiff", true); }
void BM_step_hairstiff_double(benchmark::State& s) { run_step<double, kAllTerms, Viscous::implicit>(s, "hairstiff", true); }
void BM_step64_hairstiff_float(benchmark::State& s) {
  run_step<float, kAllTerms, Viscous::implicit, 64>(s, "hairstiff", true);
}
BENCHMARK(BM_step_hairstiff_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_step_hairstiff_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_step64_hairstiff_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
// The stiff hair with every root driven (a turning head): against hairstiff,
// the cost of driven roots.
void BM_step_hairturn_double(benchmark::State& s) { run_step<double, kAllTerms, Viscous::implicit>(s, "hairturn", true); }
void BM_step64_hairturn_float(benchmark::State& s) {
  run_step<float, kAllTerms, Viscous::implicit, 64>(s, "hairturn", true);
}
BENCHMARK(BM_step_hairturn_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_step64_hairturn_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);

// Float with IEEE subnormals (Exec::flush_subnormals = false): against the
// same benchmarks without _ieee, what the flush gains (host/core/step/fp_env.h).
void BM_ieee_step64_hair_nokv_float(benchmark::State& s) {
  run_step<float, kNoKV, Viscous::implicit, 64>(s, "hair", false, false);
}
void BM_ieee_step64_hair_float(benchmark::State& s) {
  run_step<float, kAllTerms, Viscous::implicit, 64>(s, "hair", true, false);
}
void BM_ieee_step64_hairstiff_float(benchmark::State& s) {
  run_step<float, kAllTerms, Viscous::implicit, 64>(s, "hairstiff", true, false);
}
BENCHMARK(BM_ieee_step64_hair_nokv_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_ieee_step64_hair_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_ieee_step64_hairstiff_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);

}  // namespace

// What holds and fluids cost (bench/RESULTS.md "Constraints and fluids"):
// the fibers with each, against the plain fibers, undamped and damped.
#define MANYRODS_COST(scene)                                                                                      \
  void BM_cost_##scene##_nokv_double(benchmark::State& s) { run_step<double, kNoKV, Viscous::implicit>(s, #scene, false); } \
  void BM_cost_##scene##_kv_double(benchmark::State& s) { run_step<double, kAllTerms, Viscous::implicit>(s, #scene, true); } \
  void BM_cost_##scene##_nokv_float(benchmark::State& s) { run_step<float, kNoKV, Viscous::implicit>(s, #scene, false); } \
  BENCHMARK(BM_cost_##scene##_nokv_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);       \
  BENCHMARK(BM_cost_##scene##_kv_double)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);         \
  BENCHMARK(BM_cost_##scene##_nokv_float)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
MANYRODS_COST(fibers)
MANYRODS_COST(fibers_pinned)
MANYRODS_COST(fibers_driven)
MANYRODS_COST(fibers_drag)
MANYRODS_COST(fibers_wind)

BENCHMARK_MAIN();
