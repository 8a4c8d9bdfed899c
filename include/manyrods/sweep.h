// include/manyrods/sweep.h — parameter sweeps: every variation of a scene becomes rods
// of ONE batch (a sweep is a throughput workload), and each variation is
// summarised from its rods (`manyrods sweep`, docs/scenes.md "Sweeps").
//
// --vary KEY=SPEC, KEY a numeric key path of a [[rods]] group
// ("rods.0.damping.tau_extension", "rods.0.initial_tip_force.0"), SPEC one of
//   lo:hi:n   n values from lo to hi, evenly spaced, ends included
//   lo:hi     a range for random sampling (--samples N --seed S)
//   v1,v2,... the listed values
//   v         one value
// Without --samples the variations are the Cartesian product of all --vary
// lists; with --samples N they are N points drawn uniformly from the ranges
// (a lo:hi:n range is then sampled as lo:hi, a list by index).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "manyrods/h5io.h"
#include "manyrods/runner.h"
#include "manyrods/scene.h"

namespace manyrods::scene {

struct Vary {
  std::string key;
  double lo = 0, hi = 0;
  int count = 0;               // lo:hi:n (0 for a bare range)
  std::vector<double> values;  // a list or single value (empty for ranges)
};

Vary parse_vary(const std::string& arg);  // SceneError on bad syntax

// Rows of parameter values, one per variation, in the order of `vary`.
std::vector<std::vector<double>> sweep_points(const std::vector<Vary>& vary, int samples, std::uint64_t seed);

struct Sweep {
  Scene scene;                              // all variations' rods in one batch
  std::vector<std::string> names;           // parameter keys
  std::vector<std::vector<double>> points;  // [variations][parameters]
  std::vector<int> first_rod;               // [variations + 1] rod ranges
  std::vector<Probe> probes;                // one per variation: its first rod's tip, all its rods
};

// Parses the scene once per variation with the overrides applied (each is
// validated like a scene file) and concatenates the rods.
Sweep make_sweep(const std::string& text, const std::string& source, const std::vector<Vary>& vary,
                 int samples, std::uint64_t seed);
// The same for given variations: parameter keys and one row of values per
// variation (a sweep file's /sweep/parameters, to continue it).
Sweep make_sweep(const std::string& text, const std::string& source, std::vector<std::string> names,
                 std::vector<std::vector<double>> points);
// The sweep of a sweep file's checkpoint (h5::read_checkpoint), to continue
// it; SceneError when its rods do not match the file's.
Sweep sweep_of_checkpoint(const h5::Checkpoint& c, const std::string& path);

// Period and damping ratio of a decaying oscillation u(t) (samples in time
// order): maxima and minima refined by a parabola through three samples;
// period = mean spacing of the maxima; damping ratio from the decay of the
// peak-to-peak amplitude P_k = u(max_k) − u(following min) (independent of
// the equilibrium offset): δ = ln(P_first/P_last)/(cycles), ζ = δ/√(4π² + δ²).
// Cycles whose amplitude has fallen below 1 % of the first are not used.
// NaN when fewer than two maxima are found.
struct Oscillation {
  double period = 0, damping_ratio = 0;
  int cycles = 0;
};
Oscillation analyse_oscillation(const std::vector<double>& t, const std::vector<double>& u);

// Per-variation summary columns (tip deflections, period, damping ratio,
// energies, max strain) from the probe records of a run of the sweep.
std::vector<h5::Column> sweep_summary(const Sweep& sw, const std::vector<ProbeRecord>& rec);
std::vector<h5::Column> sweep_parameters(const Sweep& sw);

// Runs the sweep (new, or continued from its file's checkpoint `restart`)
// into opt.output with /sweep (parameters, summary, each variation's first
// rod); opt.probes and opt.before_finish are set here.
struct SweepRun {
  RunResult run;
  std::vector<h5::Column> parameters, summary;
};
SweepRun run_sweep(const Sweep& sw, RunOptions opt, const h5::Checkpoint* restart = nullptr);

// variation, parameters..., summary... (written to path.tmp, then renamed).
void write_csv(const std::string& path, const std::vector<h5::Column>& parameters,
               const std::vector<h5::Column>& summary);

}  // namespace manyrods::scene
