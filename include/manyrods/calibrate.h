// include/manyrods/calibrate.h — fitting a scene's parameters to measurements
// (`manyrods calibrate`, docs/scenes.md "Calibration").
//
// --fit KEY=SPEC, KEY a numeric key path of a [[rods]] group (as --vary's,
// include/manyrods/sweep.h), SPEC one of
//   lo:hi                   searched on [lo, hi], uniformly
//   log:lo:hi               searched on [lo, hi] in log (lo > 0)
//   normal:mean:std         a normal prior (searched within mean ± 4 std)
//   lognormal:median:sigma  a log-normal prior, sigma that of the log
//                           (searched within median·e^{±4 sigma})
// Each parameter is searched in its coordinate θ (the value, or its log) on
// the range mapped to [0, 1].
//
// The objective (docs/scenes.md "Calibration"): the weighted least-squares
// misfit of the measured node tracks,
//   χ²(p) = Σ over tracks, measured times and components of
//           ((x_sim(p) − x_meas) / σ)²        (NaN samples left out)
// plus, for a parameter with a prior, ((θ − θ_prior)/s_prior)² (the
// negative log-posterior, times 2, up to a constant). σ is the tracks' noise
// (a CSV column, or --sigma); where none is given, σ = 1 m and the
// uncertainty is scaled by the residuals' own variance, s² = χ²/(N − d).
//
// The optimizer is CMA-ES (Hansen 2016, "The CMA Evolution Strategy: A
// Tutorial"): each generation's λ candidates are the variations of ONE
// sweep batch (include/manyrods/sweep.h make_sweep), so a generation costs
// about one run of λ rods. Its random numbers come from the seed alone
// (manyrods/rng.h), and the steps are bit-identical for any thread count, so
// a calibration is reproducible for a seed.
//
// The uncertainty is the Laplace (Gauss–Newton) estimate at the optimum:
// the residuals' Jacobian J in θ by central differences (the 2d neighbours
// one more batch), covariance (JᵀJ + prior precision)⁻¹ (× s² without σ).
// A direction of θ (scaled to the search ranges) whose standard deviation
// exceeds half the range is a flat direction of the misfit: the parameters
// along it are reported as not determined by the data, not as numbers.
#pragma once

#include <array>
#include <csignal>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "manyrods/h5io.h"
#include "manyrods/runner.h"
#include "manyrods/sweep.h"

namespace manyrods::scene {

struct FitParameter {
  enum class Kind { range, log_range, normal, lognormal };
  std::string key;
  Kind kind = Kind::range;
  double lo = 0, hi = 0;      // range, log_range: the search range (values)
  double mean = 0, std = 0;   // normal: mean, std; lognormal: median, sigma of the log
  bool log() const { return kind == Kind::log_range || kind == Kind::lognormal; }
  bool prior() const { return kind == Kind::normal || kind == Kind::lognormal; }
  // the search range in θ (the value or its log)
  double theta_lo() const;
  double theta_hi() const;
  double value(double theta) const;  // θ → the parameter's value
  double theta(double value) const;
};

// "KEY=SPEC" (above); SceneError naming the argument on bad syntax, an
// empty range, a non-positive log bound, a prior of no width.
FitParameter parse_fit(const std::string& arg);

// Positions of nodes over time: tracks[k] is node `node` of rod `rod` (a
// rod of the scene, before the calibration's copies), x[t] its position
// at time[t] (NaN: not measured then), sigma its noise (m; NaN: not given).
struct Track {
  std::string name;  // "ROD:NODE" as given
  int rod = 0, node = 0;
  std::vector<std::array<double, 3>> x;
  double sigma = std::numeric_limits<double>::quiet_NaN();
};
// A scalar of the scene's [[observables]] (a column of observable_columns:
// "name", or "name@t"), measured as value ± sigma.
struct ScalarMeasurement {
  std::string name;
  int column = 0;  // its column among the scene's observables
  double value = 0, sigma = 0;
};
struct Measurements {
  std::string path;  // (the files, ", "-joined)
  std::vector<double> time;
  std::vector<Track> tracks;
  std::vector<ScalarMeasurement> scalars;
};

// Reads measurements: an HDF5 file written by `manyrods run` (every node of
// every rod a track, its frames the times) or a CSV file with the header
//   time,track,x,y,z[,sigma]
// one row per sample, track "ROD:NODE" (the scene's rod index, a node index,
// negative from the end), x y z in m (empty or nan: not measured), sigma
// in m; or a CSV file of scalars with the header
//   observable,value,sigma
// one row per column of the scene's [[observables]] (its name, "name@t"
// for one time of an `at` observable), in that observable's unit; sigma is
// required (it weighs the scalar against the other measurements). Several
// files: at most one of tracks and one of scalars. Checked against the
// scene: every track's rod and node exist, some sample is finite, the times
// lie within [0, duration], every scalar names an observable column. SceneError (or
// h5::H5Error) naming the file, line and column, or track.
Measurements read_measurements(const std::string& path, const Scene& scene);
Measurements read_measurements(const std::vector<std::string>& paths, const Scene& scene);

struct CalibrateOptions {
  int population = 0;          // λ; 0: 4 + ⌊3 ln d⌋, at least 8
  int max_generations = 200;   // the budget
  double tolerance = 1e-7;     // stop when every coordinate's step (in [0, 1] units) is below it
  std::uint64_t seed = 0;
  double sigma = std::numeric_limits<double>::quiet_NaN();  // the tracks' noise (m) where they give none
  int threads = 1;
  // after each generation: its number, the best χ² so far, the step size
  std::function<void(int, double, double)> on_generation;
  const volatile std::sig_atomic_t* interrupt = nullptr;
  // The search's state file (empty: none): written after every generation
  // (process 0), and where it exists at the start, read and continued —
  // bit for bit the calibration that was not stopped. A state from other
  // inputs (scene, measurements, --fit, seed, population, sigma) is refused
  // (SceneError). The caller removes it once the results are written.
  std::string state;
  // MPI ranks (include/manyrods/sweep.h Shards): each generation's
  // candidates split among them, each rank one batch of its share, their
  // tracks gathered (all_gather); every rank runs the same search. The
  // result is the same for any number of ranks.
  Shards shards;
};

struct Calibration {
  std::vector<FitParameter> fit;
  std::vector<double> best;       // values
  std::vector<double> sigma;      // their standard deviations (values; NaN: not determined)
  std::vector<double> theta_sigma;  // in θ (the log for log parameters)
  std::vector<bool> determined;   // false: along a flat direction of the misfit
  std::vector<std::vector<double>> covariance;  // in θ, [d][d]
  double misfit = 0;              // χ² at the best (priors included)
  double data_misfit = 0;         // χ² of the data alone
  std::int64_t samples = 0;       // N: finite measured coordinates and scalars, less those that carry nothing (s² below)
  bool sigma_given = false;       // false: the covariance is scaled by s² = χ²/(N − d)
  int generations = 0, evaluations = 0;
  bool converged = false;         // by the tolerance (else by the budget or an interrupt)
  bool interrupted = false;
  int resumed = 0;                // the generations read back from the state file
  double dt = 0;                  // the step every candidate ran with
  double duration = 0;            // and how far (the last measured time)
  std::vector<double> history_best;   // per generation: the best χ² so far
  std::vector<double> history_step;   // per generation: the step size σ (in [0, 1] units)
  // the fitted tracks: [track][time][3] at the best parameters, and the
  // fitted scalars (as Measurements::scalars)
  std::vector<std::vector<std::array<double, 3>>> fitted;
  std::vector<double> fitted_scalars;
  Measurements data;  // what was fitted
};

// Fits the parameters of the scene text (source: its path, for messages)
// to the measurements.
Calibration calibrate(const std::string& text, const std::string& source, const std::vector<FitParameter>& fit,
                      const Measurements& data, const CalibrateOptions& opt);

// The files a calibration writes, checked before any work (SceneError,
// nothing run): `output` (HDF5, the best fit's run), `csv` (empty: none) and
// the search's state (CalibrateOptions::state), returned: output +
// ".calibrate-state". None may be one of `inputs` (the scene's files, the
// measurements) or another of them, and their folders must exist;
// output_name and csv_name name them in the messages (`-o`, `--csv`).
std::string check_calibration_outputs(const std::string& output, const std::string& csv,
                                      std::vector<std::string> inputs, const std::string& output_name,
                                      const std::string& csv_name);

// Runs the scene at the best fit (its step and duration the calibration's) into
// `output` with /calibration (a dataset per key: value, sigma, sigma_theta,
// determined, lo, hi; the rows' names in its attribute "rows"),
// /calibration_history (generation, best_misfit, step), and what was
// measured beside what the fit gives: /calibration_tracks (time, then per
// track k and component c = x|y|z the columns measured_k_c and fitted_k_c;
// the tracks' names in its attribute "tracks") and /calibration_scalars
// (measured, sigma, fitted; the names in "rows"), as run_scene writes.
// (interrupt: as RunOptions::interrupt; the run then ends early, the tables
// written.)
RunResult run_best_fit(const std::string& text, const std::string& source, const Calibration& c,
                       const std::string& output, int threads,
                       const volatile std::sig_atomic_t* interrupt = nullptr);

// A line per parameter: "KEY = VALUE ± SIGMA" (or "KEY = VALUE (not
// determined by the data: ...)").
std::vector<std::string> calibration_lines(const Calibration& c);

// key, value, sigma, determined, lo, hi, misfit (written to path.tmp, renamed).
void write_calibration_csv(const std::string& path, const Calibration& c);

}  // namespace manyrods::scene
