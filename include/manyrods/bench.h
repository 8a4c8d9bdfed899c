// include/manyrods/bench.h — timing any scene file (`manyrods bench`;
// library manyrods::scene).
//
// The scene's batch is built as `manyrods run` builds it and stepped with
// its dt, Terms and integrator, without output: a warm-up, then `repeats`
// timed runs of `steps` steps each (the state goes on from one to the
// next, as in a run), then one more run with the per-stage profile on (so
// that the clock reads of the profile do not enter the timed runs). The
// median of the timed runs gives the rates. This machine's ceilings are
// measured in the same call with the same threads: the FMA peak (on the
// instruction set of the active step path, include/manyrods/isa.h) and the
// STREAM triad bandwidth.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "manyrods/profile.h"
#include "manyrods/scene.h"

namespace manyrods::scene {

struct BenchOptions {
  int threads = 1;
  std::int64_t steps = 0;  // per timed run; 0: a multiple of 64 that takes about `target_s`
  int repeats = 5;         // timed runs (≥ 1)
  std::int64_t warmup = 0;  // steps before the timed runs; 0: 64, or `steps` if that is fewer
  double target_s = 0.5;
  std::optional<Precision> precision;  // default: the scene's
  bool ceilings = true;                // measure the FMA peak and the triad bandwidth
  bool stiff_solve_in_double = true;   // Exec::stiff_solve_in_double (false: for comparison)
};

struct BenchResult {
  std::string scene;       // the scene's name (its file's stem when it has none)
  std::string precision;   // "float" or "double"
  std::string terms;       // e.g. "kelvin_voigt gravity colliders"
  std::string integrator;  // "position_verlet" or "pefrl"
  std::string step_path;   // include/manyrods/isa.h
  bool stiff_solve_float = false;  // a float batch's stiff rods were solved in float (BenchOptions)
  int threads = 1;
  std::int64_t rods = 0, elements = 0;
  double dt = 0;
  std::int64_t steps = 0, warmup = 0;
  std::vector<double> run_s;  // wall time of each timed run
  double median_s = 0;
  double element_steps_per_s = 0;
  double sim_s_per_wall_s = 0;
  double bytes_per_element = 0;      // the batch's arrays and the solve's buffers (RodBatch::bytes)
  StageTimes stages;                 // the profiled run (thread-seconds)
  double peak_flops = 0;             // measured FMA peak, FLOP/s (0 when not measured)
  double triad_bytes_per_s = 0;      // measured STREAM triad, bytes/s
  double flops_per_element_step = 0;  // counted estimate (bench/RESULTS.md "FLOPs per element-step")
  std::uint64_t state_hash = 0;      // after the warm-up, the timed and the profiled runs
};

// Throws SceneError / InputError for a bad scene or option,
// NonFiniteError when the state stops being finite.
BenchResult bench_scene(const Scene& s, const BenchOptions& opt);

// Google Benchmark's JSON output format (one entry per timed run, then the
// mean, median and stddev aggregates), so that its tools (compare.py)
// compare runs of scenes; the extra fields are per-entry counters.
std::string bench_json(const BenchResult& r, const std::string& date);

// The report `manyrods bench` prints.
std::string bench_report(const BenchResult& r);

}  // namespace manyrods::scene
