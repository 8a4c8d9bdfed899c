// include/manyrods/runner.h — running a scene into an HDF5 file (the `manyrods run` and
// `manyrods sweep` commands; manyrods/h5io.h has the file layout).
//
// The run advances in chunks that end at the "sample points": every 64th
// step, every output frame (output_interval rounded to whole steps), the
// step of each time an observable is wanted at (include/manyrods/observables.h)
// and the last step, all counted from step 0 of the run. At each sample point the
// dissipation rate 2·D_v is evaluated and integrated by the trapezoidal
// rule into /energy/dissipated (so E_mech + dissipated stays constant up to
// the integrator's and the quadrature's error); at each frame the positions,
// directors and energies are written. SIGINT (Ctrl-C) and --until stop at a
// sample point; the file is then closed with the frames so far and a
// checkpoint. Because the sample points depend only on the step number, a
// restart from that checkpoint continues exactly as the uninterrupted run:
// the same steps in the same order (bit-identical state) and the same
// quadrature points.
#pragma once

#include <csignal>
#include <cstdint>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "manyrods/h5io.h"
#include "manyrods/scene.h"
#include "manyrods/manyrods.h"

namespace manyrods::scene {

inline constexpr std::int64_t kSampleSteps = 64;

// ---- what a command may write: checked before any work ----------------------------
// SceneError when `output` is one of `inputs`: the same file by identity
// (std::filesystem::equivalent: another name, a hard or a symbolic link).
// `what` names the option in the message ("-o", "--usd").
void check_not_input(const std::string& output, const std::vector<std::string>& inputs, const std::string& what);
// SceneError unless `output`'s extension (case-insensitive, with its dot) is
// one of `extensions`; `format` names what is written ("USD ASCII").
void check_extension(const std::string& output, const std::vector<std::string>& extensions, const std::string& what,
                     const std::string& format);
// An HDF5 output (run, sweep): not one of `inputs`, and no extension of the
// project's other formats (.toml, .usda, .usd, .usdc, .usdz, .obj, .csv, .json, .png, .gif).
void check_h5_output(const std::string& output, const std::vector<std::string>& inputs, const std::string& what);

// A rod whose tip is recorded at every sample point, and the rods
// [rods_begin, rods_end) whose strain, energies and observables are
// summarised with it (one sweep variation; a run with observables that is
// not a sweep has one probe over all its rods).
struct Probe {
  int tip_rod = 0;
  int rods_begin = 0, rods_end = 0;
};

struct ProbeRecord {
  std::vector<double> time;  // s, at the sample points
  std::vector<Vec3> tip;     // tip position, m
  double max_strain = 0;     // over its rods, over the sample points
  Energies final_energy;     // summed over its rods at the end
  double dissipated = 0;     // ∫ 2·D_v dt over its rods, J
  // the time its state stopped being finite (NaN: it did not): its rods
  // were then frozen at their start and the run went on with the others
  double failed_at = std::numeric_limits<double>::quiet_NaN();
  Observed observed;  // the scene's [[observables]] for these rods (Scene::observables)
};

struct RunOptions {
  std::string output;  // HDF5 path (written as <output>.tmp, renamed at the end)
  // > 0: checkpoints in parts (below) every this many wall seconds
  double checkpoint_every = 0;
  // continue the parts of an interrupted run of this output from their last
  // checkpoint ("Checkpoints in parts" below; its first frame is not written
  // again): run_scene reads it; without a complete part yet it runs from
  // the start (and says so through on_note)
  bool resume = false;
  // start from the rods' static equilibrium at t = 0 (include/manyrods/scene.h
  // start_from_static) instead of the scene's initial state
  bool from_static = false;
  int threads = 1;
  double until = -1;      // stop at the first sample point at or after this time (< 0: never)
  double duration = -1;   // overrides [simulation] duration when > 0
  bool progress = false;  // progress line on stderr
  bool profile = false;   // time each stage of the step (RunResult::stages)
  // Which frames are written: every output_interval; the first and last
  // step's only (a sweep's default: its summary comes from the probes,
  // sampled every 64 steps, not the frames); or none (the file holds the
  // checkpoint, and a sweep's summary, only)
  enum class Frames { all, ends, none };
  Frames frames = Frames::all;
  const volatile std::sig_atomic_t* interrupt = nullptr;  // nonzero: stop at the next sample point
  std::vector<Probe> probes;
  // Called with a line of information on where a resumed run starts.
  std::function<void(const std::string&)> on_note;
  // Called with each new kind of validity violation when it is first seen
  // (host/scene/run/validity.h; docs/scenes.md "The validity monitor").
  std::function<void(const std::string&)> on_warning;
  // Called before the file is closed (the sweep adds /sweep here).
  std::function<void(h5::Writer&, const std::vector<ProbeRecord>&)> before_finish;
};

struct RunResult {
  double dt = 0;
  std::int64_t first_step = 0, steps = 0, total_steps = 0;  // steps: the last step reached
  double time = 0;                                          // simulated time reached, s
  std::int64_t frames = 0;                                  // written to this file
  std::int64_t elements = 0;
  bool interrupted = false;  // SIGINT or --until before the end
  double wall_s = 0, element_steps_per_s = 0;
  std::uint64_t state_hash = 0;  // of the final state (include/manyrods/batch.h state_hash)
  StageTimes stages;             // with RunOptions::profile: thread-seconds per stage
  std::vector<ProbeRecord> probes;
  // a run with [[observables]] that is not a sweep: their values (also in
  // the file's /observables)
  std::vector<h5::Column> observables;
  // scenes with contact, over the frames written: most contacts in touch
  // and the deepest overlap (m)
  std::int64_t max_contacts = 0;
  double max_penetration = 0;
  // the rod–rod neighbour lists at the end: capacity and how often they grew
  int list_capacity = 0;
  std::int64_t list_growths = 0;
  // rod–rod contacts in the implicit solve: its sweeps, the steps that ran
  // them, and those whose sweeps stalled (ContactStats)
  std::int64_t solve_sweeps = 0, solve_steps = 0, solve_stalled = 0;
  // the validity monitor's summary, a line per kind of violation seen
  // (empty: the run stayed in the model's range)
  std::vector<std::string> validity;
};

// Checkpoints in parts. With RunOptions::checkpoint_every > 0 the run writes
// its frames into parts, <output>.parts/part-000001.h5, -000002, …: every
// checkpoint_every wall seconds, at the next sample point, the current part
// gets a checkpoint and is closed (written as .tmp, renamed when complete)
// and the next one begins. Each closed part is a manyrods file (readable
// while the run goes on). At the end the parts are merged into <output> and
// removed. After a kill at any moment the parts so far are intact: the same
// run with `resume` continues from the last one's checkpoint and loses at
// most one interval; as the steps are those of an uninterrupted run (see the
// top of this file) the merged output equals an uninterrupted run's.
// (host/scene/run/parts.h handles the parts.)

// A validity violation with [simulation] validity.on_violation = "error".
struct ValidityError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Runs the scene (from its initial state, or from `restart`, whose scene
// must be `s`; with probes, a sweep's checkpoint, whose records continue;
// with RunOptions::resume and no restart, the last checkpoint of the
// output's parts, SceneError when they were made from another scene text)
// and writes the output. Throws SceneError, h5::H5Error,
// NonFiniteError, ValidityError (the output file is then not written; an
// existing one is kept).
RunResult run_scene(const Scene& s, const RunOptions& opt, const h5::Checkpoint* restart = nullptr);

// The per-stage profile as text, a line per stage that ran (name,
// thread-seconds, share, calls) and the total; empty when nothing was timed
// (`manyrods run --profile`, `manyrods bench`).
std::string stage_report(const StageTimes& st);

}  // namespace manyrods::scene
