// include/manyrods/h5io.h — the HDF5 output file of a run (layout in docs/scenes.md,
// "Output file"), its checkpoint, and reading both back. HDF5 C API.
//
//   /time                 [frames]                 s
//   /node_offsets         [rods + 1]               rod r owns nodes [o_r, o_{r+1})
//   /element_offsets      [rods + 1]               rod r owns elements [o_r, o_{r+1})
//   /node_position        [frames, nodes, 3]       m, lab frame (float or double)
//   /element_directors    [frames, elements, 3, 3] rows d1, d2, d3 (optional)
//   /energy/{kinetic, elastic, potential, dissipation_rate, dissipated}  [frames]
//                         (step.h MANYRODS_ENERGY_FIELDS by dataset name, then
//                         the run's integral of the dissipation rate)
//   /energy/contact_work, /contact/{count, max_penetration}  [frames]  (scenes with contact)
//   /rods/{group, width}  [rods]                   group index, section width (m);
//                         attribute group_names (one per line)
//   /scene                group; attributes text (the scene TOML), source
//   /checkpoint           the full State (include/manyrods/fields.h):
//                         node_x, node_v [3, slots], elem_Q [9, slots],
//                         elem_w [3, slots], node_xc [3, slots] (float) in the run's
//                         precision, raw slot arrays (ghosts included), and
//                         attributes time, steps, dt, dissipated, ...;
//                         with contact contact_work [1, slots] (per slot)
//                         and, where contacts acted in the implicit solve,
//                         contact_impulses [rows, 13] (double: rod, k,
//                         collider, k2, kb, partner, s, n[3], p[3]);
//                         and, for a sweep, probes/{time, tip, max_strain,
//                         dissipated, dissipation_rate, observed,
//                         observed_last} (its records so far)
//   /observables          a run's observables, one value per dataset
//   /holds, /static       (manyrods static) the reactions at the holds (Holds)
//   /sweep                (manyrods sweep) parameters, summary and statistics columns
// Root attributes: format = "manyrods", format_version = 2, precision,
// integrator, dt. Frames are chunked one frame per chunk (at most 2^16 nodes)
// and compressed (shuffle + deflate).
//
// The writer creates `<path>.tmp` and renames it to `<path>` in finish(), so
// an existing output is never left half-written.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "manyrods/fields.h"
#include "manyrods/step.h"

namespace manyrods::h5 {

// Every problem reading or writing an HDF5 file; what() names the file.
struct H5Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Layout {
  std::vector<std::int64_t> node_offsets, element_offsets;  // [rods + 1]
  std::vector<std::int32_t> rod_group;                      // [rods]
  std::vector<double> rod_width;                            // [rods]
  // [nodes] each node's width where some rod is tapered (RodSpec::section_scale;
  // /rods/node_width); empty: rod_width
  std::vector<double> node_width;
  std::vector<std::string> group_names;                     // [groups]
  bool float32 = false;
  bool directors = true;
  bool contact = false;  // write /energy/contact_work and /contact/{count, max_penetration}
};

struct RunInfo {
  std::string scene_text, scene_source;
  std::string integrator;  // "position_verlet" | "pefrl"
  double dt = 0;
};

// A frame's energies: the step's Energies (one /energy dataset per entry of
// step.h MANYRODS_ENERGY_FIELDS, under its dataset name; the contact entries
// only with Layout::contact), the run's dissipated energy so far and, with
// contact, the frame's contact record.
struct EnergyRow : Energies {
  double dissipated = 0;       // /energy/dissipated: ∫ 2·D_v dt since the run's start (J, trapezoidal rule)
  double contacts = 0;         // /contact/count: contacts in touch
  double max_penetration = 0;  // /contact/max_penetration: the deepest overlap (m)
};

// A named column of values per sweep variation.
struct Column {
  std::string name;
  std::vector<double> values;
};

// The state of a run at one step: the batch's State arrays (raw slots, the
// run's precision; stored as bytes) plus what continues the energy record
// and, for a sweep, its per-variation records (manyrods/runner.h ProbeRecord).
struct Checkpoint {
  bool float32 = false;
  std::int64_t slots = 0;
  double time = 0, dt = 0;
  std::int64_t steps = 0;
  double dissipated = 0;            // ∫ 2·D_v dt so far, J
  double last_rate = 0;             // 2·D_v at the last energy sample, W
  std::int64_t frames_written = 0;  // frames of the run up to this state
  // the validity monitor's reference (host/scene/run/validity.h): the budget at the
  // run's start and the largest kinetic + elastic energy so far (NaN: none)
  double validity_energy0 = NAN, validity_scale = NAN;
  std::string scene_text, scene_source;
  bool from_sweep = false;  // the file is a sweep's (read only)
  // The State arrays (include/manyrods/fields.h MANYRODS_STATE_FIELDS), raw
  // slots of float or double as bytes, [components][slots] each: node_x,
  // node_v, elem_Q, elem_w, and for float node_xc (empty for double, and
  // for a float file written before it existed: then zero).
#define MANYRODS_CHECKPOINT_MEMBER(name, n, fill, float_only, doc) std::vector<unsigned char> name;
  MANYRODS_STATE_FIELDS(MANYRODS_CHECKPOINT_MEMBER)
#undef MANYRODS_CHECKPOINT_MEMBER
  // With contact: the work of the contact impulses per slot so far
  // (ContactData::work, [1][slots] as bytes; empty: none), so that a
  // continued run's /energy/contact_work goes on bit for bit.
  std::vector<unsigned char> contact_work;
  // With contact in the implicit solve: each rod's contacts' impulses at the
  // end of the last step (ContactData::solve_impulses, the next step's first
  // guess), kContactImpulseColumns values a row: rod, k, collider, k2, kb,
  // partner, s, n[3], p[3] (float values exactly as doubles); empty: none.
  static constexpr int kContactImpulseColumns = 13;
  std::vector<double> contact_impulses;
  // A sweep's probe records up to this state (/checkpoint/probes; all
  // probes are sampled together): time [probes, samples], tip
  // [probes, samples, 3], and per probe max_strain, dissipated and the last
  // dissipation rate. probe_count = 0: none.
  std::int64_t probe_count = 0, probe_samples = 0;
  std::vector<double> probe_time, probe_tip, probe_max_strain, probe_dissipated, probe_rate;
  // and the scene's observables so far (include/manyrods/observables.h
  // Observed, /checkpoint/probes/observed{,_last}): [probes, columns] and
  // [probes, observables]; empty: the scene has none
  std::vector<double> probe_observed, probe_observed_last;
  // per probe, the time its variation stopped being finite (NaN: it did
  // not; /checkpoint/probes/failed_at; empty in files from before it)
  std::vector<double> probe_failed_at;
  // read only, from a sweep's file: its variations (/sweep/parameters) and
  // the first rod of each (/sweep/variation_first_rod)
  std::vector<Column> sweep_parameters;
  std::vector<std::int32_t> sweep_first_rod;
  int sweep_sensitivity_base = 0;  // /sweep.sensitivity_base: a saltelli design's N (0: none)
};

// A chunked sweep's index file (format "manyrods-sweep-index"): the
// variations' parameters and summary gathered from its chunk files, the
// statistics, the chunk files' names (relative to the index's folder) and
// each one's first variation, and the scene; written to <path>.tmp and
// renamed. The frames stay in the chunk files (below).
struct SweepIndex {
  std::vector<Column> parameters, summary, statistics, sensitivity;
  std::vector<std::string> statistic_names, sensitivity_names;
  std::vector<std::string> chunk_files;
  std::vector<std::int64_t> chunk_first;  // [chunks + 1]
  std::string scene_text, scene_source;
  double dt = 0;
  // The chunk files' frames, presented as those of one sweep file: /time
  // (the same in every chunk), /node_offsets and /element_offsets of all
  // rods, and /node_position [frames, nodes, 3] and /element_directors
  // [frames, elements, 3, 3] as HDF5 virtual datasets that read each chunk
  // file's (h5py opens them as one; a chunk file that is missing reads as
  // NaN). chunk_nodes empty: no frames in the index.
  std::vector<double> time;
  std::vector<std::int64_t> node_offsets, element_offsets;  // [rods + 1]
  std::vector<std::int64_t> chunk_nodes, chunk_elements;    // [chunks]
  bool float32 = false, directors = false;
};
void write_sweep_index(const std::string& path, const SweepIndex& index);
// Whether path is a sweep index (format "manyrods-sweep-index"), and its
// parameters, summary, statistics, scene and dt (H5Error for a damaged one).
bool is_sweep_index(const std::string& path);
SweepIndex read_sweep_index(const std::string& path);

// The reactions at the holds of a static equilibrium (`manyrods static`):
// /holds/rod, /holds/node, /holds/clamped [H] (int32, int32, int8),
// /holds/force, /holds/moment [H, 3] (N, N·m, lab frame: what the hold
// exerts on its rod; a pinned hold's moment is zero), and the attributes of
// /static: time (s, the holds' poses), residual_force (N), residual_couple
// (N·m), newton_iterations, load_increments.
struct Holds {
  std::vector<std::int32_t> rod, node;
  std::vector<std::int8_t> clamped;
  std::vector<double> force, moment;  // [H * 3]
  double time = 0, residual_force = 0, residual_couple = 0;
  std::int64_t iterations = 0, load_increments = 0;
};

class Writer {
 public:
  Writer(const std::string& path, const Layout& layout, const RunInfo& info);
  ~Writer();  // without finish(): closes and removes the temporary file
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // positions: [nodes * 3]; directors: [elements * 9] (ignored unless
  // layout.directors); the pointer type must match layout.float32.
  void append_frame(double time, const void* positions, const void* directors, const EnergyRow& energy);
  void write_checkpoint(const Checkpoint& c);
  // sensitivity_base: a saltelli design's N, kept to continue the sweep (0: none)
  void write_sweep(const std::vector<Column>& parameters, const std::vector<Column>& summary,
                   const std::vector<std::int32_t>& variation_first_rod, int sensitivity_base = 0);
  // After write_sweep: /sweep/<name>, one column per summary column (its
  // name), its values named by `row_names` (the group's attribute
  // `rows_attr`): the statistics, the sensitivity indices.
  void add_sweep_table(const char* name, const std::vector<Column>& columns, const char* rows_attr,
                       const std::vector<std::string>& row_names);
  // /observables: one dataset per column (include/manyrods/observables.h)
  // holding its one value (a run that is not a sweep).
  void write_observables(const std::vector<Column>& columns);
  // /<name>: one dataset per column, their order in the attribute "order",
  // and (rows_attr non-null) the rows' names in the attribute rows_attr
  // (`manyrods calibrate`: /calibration, /calibration_history).
  void write_table(const char* name, const std::vector<Column>& columns, const char* rows_attr = nullptr,
                   const std::vector<std::string>& row_names = {});
  // /holds and /static (Holds above).
  void write_holds(const Holds& holds);
  std::int64_t frames() const;
  // Closes the file and renames <path>.tmp to <path>.
  void finish();
  const std::string& path() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Reads /checkpoint and /scene (H5Error for missing, foreign or truncated files).
Checkpoint read_checkpoint(const std::string& path);

// A whole output file in memory, as double (for export and plots).
struct Output {
  std::vector<double> time;  // [frames]
  std::vector<std::int64_t> node_offsets, element_offsets;
  std::vector<std::int32_t> rod_group;
  std::vector<double> rod_width;
  std::vector<double> node_width;  // [nodes] /rods/node_width (tapered rods); empty: rod_width
  std::vector<std::string> group_names;
  std::int64_t nodes = 0;
  std::vector<EnergyRow> energy;  // [frames] (contact_work, contacts, max_penetration where the file has them)
  bool contact = false;           // the file has /contact (a scene with contact)
  std::string scene_text, scene_source;
  double dt = 0;
  bool has_sweep = false;
  std::vector<Column> sweep_parameters, sweep_summary;
  // /sweep/statistics (files from before it: empty): per summary column, the
  // statistics named in sweep_statistic_names
  std::vector<Column> sweep_statistics;
  std::vector<std::string> sweep_statistic_names;
  std::vector<std::int32_t> sweep_first_rod;  // [variations] /sweep/variation_first_rod
  std::vector<Column> observables;            // /observables (a run's; empty: none)
  // `manyrods calibrate` (include/manyrods/calibrate.h run_best_fit; empty:
  // none): /calibration (a column per fitted key, rows named in
  // calibration_rows), /calibration_history, /calibration_tracks (its
  // tracks' names in calibration_track_names), /calibration_scalars (rows
  // named in calibration_scalar_names)
  std::vector<Column> calibration, calibration_history, calibration_tracks, calibration_scalars;
  std::vector<std::string> calibration_rows, calibration_track_names, calibration_scalar_names;
};

class Reader {
 public:
  explicit Reader(const std::string& path);  // H5Error if not a manyrods output
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;
  const Output& output() const;
  std::int64_t frames() const;
  // Node positions of frame f, [nodes * 3], as double.
  void read_positions(std::int64_t f, std::vector<double>& out) const;
  // Element directors of frame f, [elements * 9], as double.
  bool has_directors() const;
  void read_directors(std::int64_t f, std::vector<double>& out) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace manyrods::h5
