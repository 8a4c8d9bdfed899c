// tools/manyrods.cpp — the command-line tool (docs/scenes.md).
//
//   manyrods run scene.toml -o out.h5 [--threads N] [--until T] [--duration T]
//   manyrods run --restart checkpoint.h5 -o out.h5 [--duration T] [--csv F]   (a run or a sweep)
//   manyrods run scene.toml -o out.h5 --from-static        (start from the static equilibrium)
//   manyrods static scene.toml -o equilibrium.h5 [--at T]   (static equilibrium and the reactions at the holds)
//   manyrods sweep scene.toml --vary KEY=SPEC [--vary ...] [--design mc|lhs|sobol --samples N --seed S] [--until T] -o sweep.h5 [--csv F]
//   manyrods calibrate scene.toml --data MEAS [--data ...] --fit KEY=SPEC [--fit ...] -o fit.h5 [--csv F] [--seed S]
//                  [--population N] [--generations G] [--sigma S]   (fit parameters to measured node tracks)
//   manyrods export out.h5 --usd out.usda [--every K]
//   manyrods plot out.h5 [--out-dir DIR]
//   manyrods bench scene.toml [--threads N] [--steps K] [--repeats R] [--warmup W] [--precision P] [--json F]
//                  [--stiff-solve-float]
//   manyrods --version
//
// Exit status: 0 done, 3 done with validity warnings, 1 the simulation
// failed (non-finite state, a validity error, a static solve without
// equilibrium) or a tool failed, 2 bad input
// (scene, options, HDF5 file, a step above the stable limit, an unwritable
// output), 130 interrupted by Ctrl-C (the output is then a valid file with
// the frames so far and a checkpoint).
#include <omp.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <csignal>
#include <ctime>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "manyrods/any_batch.h"
#include "manyrods/bench.h"
#include "manyrods/calibrate.h"
#include "manyrods/h5io.h"
#include "manyrods/isa.h"
#include "manyrods/runner.h"
#include "manyrods/scene.h"
#include "manyrods/sweep.h"
#ifdef MANYRODS_MPI
#include <mpi.h>
#endif
#include "manyrods/usd.h"
#include "plot.h"

using namespace manyrods;
using manyrods::cli::plot;  // `manyrods plot` (tools/plot.cpp)
using namespace manyrods::scene;
namespace fs = std::filesystem;

namespace {

volatile std::sig_atomic_t g_interrupt = 0;

extern "C" void on_sigint(int) {
  g_interrupt = 1;
  std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C ends the program at once
}

int default_threads() { return std::max(1, omp_get_max_threads()); }

// With --profile: each stage's share of the step's thread-seconds.
void profile_lines(const StageTimes& st) {
  const std::string table = stage_report(st);
  if (!table.empty()) std::fprintf(stderr, "manyrods: profile (thread-seconds per stage, all steps):\n%s", table.c_str());
}

void summary_line(const RunResult& r, const std::string& out) {
  std::fprintf(stderr,
               "manyrods: %s: t = %.6g s after %lld steps (dt = %.4g s), %lld frames, %lld elements, "
               "%.3g element-steps/s, %.3g s wall, state hash %016llx, step path %s -> %s\n",
               r.interrupted ? "stopped" : "done", r.time, (long long)r.steps, r.dt, (long long)r.frames,
               (long long)r.elements, r.element_steps_per_s, r.wall_s, (unsigned long long)r.state_hash,
               active_step_path().c_str(), out.c_str());
  if (r.max_contacts > 0 || r.max_penetration > 0)
    std::fprintf(stderr, "manyrods: contact: up to %lld contacts in a frame, deepest overlap %.3g m\n",
                 (long long)r.max_contacts, r.max_penetration);
  if (r.solve_steps > 0)
    std::fprintf(stderr,
                 "manyrods: contact: rods met each other in their solve on %lld steps, %.3g sweeps a step, "
                 "%lld steps with sweeps that cycled (friction) and stopped\n",
                 (long long)r.solve_steps, double(r.solve_sweeps) / double(r.solve_steps), (long long)r.solve_stalled);
  if (r.list_growths > 0)
    std::fprintf(stderr, "manyrods: contact: the neighbour lists grew %lld times, to %d candidates per element\n",
                 (long long)r.list_growths, r.list_capacity);
  for (const h5::Column& c : r.observables)
    std::fprintf(stderr, "manyrods: observable %s = %.10g\n", c.name.c_str(), c.values[0]);
  for (const std::string& v : r.validity) std::fprintf(stderr, "manyrods: validity: %s\n", v.c_str());
  profile_lines(r.stages);
}

// The exit status of a finished run: 0, 3 with validity warnings, 130 interrupted.
int run_status(const RunResult& r) { return g_interrupt ? 130 : (r.validity.empty() ? 0 : 3); }

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot read the scene file");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A sweep's CSVs (csv, its stem's _statistics.csv and _sensitivity.csv):
// .csv, and none of them the HDF5 output or an input (checked before any work).
void check_csvs(const std::string& csv, const std::string& output, std::vector<std::string> inputs) {
  check_extension(csv, {".csv"}, "--csv", "the sweep summary (CSV)");
  inputs.push_back(output);
  const std::string stem = fs::path(csv).replace_extension("").string();
  for (const std::string& f : {csv, stem + "_statistics.csv", stem + "_sensitivity.csv"}) check_not_input(f, inputs, "--csv");
}

// The CSVs of a sweep: the summary (csv), its statistics and, for a
// saltelli design, the sensitivity indices (csv's stem + _statistics.csv,
// _sensitivity.csv).
void write_sweep_csvs(const std::string& csv, const SweepRun& sr, const std::vector<std::string>& names) {
  write_csv(csv, sr.parameters, sr.summary);
  const std::string stem = fs::path(csv).replace_extension("").string();
  write_statistics_csv(stem + "_statistics.csv", sr.statistics);
  std::fprintf(stderr, "manyrods: sweep summary -> %s, statistics -> %s_statistics.csv", csv.c_str(), stem.c_str());
  if (!sr.sensitivity.empty()) {
    write_sensitivity_csv(stem + "_sensitivity.csv", sr.sensitivity, names);
    std::fprintf(stderr, ", sensitivity indices -> %s_sensitivity.csv", stem.c_str());
  }
  std::fputc('\n', stderr);
}

// A sweep (new, or continued from its file's checkpoint) into opt.output,
// with the per-variation summary in /sweep and in `csv` (default: the
// output with .csv).
int run_sweep(const Sweep& sw, RunOptions opt, std::string csv, const h5::Checkpoint* restart) {
  if (csv.empty()) csv = fs::path(opt.output).replace_extension(".csv").string();
  check_csvs(csv, opt.output, sw.scene.inputs);
  std::fprintf(stderr, "manyrods sweep: %zu variations, %zu rods in one batch%s\n", sw.points.size(),
               sw.scene.rods.size(), restart ? " (continued)" : "");
  const std::string output = opt.output;
  const SweepRun sr = manyrods::scene::run_sweep(sw, std::move(opt), restart);
  const RunResult& r = sr.run;
  summary_line(r, output);
  write_sweep_csvs(csv, sr, sw.names);
  return run_status(r);
}

// Every option of every subcommand (CLI11 writes into it).
struct Options {
  std::string scene_path, output, restart, csv, usd, plot_dir, input;
  int threads = default_threads(), samples = 0, every = 1;
  double until = -1, duration = -1;
  double at = 0;             // static: the time of the driven holds' poses
  bool from_static = false;  // run: start from the static equilibrium
  std::uint64_t seed = 0;
  bool progress = isatty(2) != 0, no_progress = false, force_progress = false, profile = false;
  bool force_dt = false, resume = false;
  double checkpoint_every = 300;
  std::vector<std::string> vary;
  std::string design;  // sweep: grid, mc, lhs, sobol (empty: grid, or mc with --samples)
  std::string frames = "ends";  // sweep: ends or all
  int chunk = 0;                 // sweep: variations per batch (0: all in one)
  // bench
  std::int64_t bench_steps = 0, bench_warmup = 0;
  bool stiff_solve_float = false;
  int repeats = 5;
  std::string json, precision;
  // calibrate
  std::vector<std::string> fit;
  std::vector<std::string> data;
  int population = 0, generations = 200;
  double sigma = std::numeric_limits<double>::quiet_NaN(), fit_tolerance = 1e-7;
};

struct Commands {
  CLI::App *run, *sweep, *exp, *plot, *bench, *stat, *cal;
};

// (CLI11's PositiveNumber prints the whole range up to DBL_MAX)
CLI::Validator number_check(bool strict) {
  return CLI::Validator(
      [strict](std::string& s) {
        try {
          std::size_t used = 0;
          const double v = std::stod(s, &used);
          if (used == s.size() && std::isfinite(v) && (strict ? v > 0 : v >= 0)) return std::string();
        } catch (const std::exception&) {
        }
        return std::string(strict ? "must be a number > 0" : "must be a number >= 0") + ", got '" + s + "'";
      },
      strict ? "NUMBER>0" : "NUMBER>=0");
}

void add_progress_flags(CLI::App* c, Options& o) {
  c->add_flag("--no-progress", o.no_progress, "no progress line on stderr (default: shown when stderr is a terminal)");
  c->add_flag("--progress", o.force_progress, "progress line on stderr even when it is not a terminal");
  c->add_flag("--profile", o.profile, "print the time of each stage of the step (thread-seconds) at the end");
}

void add_force_dt_flag(CLI::App* c, Options& o) {
  c->add_flag("--force-dt", o.force_dt,
              "run a step above the scene's stable limit (refused otherwise; docs/scenes.md \"The step-size guard\")");
}

CLI::App* add_run_command(CLI::App& app, Options& o) {
  const CLI::Validator positive = number_check(true), non_negative = number_check(false);
  CLI::App* run = app.add_subcommand("run", "run a scene into an HDF5 file");
  run->add_option("scene", o.scene_path, "scene file (TOML)");
  run->add_option("-o,--output", o.output, "output HDF5 file")->required();
  run->add_option("--restart", o.restart, "continue the run whose output (checkpoint) is this file");
  run->add_option("--threads", o.threads, "OpenMP threads (results do not depend on it)")->check(positive);
  run->add_option("--until", o.until, "stop at this simulated time (s); the file keeps a checkpoint to --restart from")
      ->check(non_negative);
  run->add_option("--duration", o.duration, "override [simulation] duration (s)")->check(positive);
  run->add_option("--csv", o.csv, "restarting a sweep: summary CSV (default: the output with .csv)");
  run->add_option("--checkpoint-every", o.checkpoint_every,
                  "wall seconds between checkpoints, each closing a part of the output (0: none; default 300)")
      ->check(number_check(false));
  run->add_flag("--resume", o.resume, "continue this scene's run into this output from its last checkpoint (after a kill)");
  run->add_flag("--from-static", o.from_static,
                "start from the rods' static equilibrium under the scene's loads (what `manyrods static` solves), at rest");
  add_force_dt_flag(run, o);
  add_progress_flags(run, o);
  return run;
}

CLI::App* add_sweep_command(CLI::App& app, Options& o) {
  const CLI::Validator positive = number_check(true), non_negative = number_check(false);
  CLI::App* sweep = app.add_subcommand("sweep", "run every variation of a scene as rods of one batch");
  sweep->add_option("scene", o.scene_path, "scene file (TOML)")->required();
  sweep->add_option("--vary", o.vary,
                    "KEY=lo:hi:n | KEY=lo:hi | KEY=uniform:lo:hi | KEY=normal:mean:std[:lo:hi] | "
                    "KEY=lognormal:median:sigma | KEY=v1,v2,.. (v@weight) (e.g. rods.0.damping.tau_extension=0.01:0.1:64)")
      ->required()
      ->allow_extra_args(false)  // one KEY=SPEC per --vary (repeat it), so a scene after it stays positional
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sweep->add_option("--samples", o.samples, "sampled design: number of variations")->check(non_negative);
  sweep->add_option("--seed", o.seed, "sampled design: seed");
  sweep->add_option("--design", o.design,
                    "grid (default without --samples), mc (default with it), lhs, sobol, or saltelli (Sobol' "
                    "sensitivity indices: --samples N base points, N (parameters + 2) variations)")
      ->check(CLI::IsMember({"grid", "mc", "lhs", "sobol", "saltelli"}));
  sweep->add_option("-o,--output", o.output, "output HDF5 file")->required();
  sweep->add_option("--csv", o.csv, "summary CSV (default: the output with .csv)");
  sweep->add_option("--threads", o.threads, "OpenMP threads")->check(positive);
  sweep->add_option("--duration", o.duration, "override [simulation] duration (s)")->check(positive);
  sweep->add_option("--until", o.until, "stop at this simulated time (s); the file keeps a checkpoint to continue with run --restart")
      ->check(non_negative);
  sweep->add_option("--frames", o.frames,
                    "ends (default): frames of the first and last step only; all: every output_interval (large: "
                    "every variation's every node); none: the summary and checkpoint only")
      ->check(CLI::IsMember({"ends", "all", "none"}));
  sweep->add_option("--chunk", o.chunk,
                    "run the variations this many at a time, each chunk a file in <output>.chunks/ (the output "
                    "becomes their index; the same command continues an interrupted sweep)")
      ->check(positive);
  add_force_dt_flag(sweep, o);
  add_progress_flags(sweep, o);
  return sweep;
}

Commands add_commands(CLI::App& app, Options& o) {
  Commands c{add_run_command(app, o), add_sweep_command(app, o), nullptr, nullptr, nullptr, nullptr, nullptr};
  c.exp = app.add_subcommand("export", "export an output file (USD ASCII BasisCurves)");
  c.exp->add_option("input", o.input, "manyrods HDF5 output")->required();
  c.exp->add_option("--usd", o.usd, "USD ASCII file to write (.usda)")->required();
  c.exp->add_option("--every", o.every, "export every k-th frame")->check(number_check(true));
  c.plot = app.add_subcommand("plot", "PNG plots of an output file with gnuplot");
  c.plot->add_option("input", o.input, "manyrods HDF5 output")->required();
  c.plot->add_option("--out-dir", o.plot_dir, "directory for the PNGs (default: <input>_plots)");
  const CLI::Validator positive = number_check(true);
  c.bench = app.add_subcommand("bench", "time a scene: element-steps/s, simulated s per wall s, stages, ceilings");
  c.bench->add_option("scene", o.scene_path, "scene file (TOML)")->required();
  c.bench->add_option("--threads", o.threads, "OpenMP threads")->check(positive);
  c.bench->add_option("--steps", o.bench_steps, "steps per timed run (default: a multiple of 64 taking about 0.5 s)")
      ->check(positive);
  c.bench->add_option("--repeats", o.repeats, "timed runs; their median is reported (default 5)")->check(positive);
  c.bench->add_option("--warmup", o.bench_warmup, "steps before the timed runs (default 64)")->check(positive);
  c.bench->add_option("--precision", o.precision, "float or double (default: the scene's)")
      ->check(CLI::IsMember({"float", "double"}));
  c.bench->add_option("--json", o.json, "write the runs in Google Benchmark's JSON format to this file");
  add_force_dt_flag(c.bench, o);
  c.stat = app.add_subcommand("static", "the static equilibrium of a scene's rods and the reactions at their holds");
  c.stat->add_option("scene", o.scene_path, "scene file (TOML)")->required();
  c.stat->add_option("-o,--output", o.output, "output HDF5 file (one frame, /holds, a checkpoint)")->required();
  c.stat->add_option("--at", o.at, "time (s) whose poses the driven holds take (default 0)")->check(number_check(false));
  c.stat->add_option("--threads", o.threads, "OpenMP threads (rods solved in parallel; results do not depend on it)")
      ->check(positive);
  c.cal = app.add_subcommand("calibrate", "fit a scene's parameters to measured node tracks (CMA-ES, each generation one batch)");
  c.cal->add_option("scene", o.scene_path, "scene file (TOML)")->required();
  c.cal->add_option("--data", o.data,
                    "the measurements: node tracks, a CSV (time,track,x,y,z[,sigma]) or a manyrods run output "
                    "(HDF5), and/or scalars of the scene's [[observables]], a CSV (observable,value,sigma)")
      ->required()
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  c.cal->add_option("--fit", o.fit,
                    "KEY=lo:hi | KEY=log:lo:hi | KEY=normal:mean:std | KEY=lognormal:median:sigma "
                    "(e.g. rods.0.material.youngs_modulus=log:1e5:1e7)")
      ->required()
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  c.cal->add_option("-o,--output", o.output, "output HDF5 file: the best fit's run with /calibration")->required();
  c.cal->add_option("--csv", o.csv, "the fitted parameters as CSV (default: the output with .csv)");
  c.cal->add_option("--seed", o.seed, "the optimizer's seed (the result is the same for a seed and any thread count)");
  c.cal->add_option("--population", o.population, "candidates per generation (default 4 + 3 ln d, at least 8)")
      ->check(positive);
  c.cal->add_option("--generations", o.generations, "the budget: at most this many generations (default 200)")
      ->check(positive);
  c.cal->add_option("--tolerance", o.fit_tolerance,
                    "stop when the search's steps fall below this fraction of each range (default 1e-7)")
      ->check(positive);
  c.cal->add_option("--sigma", o.sigma, "the tracks' noise (m) where the data give none (default: estimated from the fit)")
      ->check(positive);
  c.cal->add_option("--threads", o.threads, "OpenMP threads (results do not depend on it)")->check(positive);
  c.cal->add_flag("--no-progress", o.no_progress, "no progress line on stderr (default: shown when stderr is a terminal)");
  c.cal->add_flag("--progress", o.force_progress, "progress line on stderr even when it is not a terminal");
  c.bench->add_flag("--stiff-solve-float", o.stiff_solve_float,
                    "solve a float batch's stiff rods in float (faster; loses the slow motion at frame-rate steps: "
                    "for comparison only)");
  return c;
}

RunOptions run_options(const Options& o) {
  RunOptions opt;
  opt.output = o.output;
  opt.threads = o.threads;
  opt.until = o.until;
  opt.duration = o.duration;
  opt.progress = o.progress;
  opt.profile = o.profile;
  opt.interrupt = &g_interrupt;
  opt.checkpoint_every = o.checkpoint_every;
  opt.on_warning = [progress = o.progress](const std::string& m) {
    std::fprintf(stderr, "%smanyrods: warning: %s\n", progress ? "\n" : "", m.c_str());
  };
  std::signal(SIGINT, on_sigint);
  return opt;
}

int command_run(const Options& o) {
  if (o.restart.empty() == o.scene_path.empty()) {
    std::fprintf(stderr, "manyrods run: give a scene file, or --restart FILE (not both)\n");
    return 2;
  }
  if (!o.csv.empty() && o.restart.empty()) {
    std::fprintf(stderr, "manyrods run: --csv applies only to continuing a sweep (--restart sweep.h5)\n");
    return 2;
  }
  std::error_code ec;
  if (!o.restart.empty() && fs::exists(o.output, ec) && fs::equivalent(o.restart, o.output, ec)) {
    std::fprintf(stderr,
                 "manyrods run: --restart %s -o %s: the continuation would replace the file it continues (and its "
                 "frames); write it to another file\n",
                 o.restart.c_str(), o.output.c_str());
    return 2;
  }
  if (!o.restart.empty()) check_h5_output(o.output, {o.restart}, "-o");
  if (!o.restart.empty() && o.resume) {
    std::fprintf(stderr, "manyrods run: --resume continues a scene's run into its output (give the scene, not --restart)\n");
    return 2;
  }
  if (!o.restart.empty() && o.from_static) {
    std::fprintf(stderr, "manyrods run: --from-static starts a scene's run (a restart continues from its checkpoint)\n");
    return 2;
  }
  if (!o.restart.empty() && o.force_dt) {
    std::fprintf(stderr, "manyrods run: --force-dt: a restart keeps the step of the run it continues\n");
    return 2;
  }
  const RunOptions opt = run_options(o);
  RunResult r;
  if (!o.restart.empty()) {
    const h5::Checkpoint c = h5::read_checkpoint(o.restart);
    if (c.from_sweep) {  // a sweep continued: the same variations, its records go on
      const Sweep sw = sweep_of_checkpoint(c, o.restart);
      RunOptions so = opt;
      so.checkpoint_every = 0;  // (sweeps are written in one piece)
      so.frames = RunOptions::Frames::ends;  // (a sweep's frames: its ends)
      return run_sweep(sw, so, o.csv, &c);
    }
    if (!o.csv.empty()) {
      std::fprintf(stderr, "manyrods run: --csv applies only to continuing a sweep; %s is a run\n", o.restart.c_str());
      return 2;
    }
    const Scene s = parse_scene(c.scene_text, o.restart + ":/scene");
    r = run_scene(s, opt, &c);
  } else {
    Scene s = load_scene(o.scene_path);
    s.sim.force_dt = o.force_dt;
    RunOptions ro = opt;
    ro.resume = o.resume;  // (run_scene finds the parts' last checkpoint)
    ro.from_static = o.from_static;
    ro.on_note = [](const std::string& line) { std::fprintf(stderr, "manyrods: %s\n", line.c_str()); };
    r = run_scene(s, ro);
    if (!s.sim.dt_auto && r.dt != s.sim.dt)
      std::fprintf(stderr,
                   "manyrods: note: dt = %.6g s was shortened to %.6g s, so that output_interval = %.6g s is a whole "
                   "number of steps (frames at its exact multiples)\n",
                   s.sim.dt, r.dt, s.sim.output_interval);
  }
  summary_line(r, o.output);
  return run_status(r);
}

int report(const std::exception& e);

// ---- MPI: a sweep's chunks, a calibration's generations shared among ranks ------------

// The MPI session of a `manyrods sweep` or `calibrate` started by an MPI launcher (mpirun,
// srun): initialized only then, so that every other use of the tool runs
// without MPI (a plain start is one process).
bool launched_by_mpi() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(v)) return true;
  return false;
}

struct MpiSession {
  bool on = false;
  Shards shards;
  MpiSession() {
#ifdef MANYRODS_MPI
    on = launched_by_mpi();
    if (!on) return;
    MPI_Init(nullptr, nullptr);
    MPI_Comm_rank(MPI_COMM_WORLD, &shards.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &shards.ranks);
    shards.min_all = [](double x) {
      double m = x;
      MPI_Allreduce(&x, &m, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
      return m;
    };
    shards.sum_all = [](double x) {
      double s = 0;
      MPI_Allreduce(&x, &s, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
      return s;
    };
    shards.all_ok = [](bool b) {
      int in = b ? 1 : 0, all = 0;
      MPI_Allreduce(&in, &all, 1, MPI_INT, MPI_LAND, MPI_COMM_WORLD);
      return all != 0;
    };
    shards.all_gather = [](const std::vector<double>& mine, const std::vector<int>& counts) {
      std::vector<int> at(counts.size(), 0);
      for (std::size_t r = 1; r < counts.size(); ++r) at[r] = at[r - 1] + counts[r - 1];
      std::vector<double> all(std::size_t(at.back() + counts.back()));
      MPI_Allgatherv(mine.data(), int(mine.size()), MPI_DOUBLE, all.data(), counts.data(), at.data(), MPI_DOUBLE,
                     MPI_COMM_WORLD);
      return all;
    };
#endif
  }
  ~MpiSession() {
#ifdef MANYRODS_MPI
    if (on) MPI_Finalize();
#endif
  }
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

// f() on every rank of an MPI session: an error on one rank ends them all
// (the others would wait in a collective), reported once by the rank that
// had it; in one process it is thrown as it is.
template <class F>
auto on_every_rank(const Shards& sh, F&& f) {
  try {
    return f();
  } catch (const std::exception& e) {
#ifdef MANYRODS_MPI
    if (sh.ranks > 1) {
      report(e);
      MPI_Abort(MPI_COMM_WORLD, 2);
    }
#else
    (void)sh;
#endif
    throw;
  }
}

// A sweep `--chunk` variations at a time (scene::run_sweep_chunked), its
// chunks shared among the MPI ranks when launched by mpirun or srun: a
// line per chunk, then (rank 0) the index file and the CSVs; stopped by
// Ctrl-C, the same command continues it.
int chunked_sweep(const Options& o, const std::vector<Vary>& vs, const Design& design, const RunOptions& opt) {
  if (o.force_dt) throw SceneError("--force-dt does not apply to a chunked sweep (--chunk)");
  check_csvs(o.csv.empty() ? fs::path(opt.output).replace_extension(".csv").string() : o.csv, opt.output,
             {o.scene_path});
  static MpiSession mpi;  // (finalized at exit)
  const Shards& sh = mpi.shards;
  std::vector<std::string> names;
  for (const Vary& v : vs) names.push_back(v.key);
  const std::vector<std::vector<double>> points = sweep_points(vs, design);
  if (sh.rank == 0)
    std::fprintf(stderr, "manyrods sweep: %zu variations in chunks of %d -> %s.chunks/%s\n", points.size(), o.chunk,
                 opt.output.c_str(), sh.ranks > 1 ? (" (" + std::to_string(sh.ranks) + " MPI ranks)").c_str() : "");
  const std::string who = sh.ranks > 1 ? "rank " + std::to_string(sh.rank) + ": " : "";
  const ChunkedSweep cs = on_every_rank(sh, [&] {
    return run_sweep_chunked(
      read_file(o.scene_path), o.scene_path, names, points, o.chunk, opt,
      [&](int k, int n, const RunResult* r) {
        if (r)
          std::fprintf(stderr, "manyrods: %schunk %d/%d: %s at t = %.6g s, %.3g element-steps/s, %.3g s wall\n",
                       who.c_str(), k + 1, n, r->interrupted ? "stopped" : "done", r->time, r->element_steps_per_s,
                       r->wall_s);
        else
          std::fprintf(stderr, "manyrods: %schunk %d/%d: done before (read back)\n", who.c_str(), k + 1, n);
      },
      sh, design.kind == DesignKind::saltelli ? design.samples : 0);
  });
  if (!cs.complete) {
    if (sh.rank == 0)
      std::fprintf(stderr, "manyrods: stopped; the finished chunks are kept: run the same command to continue\n");
    return 130;
  }
  if (sh.rank != 0) return 0;
  const std::string csv = o.csv.empty() ? fs::path(opt.output).replace_extension(".csv").string() : o.csv;
  std::fprintf(stderr, "manyrods: %d chunks (%d read back from an earlier run) -> index %s\n", cs.chunks, cs.reused,
               opt.output.c_str());
  write_sweep_csvs(csv, cs.result, names);
  return 0;
}

int command_sweep(const Options& o) {
  std::vector<Vary> vs;
  for (const std::string& v : o.vary) vs.push_back(parse_vary(v));
  const Design design = make_design(o.design, o.samples, o.seed);
  RunOptions opt = run_options(o);
  opt.checkpoint_every = 0;  // sweeps are written in one piece (a checkpoint at the end, Ctrl-C, --until)
  opt.frames = o.frames == "all" ? RunOptions::Frames::all : o.frames == "none" ? RunOptions::Frames::none : RunOptions::Frames::ends;
  if (o.chunk > 0) return chunked_sweep(o, vs, design, opt);
  if (launched_by_mpi())
    throw SceneError("sweep: under mpirun or srun the ranks share a sweep's chunks: give --chunk C");
  Sweep sw = make_sweep(read_file(o.scene_path), o.scene_path, vs, design);
  sw.scene.sim.force_dt = o.force_dt;
  return run_sweep(sw, opt, o.csv, nullptr);
}

int command_export(const Options& o) {
  const usd::ExportResult r = usd::export_usd(o.input, o.usd, o.every);
  std::fprintf(stderr, "manyrods: %zu frames of %d rods -> %s\n", r.frames, r.rods, o.usd.c_str());
  return 0;
}

// `manyrods static`: the equilibrium (include/manyrods/any_batch.h
// static_equilibrium) as one frame with the reactions at the holds and a
// checkpoint (`run --restart` continues from it); nothing is written
// without an equilibrium.
int command_static(const Options& o) {
  const Scene s = load_scene(o.scene_path);
  check_h5_output(o.output, s.inputs, "-o");
  if (o.at > s.sim.duration)
    throw SceneError(s.source + ": --at " + std::to_string(o.at) + ": after the scene's duration (" +
                     std::to_string(s.sim.duration) + " s), the span its motions are given for");
  StaticResult r;
  AnyBatch b = static_equilibrium(s, o.at, &r);
  // the step count of time --at, so that `run --restart` from this file
  // ends at the scene's duration with its frames on the scene's grid
  b.f64().state.steps = std::llround(o.at / b.scene_dt());
  const h5::Holds h = b.holds_record(&r);
  b.save(o.output, &h);
  std::fprintf(stderr,
               "manyrods static: equilibrium at t = %.6g s after %d Newton iterations in %d load increments, residual "
               "%.3g N, %.3g N m; %zu holds -> %s\n",
               o.at, r.iterations, r.load_increments, r.residual_force, r.residual_couple, h.rod.size(), o.output.c_str());
  if (r.sticking + r.slipping > 0)
    std::fprintf(stderr, "  friction at the colliders: %d nodes stick where they first touched, %d at the friction limit\n",
                 r.sticking, r.slipping);
  const std::size_t shown = std::min<std::size_t>(h.rod.size(), 20);
  if (shown > 0) std::fprintf(stderr, "  rod  node  kind     force (N)                              moment (N m)\n");
  for (std::size_t i = 0; i < shown; ++i)
    std::fprintf(stderr, "%5d %5d  %-7s  (%11.4g, %11.4g, %11.4g)  (%11.4g, %11.4g, %11.4g)\n", h.rod[i], h.node[i],
                 h.clamped[i] ? "clamped" : "pinned", h.force[3 * i], h.force[3 * i + 1], h.force[3 * i + 2],
                 h.moment[3 * i], h.moment[3 * i + 1], h.moment[3 * i + 2]);
  if (shown < h.rod.size()) std::fprintf(stderr, "  ... (%zu more in /holds)\n", h.rod.size() - shown);
  return 0;
}

// `manyrods calibrate`: the fit (include/manyrods/calibrate.h), a line per
// parameter, the CSV, and the best fit's run with /calibration and
// /calibration_history into the output (checked, with the CSV, before any
// work: neither may be an input). The search's state is kept in
// OUT.calibrate-state after every generation: stopped (Ctrl-C, a job's time
// limit), the same command continues it; it is removed once the results are
// written. Under mpirun or srun the ranks share each generation (rank 0
// writes).
int command_calibrate(const Options& o) {
  const std::string text = read_file(o.scene_path);
  const Scene s = parse_scene(text, o.scene_path);
  std::vector<std::string> inputs = s.inputs;
  inputs.insert(inputs.end(), o.data.begin(), o.data.end());
  const std::string csv = o.csv.empty() ? fs::path(o.output).replace_extension(".csv").string() : o.csv;
  const std::string state = check_calibration_outputs(o.output, csv, inputs, "-o", "--csv");
  std::vector<FitParameter> fit;
  for (const std::string& f : o.fit) fit.push_back(parse_fit(f));
  const Measurements data = read_measurements(o.data, s);
  static MpiSession mpi;  // (finalized at exit; one process unless launched by mpirun or srun)
  const bool lead = mpi.shards.rank == 0;
  CalibrateOptions opt;
  opt.population = o.population;
  opt.max_generations = o.generations;
  opt.tolerance = o.fit_tolerance;
  opt.seed = o.seed;
  opt.sigma = o.sigma;
  opt.threads = o.threads;
  opt.interrupt = &g_interrupt;
  opt.state = state;
  opt.shards = mpi.shards;
  std::signal(SIGINT, on_sigint);
  opt.on_generation = [progress = o.progress && lead](int g, double best, double step) {
    if (progress) std::fprintf(stderr, "\rmanyrods calibrate: generation %d, best misfit %.6g, step %.3g   ", g, best, step);
  };
  if (lead)
    std::fprintf(stderr, "manyrods calibrate: %zu parameters, %zu tracks at %zu times, %zu scalars%s\n", fit.size(),
                 data.tracks.size(), data.time.size(), data.scalars.size(),
                 mpi.shards.ranks > 1 ? (" (" + std::to_string(mpi.shards.ranks) + " MPI ranks)").c_str() : "");
  const Calibration c = on_every_rank(mpi.shards, [&] { return calibrate(text, o.scene_path, fit, data, opt); });
  if (o.progress && lead) std::fputc('\n', stderr);
  if (c.resumed > 0 && lead)
    std::fprintf(stderr, "manyrods calibrate: continued the search from generation %d (%s)\n", c.resumed, state.c_str());
  if (c.interrupted) {  // nothing written but the state: the best so far on stderr
    if (lead) {
      if (c.generations > 0)
        std::fprintf(stderr,
                     "manyrods calibrate: interrupted after %d generations; the search is kept in %s: run the same "
                     "command to continue it. The best so far:\n",
                     c.generations, state.c_str());
      else
        std::fprintf(stderr, "manyrods calibrate: interrupted in the first generation (nothing kept). The start:\n");
      for (std::size_t j = 0; j < fit.size(); ++j) std::fprintf(stderr, "  %s = %.6g\n", fit[j].key.c_str(), c.best[j]);
    }
    return 130;
  }
  if (!lead) return 0;
  // the best fit's run, with the tables (Ctrl-C ends it early: exit 130)
  const RunResult best = run_best_fit(text, o.scene_path, c, o.output, o.threads, &g_interrupt);
  write_calibration_csv(csv, c);
  if (!best.interrupted) {
    std::error_code ec;
    fs::remove(state, ec);
  }
  std::fprintf(stderr,
               "manyrods calibrate: %d generations, %d runs (%s), misfit %.6g over %lld samples%s -> %s, %s\n",
               c.generations, c.evaluations,
               c.converged ? "converged" : c.interrupted ? "interrupted" : "the budget reached", c.misfit,
               static_cast<long long>(c.samples), c.sigma_given ? "" : " (sigma estimated from the residuals)",
               o.output.c_str(), csv.c_str());
  for (const std::string& line : calibration_lines(c)) std::printf("%s\n", line.c_str());
  if (best.interrupted)
    std::fprintf(stderr, "manyrods calibrate: the best fit's run was interrupted at t = %g s (the search is kept in %s)\n",
                 best.time, state.c_str());
  return best.interrupted ? 130 : 0;
}

// The exit status of an error (see the top of this file), with its message.
int report(const std::exception& e) {
  if (dynamic_cast<const SceneError*>(&e) || dynamic_cast<const h5::H5Error*>(&e)) {
    std::fprintf(stderr, "manyrods: error: %s\n", e.what());
    return 2;
  }
  if (dynamic_cast<const StaticError*>(&e)) {
    std::fprintf(stderr, "manyrods: the static solve failed: %s\n(no output written)\n", e.what());
    return 1;
  }
  if (dynamic_cast<const ValidityError*>(&e)) {
    std::fprintf(stderr, "manyrods: the simulation failed: %s\n(no output written; validity.on_violation = \"error\")\n",
                 e.what());
    return 1;
  }
  if (dynamic_cast<const NonFiniteError*>(&e)) {
    std::fprintf(stderr,
                 "manyrods: the simulation failed: %s\n(no output written; a smaller dt or dt = \"auto\" may help)\n",
                 e.what());
    return 1;
  }
  if (dynamic_cast<const std::bad_alloc*>(&e)) {
    std::fprintf(stderr, "manyrods: error: out of memory\n");
    return 2;
  }
  std::fprintf(stderr, "manyrods: error: %s\n", e.what());
  return 1;
}

int command_bench(const Options& o) {
  Scene s = load_scene(o.scene_path);
  if (o.force_dt) s.sim.force_dt = true;
  BenchOptions opt;
  opt.threads = o.threads;
  opt.steps = o.bench_steps;
  opt.repeats = o.repeats;
  opt.warmup = o.bench_warmup;
  opt.stiff_solve_in_double = !o.stiff_solve_float;
  if (!o.precision.empty()) opt.precision = o.precision == "float" ? Precision::float32 : Precision::float64;
  if (!o.json.empty()) {
    check_extension(o.json, {".json"}, "--json", "Google Benchmark's JSON");
    check_not_input(o.json, s.inputs, "--json");
  }
  const BenchResult r = bench_scene(s, opt);
  std::fputs(bench_report(r).c_str(), stdout);
  if (!o.json.empty()) {
    const std::time_t now = std::time(nullptr);
    char date[64];
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S%z", std::localtime(&now));
    const std::string tmp = o.json + ".tmp";
    {
      std::ofstream out(tmp, std::ios::binary);
      out << bench_json(r, date);
      if (!out.flush()) throw SceneError(o.json + ": cannot write the JSON file");
    }
    std::filesystem::rename(tmp, o.json);
    std::fprintf(stderr, "manyrods: wrote %s\n", o.json.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"manyrods: many Cosserat rods with Kelvin-Voigt damping (scenes: docs/scenes.md)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", [] {
    std::string v = "manyrods " MANYRODS_VERSION "\nstep paths (include/manyrods/isa.h, MANYRODS_ISA):";
    for (const StepPath& p : step_paths())
      v += "\n  " + p.name + " (" + p.target + ")" + (p.supported ? "" : " not on this CPU") + (p.active ? ", active" : "");
    return v;
  });
  Options o;
  const Commands c = add_commands(app, o);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (o.force_progress) o.progress = true;
  if (o.no_progress) o.progress = false;
  omp_set_num_threads(o.threads);  // (for the library's parallel work outside the step too: the static solves)
  try {
    if (c.run->parsed()) return command_run(o);
    if (c.sweep->parsed()) return command_sweep(o);
    if (c.exp->parsed()) return command_export(o);
    if (c.plot->parsed()) return plot(o.input, o.plot_dir);
    if (c.bench->parsed()) return command_bench(o);
    if (c.stat->parsed()) return command_static(o);
    if (c.cal->parsed()) return command_calibrate(o);
  } catch (const std::exception& e) {
    return report(e);
  }
  return 0;
}
