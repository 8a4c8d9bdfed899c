// include/manyrods/sweep.h — parameter sweeps: every variation of a scene becomes rods
// of ONE batch (a sweep is a throughput workload), and each variation is
// summarised from its rods (`manyrods sweep`, docs/scenes.md "Sweeps").
//
// --vary KEY=SPEC, KEY a numeric key path of a [[rods]] group
// ("rods.0.damping.tau_extension", "rods.0.initial_tip_force.0"), SPEC one of
//   lo:hi:n                  n values from lo to hi, evenly spaced, ends included
//   lo:hi, uniform:lo:hi     uniform on [lo, hi]
//   normal:mean:std          normal
//   normal:mean:std:lo:hi    normal truncated to [lo, hi]
//   lognormal:median:sigma   log-normal, sigma the standard deviation of the log
//   v1,v2,...                the listed values, equally likely
//   v1@w1,v2@w2,...          the listed values with weights w (any positive scale)
//   v                        one value
// The grid design (the default without --samples) runs the Cartesian
// product of all lists (lo:hi:n, lists, single values; a distribution there
// is an error). A sampled design (--design mc|lhs|sobol --samples N --seed S,
// include/manyrods/sampling.h) maps each point's coordinate u of a
// parameter through that parameter's inverse CDF: a lo:hi:n range is then
// sampled as uniform on [lo, hi], a list by its weights.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "manyrods/h5io.h"
#include "manyrods/runner.h"
#include "manyrods/sampling.h"
#include "manyrods/scene.h"

namespace manyrods::scene {

struct Vary {
  enum class Kind { uniform, normal, lognormal, list };
  std::string key;
  Kind kind = Kind::uniform;
  double lo = 0, hi = 0;       // uniform: the range; normal: the truncation (±inf: none)
  int count = 0;               // uniform lo:hi:n: the grid's n (0 for a bare range)
  double mean = 0, std = 0;    // normal: mean, standard deviation; lognormal: median, sigma of the log
  std::vector<double> values;  // list (a single value is a list of one)
  std::vector<double> weights; // list: empty (equal) or one per value
  // The value at u ∈ (0, 1) (the inverse CDF).
  double at(double u) const;
};

Vary parse_vary(const std::string& arg);  // SceneError on bad syntax

// Rows of parameter values, one per variation, in the order of `vary`.
std::vector<std::vector<double>> sweep_points(const std::vector<Vary>& vary, const Design& design);
// (samples > 0: the mc design with that seed; else the grid)
std::vector<std::vector<double>> sweep_points(const std::vector<Vary>& vary, int samples, std::uint64_t seed);

struct Sweep {
  Scene scene;                              // all variations' rods in one batch
  std::vector<std::string> names;           // parameter keys
  std::vector<std::vector<double>> points;  // [variations][parameters]
  std::vector<int> first_rod;               // [variations + 1] rod ranges
  std::vector<Probe> probes;                // one per variation: its first rod's tip, all its rods
  int sensitivity_base = 0;                 // a saltelli design's N (its variations: A, B, A_B^(i)); 0: none
};

// Parses the scene once per variation with the overrides applied (each is
// validated like a scene file) and concatenates the rods.
Sweep make_sweep(const std::string& text, const std::string& source, const std::vector<Vary>& vary,
                 const Design& design);
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
// order), from its small-amplitude part, as a free-vibration test reads
// them: maxima and minima refined by a parabola through three samples; the
// peak-to-peak amplitudes P_k = u(max_k) − u(following min) (independent of
// the equilibrium offset); the cycles from the first with P_k ≤ max(¼ P_0,
// small) down to 1 % of P_0 (large first swings of a cantilever are
// geometrically nonlinear: they lengthen the period and change the decay);
// least-squares lines through t_k and ln P_k against k give the period and
// the logarithmic decrement δ, ζ = δ/√(4π² + δ²), each with its standard
// error from the fit's residuals. NaN (all four) with fewer than three peaks
// in the window: a run too short to reach it. `small`: an amplitude that is
// small in any case (the sweep summary passes 10 % of the rod's length).
struct Oscillation {
  double period = 0, damping_ratio = 0;
  int cycles = 0;  // in the window
  double period_err = 0, damping_ratio_err = 0;
};
Oscillation analyse_oscillation(const std::vector<double>& t, const std::vector<double>& u, double small = 0);

// The built-in summary columns of a sweep, in order, one entry each:
// X(name, its standard-error column ("" for none), what it holds). The
// names, the columns' filling (by name), their HDF5 datasets and the error
// bars of `manyrods plot` all come from this list.
#define MANYRODS_SWEEP_SUMMARY(X)                                                                          \
  X(tip_deflection_initial_m, "", "m: the probe tip's distance from its rest position at the start")      \
  X(tip_deflection_max_m, "", "m: the largest such distance over the run")                               \
  X(tip_deflection_final_m, "", "m: the distance at the end")                                            \
  X(period_s, "period_err_s", "s: the period of the tip's oscillation about its end (analyse_oscillation)") \
  X(period_err_s, "", "s: the period's standard error")                                                  \
  X(damping_ratio, "damping_ratio_err", "1: the damping ratio of that oscillation")                      \
  X(damping_ratio_err, "", "1: its standard error")                                                      \
  X(cycles, "", "1: the cycles in the fitted window")                                                    \
  X(energy_final_J, "", "J: the mechanical energy at the end")                                           \
  X(dissipated_J, "", "J: the energy dissipated, ∫ 2·D_v dt")                                             \
  X(max_strain, "", "1: the largest strain over the sample points (manyrods/strain.h)")                  \
  X(failed_at_s, "", "s: when the state stopped being finite (the variation frozen since); NaN: never")

// Per-variation summary columns from the probe records of a run of the
// sweep: the built-in ones (MANYRODS_SWEEP_SUMMARY, sweep_summary_names),
// then the scene's [[observables]] (include/manyrods/observables.h
// observable_columns).
const std::vector<std::string>& sweep_summary_names();
// The standard-error column of built-in column `name` ("" for none), and
// whether `name` is such a column (MANYRODS_SWEEP_SUMMARY).
const std::string& sweep_error_column(const std::string& name);
bool is_sweep_error_column(const std::string& name);
std::vector<h5::Column> sweep_summary(const Sweep& sw, const std::vector<ProbeRecord>& rec);
std::vector<h5::Column> sweep_parameters(const Sweep& sw);

// Statistics of every summary column over the variations, from its finite
// values (NaN marks a variation without that observable, or a failed one):
//   n, nan               finite values, NaN values
//   mean, std            sample mean, standard deviation (n − 1)
//   mean_se              standard error of the mean, std/√n
//   mean_ci95_lo, _hi    95 % confidence interval of the mean by the central
//                        limit theorem, mean ∓ 1.959964 std/√n (Monte Carlo
//                        samples; conservative for lhs and sobol designs)
//   min, q05, q25, median, q75, q95, max
//                        quantiles, linear between order statistics
//                        (Hyndman & Fan's type 7, numpy's default)
// One column per summary column (its name), its values in the order of
// sweep_statistic_names(); NaN where n is too small for a statistic.
const std::vector<std::string>& sweep_statistic_names();
std::vector<h5::Column> sweep_statistics(const std::vector<h5::Column>& summary);

// Sobol' sensitivity indices of every summary column from a saltelli design
// (include/manyrods/sampling.h) of N base points over d parameters, with
// f_A, f_B, f_ABi the column's values on A, B and A_B^(i):
//   first order  S_i  = mean((f_B − f̄)(f_ABi − f_A)) / V (Saltelli et al. 2010;
//                       f centred by its mean f̄ over A and B, which leaves
//                       the estimate unbiased and removes the f̄² from its
//                       variance)
//   total        ST_i = mean((f_A − f_ABi)²) / (2 V)     (Jansen 1999)
// V the variance of f over A and B together; rows where any of the three is
// NaN are left out. One column per summary column, its values
// [S_1 … S_d, ST_1 … ST_d] (sensitivity_names); NaN where V = 0.
std::vector<std::string> sensitivity_names(const std::vector<std::string>& parameters);
std::vector<h5::Column> sweep_sensitivity(const std::vector<h5::Column>& summary, int base, int dims);

// Runs the sweep (new, or continued from its file's checkpoint `restart`)
// into opt.output with /sweep (parameters, summary, each variation's first
// rod); opt.probes and opt.before_finish are set here.
struct SweepRun {
  RunResult run;
  std::vector<h5::Column> parameters, summary, statistics;
  std::vector<h5::Column> sensitivity;  // saltelli designs
};
SweepRun run_sweep(const Sweep& sw, RunOptions opt, const h5::Checkpoint* restart = nullptr);

// A sweep too large for one batch, `chunk` variations at a time: chunk k
// (variations [k·chunk, (k+1)·chunk)) runs as a sweep of its own into
// <output>.chunks/chunk-<k>.h5 (written as chunk-<k>.h5.part, renamed when
// it has reached its end), one after the other; a chunk file that exists is
// not run again (it is read back: the same command continues an
// interrupted sweep, chunk by chunk). dt = "auto" is resolved over all
// variations first (the smallest chunk's stable step), so that every chunk
// steps with the same dt as the sweep in one batch would, and each
// variation's summary is the same, bit for bit. When all chunks are done,
// opt.output becomes the sweep's index (h5::write_sweep_index): every
// variation's parameters and summary, the statistics, the chunk files.
// on_chunk(k, chunks, run): after each chunk (run: null for one read back).
// Without `until`, a Ctrl-C (opt.interrupt) stops after the running chunk's
// interrupted run, leaving the finished chunks. SceneError for a chunk
// file that holds other variations.
// How the chunks of a chunked sweep are shared among processes (MPI ranks,
// on one folder that all of them see): process `rank` of `ranks` runs the
// chunks k with k mod ranks = rank; min_all(x) returns the minimum of x
// over all processes and all_ok(b) the AND of b over all (collectives that
// every process calls at the same point; tools/manyrods.cpp gives them to
// MPI); sum_all(x) the sum (for the count of chunks read back); all_gather
// below. Process 0 then reads the other processes' chunk files back and
// writes the index. The default: one process.
struct Shards {
  int rank = 0, ranks = 1;
  std::function<double(double)> min_all = [](double x) { return x; };
  std::function<bool(bool)> all_ok = [](bool b) { return b; };
  std::function<double(double)> sum_all = [](double x) { return x; };
  // every process's `mine` joined in rank order (counts[r]: process r's
  // length), on every process (`manyrods calibrate`: a generation's tracks)
  std::function<std::vector<double>(const std::vector<double>& mine, const std::vector<int>& counts)> all_gather =
      [](const std::vector<double>& mine, const std::vector<int>&) { return mine; };
};

struct ChunkedSweep {
  SweepRun result;       // parameters, summary, statistics of all variations (complete, process 0)
  int chunks = 0, reused = 0;
  bool complete = false;
  std::vector<std::string> chunk_files;
};
ChunkedSweep run_sweep_chunked(const std::string& text, const std::string& source, std::vector<std::string> names,
                               std::vector<std::vector<double>> points, int chunk, RunOptions opt,
                               const std::function<void(int, int, const RunResult*)>& on_chunk = {},
                               const Shards& shards = {}, int sensitivity_base = 0);

// variation, parameters..., summary... (written to path.tmp, then renamed).
void write_csv(const std::string& path, const std::vector<h5::Column>& parameters,
               const std::vector<h5::Column>& summary);
// observable, then one column per statistic (sweep_statistics), likewise.
void write_statistics_csv(const std::string& path, const std::vector<h5::Column>& statistics);
// observable, parameter, S1, ST (sweep_sensitivity), likewise.
void write_sensitivity_csv(const std::string& path, const std::vector<h5::Column>& sensitivity,
                           const std::vector<std::string>& parameters);

}  // namespace manyrods::scene
