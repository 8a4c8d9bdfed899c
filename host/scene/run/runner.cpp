// host/scene/run/runner.cpp — a scene run into an HDF5 file (include/manyrods/runner.h).
#include "manyrods/runner.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <sstream>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <type_traits>

#include "io/state_bytes.h"
#include "run/parts.h"
#include "setup/static_cache.h"
#include "run/validity.h"
#include "manyrods/scene.h"

namespace manyrods::scene {
namespace {

using detail::field_size;
using detail::from_bytes;
using detail::restore_contact_impulses;
using detail::to_bytes;

std::int64_t round_up(std::int64_t s, std::int64_t m) { return (s / m + 1) * m; }

std::string eta(double s) {
  char buf[32];
  if (!std::isfinite(s)) return "?";
  if (s < 120)
    std::snprintf(buf, sizeof buf, "%.0f s", s);
  else if (s < 7200)
    std::snprintf(buf, sizeof buf, "%.1f min", s / 60);
  else
    std::snprintf(buf, sizeof buf, "%.1f h", s / 3600);
  return buf;
}

// The output path checked before the first step (docs/scenes.md "Output
// files"): the file is written as <path>.tmp in its directory and renamed at
// the end, so the directory must exist and be writable, the path must not be
// a directory, and the disk must have room for the estimated output.
void check_output(const std::string& path, std::uint64_t bytes) {
  namespace fs = std::filesystem;
  auto fail = [&](const std::string& why) { throw SceneError("output " + path + ": " + why); };
  if (path.empty()) fail("no output file given");
  std::error_code ec;
  if (fs::is_directory(path, ec)) fail("is a directory (give a file name, e.g. " + (fs::path(path) / "out.h5").string() + ")");
  if (fs::exists(path, ec) && !fs::is_regular_file(path, ec)) fail("exists and is not a regular file");
  const fs::path dir = fs::path(path).has_parent_path() ? fs::path(path).parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec)) fail("the directory " + dir.string() + " does not exist");
  // a file can be made there (permissions, a read-only or pseudo file
  // system); the probe is the temporary file the run writes, removed again
  const std::string tmp = path + ".tmp";
  const bool existed = fs::exists(tmp, ec);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT, 0644);
  if (fd < 0) fail("cannot write in the directory " + dir.string() + " (" + std::strerror(errno) + ")");
  ::close(fd);
  if (!existed) fs::remove(tmp, ec);
  const fs::space_info sp = fs::space(dir, ec);
  if (!ec && sp.available < bytes) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "needs about %.3g GB, %.3g GB free in %s (fewer frames: a larger output_interval)",
                  double(bytes) / 1e9, double(sp.available) / 1e9, dir.c_str());
    fail(buf);
  }
}

// One run of a scene: the batch, its output file and its records, and the
// loop that advances from sample point to sample point.
template <class T>
class SceneRun {
 public:
  SceneRun(const Scene& s, const RunOptions& opt, const h5::Checkpoint* restart, StaticCache* cache)
      : s_(s), opt_(opt), restart_(restart), choice_(step_choice(s)), b_(build_scene_batch<T>(s, restart == nullptr, cache)) {
    if (!restart && opt.from_static) start_from_static(s, b_);
    res_.dt = restart ? restart->dt : scene_dt(s, b_);
    res_.elements = b_.element_count();
    plan_steps();
    if (restart) restore(*restart);
    else last_rate_ = scene_energies(b_, choice_).dissipation;
    res_.first_step = b_.state.steps;
    if (res_.first_step >= total_)
      throw SceneError(s.source + ": the run is already at step " + std::to_string(res_.first_step) + " of " +
                       std::to_string(total_) + " (give a longer --duration to continue it)");
    check_output(opt_.output, output_bytes());
    if (parts_) prepare_parts();
  }

  RunResult run() {
    std::unique_ptr<h5::Writer> w = open_writer();
    // The first frame: the initial state, or a restart's state when it lies on
    // the frame grid (then the restarted file's frames are exactly those of
    // the uninterrupted run from there on); not for a resumed run, whose
    // last part holds it.
    if (b_.state.steps % per_frame_ == 0 && !opt_.resume && opt_.frames != RunOptions::Frames::none)
      write_frame(*w, scene_energies(b_, choice_));
    if (restart_ && !probe_list_.empty()) restore_probes(*restart_);
    else sample_probes(true);
    if (!opt_.probes.empty()) start_ = b_.state;
    monitor_.emplace(s_, b_, scene_energies(b_, choice_), restart_ ? restart_->validity_energy0 : NAN,
                     restart_ ? restart_->validity_scale : NAN);
    loop(w);
    res_.validity = monitor_->summary(b_.rod_count());
    res_.validity.insert(res_.validity.end(), failures_.begin(), failures_.end());
    const h5::Checkpoint last = checkpoint(*w);
    w->write_checkpoint(last);
    if (opt_.before_finish) opt_.before_finish(*w, probes_);
    if (opt_.probes.empty() && !probes_.empty()) {  // a run's own observables
      const std::vector<std::string> cols = observable_columns(s_.observables);
      const std::vector<double> v = observed_values(probes_[0].observed);
      for (std::size_t k = 0; k < cols.size(); ++k) res_.observables.push_back({cols[k], {v[k]}});
      w->write_observables(res_.observables);
    }
    w->finish();
    if (parts_) res_.frames = merge_parts(list_parts(opt_.output), opt_.output, layout(), info(), last);
    res_.probes = std::move(probes_);
    return res_;
  }

 private:
  void plan_steps() {
    duration_ = opt_.duration > 0 ? opt_.duration : s_.sim.duration;
    if (!(duration_ / res_.dt < 1e15))
      throw SceneError(s_.source + ": duration / dt = " + std::to_string(duration_ / res_.dt) +
                       " steps is beyond any run");
    total_ = std::max<std::int64_t>(1, std::llround(duration_ / res_.dt));
    per_frame_ = std::max<std::int64_t>(1, std::llround(s_.sim.output_interval / res_.dt));
    res_.total_steps = total_;
    probes_.resize(probe_list_.size());
    probe_rate_.assign(probe_list_.size(), 0);
    for (ProbeRecord& r : probes_) r.observed = start_observed(s_.observables);
    observation_steps_ = observation_steps(s_.observables, res_.dt);
  }

  // The first step after `step` at which an observable is wanted (else the last).
  std::int64_t next_observation(std::int64_t step) const {
    const auto it = std::upper_bound(observation_steps_.begin(), observation_steps_.end(), step);
    return it == observation_steps_.end() ? total_ : *it;
  }

  void restore(const h5::Checkpoint& c) {
    if (c.float32 != std::is_same_v<T, float>)
      throw SceneError(s_.source + ": the checkpoint holds " + (c.float32 ? "float" : "double") +
                       " data, the scene's precision differs");
    if (c.slots != b_.slots())
      throw SceneError(s_.source + ": the checkpoint has " + std::to_string(c.slots) + " slots, the scene's batch " +
                       std::to_string(b_.slots()) + " (a different scene?)");
    // every array the batch has, of its size; a float-only one may be
    // missing from a file written before it existed (then it stays zero)
#define MANYRODS_RESTORE(name, n, fill, float_only, doc)                                               \
  if (const std::size_t want = field_size(b_.state.name); want > 0 && !(float_only && c.name.empty())) { \
    if (c.name.size() != want)                                                                         \
      throw SceneError(s_.source + ": the checkpoint's " #name " has " + std::to_string(c.name.size()) + \
                       " bytes, the batch needs " + std::to_string(want));                             \
    from_bytes(b_.state.name, c.name);                                                                 \
  }
    MANYRODS_STATE_FIELDS(MANYRODS_RESTORE)
#undef MANYRODS_RESTORE
    // the contact work so far (a file without it, or without contact, starts it at zero)
    if (b_.contact.on && !c.contact_work.empty()) {
      if (c.contact_work.size() != b_.contact.work.size() * sizeof(T))
        throw SceneError(s_.source + ": the checkpoint's contact_work has " + std::to_string(c.contact_work.size()) +
                         " bytes, the batch needs " + std::to_string(b_.contact.work.size() * sizeof(T)));
      from_bytes(b_.contact.work, c.contact_work);
    }
    // the contact solve's impulses at the checkpoint's step, its next first guess
    if (const std::string bad = restore_contact_impulses(b_, c.contact_impulses); !bad.empty())
      throw SceneError(s_.source + ": the checkpoint's " + bad);
    b_.state.time = c.time;
    b_.state.steps = c.steps;
    dissipated_ = c.dissipated;
    last_rate_ = c.last_rate;
    frames_before_ = c.frames_written;
  }

  // About what the output will hold: the frames from here to the end
  // (positions, directors, energy rows) and the checkpoint (the state).
  std::uint64_t output_bytes() const {
    const std::uint64_t frames = opt_.frames == RunOptions::Frames::all
                                     ? std::uint64_t((total_ - b_.state.steps) / per_frame_ + 2)
                                     : opt_.frames == RunOptions::Frames::ends ? 2 : 0;
    const std::uint64_t nodes = std::uint64_t(b_.element_count() + b_.rod_count());
    const std::uint64_t per_frame =
        sizeof(T) * (3 * nodes + (s_.sim.output_directors ? 9 * std::uint64_t(b_.element_count()) : 0)) + 8 * 8;
    return frames * per_frame + b_.bytes();
  }

  h5::RunInfo info() const {
    return {s_.text, s_.source, s_.sim.integrator == Integrator::pefrl ? "pefrl" : "position_verlet", res_.dt};
  }

  // The writer of the output, or of the next part (checkpoints in parts,
  // include/manyrods/runner.h).
  std::unique_ptr<h5::Writer> open_writer() {
    if (!parts_) return std::make_unique<h5::Writer>(opt_.output, layout(), info());
    part_start_ = std::chrono::steady_clock::now();
    return std::make_unique<h5::Writer>(part_path(opt_.output, ++part_), layout(), info());
  }

  // Parts: a fresh run refuses to start over the parts of an interrupted
  // one; a resumed run continues after the last.
  void prepare_parts() {
    const std::vector<std::string> parts = list_parts(opt_.output, opt_.resume);
    if (!opt_.resume && !parts.empty())
      throw SceneError("output " + opt_.output + ": " + parts_dir(opt_.output) + " holds " +
                       std::to_string(parts.size()) +
                       " parts of an interrupted run: add --resume to continue it, or remove the directory to "
                       "start over");
    part_ = int(parts.size());
    std::error_code ec;
    std::filesystem::create_directories(parts_dir(opt_.output), ec);
    if (ec) throw SceneError("output " + opt_.output + ": cannot make " + parts_dir(opt_.output) + ": " + ec.message());
  }

  // At a sample point: close the current part with a checkpoint and begin the next.
  void roll(std::unique_ptr<h5::Writer>& w) {
    w->write_checkpoint(checkpoint(*w));
    w->finish();
    frames_before_ += w->frames();
    part_frames_ += w->frames();
    w = open_writer();
  }

  h5::Layout layout() const {
    std::vector<std::int32_t> group;
    std::vector<double> width;
    for (int r = 0; r < b_.rod_count(); ++r) {
      group.push_back(s_.rod_group[r]);
      width.push_back(s_.groups[s_.rod_group[r]].width);
    }
    std::vector<std::string> names;
    for (const RodGroup& g : s_.groups) names.push_back(g.name);
    return detail::frame_layout(b_, std::move(group), std::move(width), std::move(names), s_.sim.output_directors,
                                s_.has_contact);
  }

  // Each probe's tip, strain maximum, dissipation integral and observables
  // at this sample point.
  void sample_probes(bool first) {
    for (std::size_t i = 0; i < probe_list_.size(); ++i) {
      const Probe& p = probe_list_[i];
      ProbeRecord& rec = probes_[i];
      rec.time.push_back(b_.state.time);
      rec.tip.push_back(b_.position(p.tip_rod, b_.elements(p.tip_rod)));
      Energies e;
      double strain = 0;  // the largest now
      for (int r = p.rods_begin; r < p.rods_end; ++r) {
        const Energies er = scene_energies(b_, choice_, r);
        e.kinetic += er.kinetic;
        e.elastic += er.elastic;
        e.potential += er.potential;
        e.dissipation += er.dissipation;
        const double st = max_strain(b_, r, s_.groups[s_.rod_group[r]].width);
        if (!(st <= strain)) strain = st;
      }
      if (!(strain <= rec.max_strain)) rec.max_strain = strain;
      if (!first) {
        const std::size_t n = rec.time.size();
        rec.dissipated += 0.5 * (probe_rate_[i] + e.dissipation) * (rec.time[n - 1] - rec.time[n - 2]);
      }
      probe_rate_[i] = e.dissipation;
      rec.final_energy = e;
      if (!s_.observables.empty())
        observe(s_.observables, rec.observed, b_.state.time, b_.state.steps, res_.dt, first,
                [&](std::size_t k) { return quantity(s_.observables[k], p, rec, e, strain); });
    }
  }

  // An observable's quantity now for probe p's rods (its `rod` counts from
  // p.rods_begin); e, strain: their energies and largest strain now.
  double quantity(const Observable& ob, const Probe& p, const ProbeRecord& rec, const Energies& e,
                  double strain) const {
    using Q = Observable::Quantity;
    const int rod = ob.rod < 0 ? -1 : p.rods_begin + ob.rod;
    switch (ob.quantity) {
      case Q::position:
      case Q::displacement: {
        const int node = ob.node < 0 ? b_.elements(rod) + 1 + ob.node : ob.node;
        Vec3 x = b_.position(rod, node);
        if (ob.quantity == Q::displacement)
          for (int a = 0; a < 3; ++a) x[a] -= s_.rods[std::size_t(rod)].nodes[std::size_t(node)][a];
        return ob.component == Observable::norm ? std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) : x[ob.component];
      }
      case Q::strain:
        return rod < 0 ? strain : max_strain(b_, rod, s_.groups[s_.rod_group[rod]].width);
      case Q::energy: {
        if (ob.component == Observable::dissipated) return rec.dissipated;
        const Energies en = rod < 0 ? e : scene_energies(b_, choice_, rod);
        return ob.component == Observable::kinetic   ? en.kinetic
               : ob.component == Observable::elastic ? en.elastic
               : ob.component == Observable::potential ? en.potential
                                                       : en.total();
      }
      case Q::contacts:
      case Q::penetration: {
        const ContactStats cs = contact_stats(b_, rod < 0 ? p.rods_begin : rod, rod < 0 ? p.rods_end : rod + 1);
        return ob.quantity == Q::contacts ? double(cs.contacts) : cs.max_penetration;
      }
    }
    return std::numeric_limits<double>::quiet_NaN();
  }

  // A sweep continued: its records so far, as the uninterrupted run has them
  // at this step (which it sampled already).
  void restore_probes(const h5::Checkpoint& c) {
    if (c.probe_count == 0)
      throw SceneError(s_.source + ": the checkpoint has no sweep or observable records (/checkpoint/probes): a file "
                                   "written before they could be continued; run it again");
    if (c.probe_count != std::int64_t(probe_list_.size()))
      throw SceneError(s_.source + ": the checkpoint holds records of " + std::to_string(c.probe_count) +
                       " variations, the run has " + std::to_string(probe_list_.size()));
    const std::size_t n = std::size_t(c.probe_samples);
    for (std::size_t i = 0; i < probes_.size(); ++i)
      if (c.probe_time[(i + 1) * n - 1] != c.time)
        throw SceneError(s_.source + ": the sweep records of variation " + std::to_string(i) + " end at t = " +
                         std::to_string(c.probe_time[(i + 1) * n - 1]) + " s, the checkpoint is at " +
                         std::to_string(c.time) + " s (a damaged file?)");
    for (std::size_t i = 0; i < probes_.size(); ++i) {
      ProbeRecord& rec = probes_[i];
      rec.time.assign(c.probe_time.begin() + std::ptrdiff_t(i * n), c.probe_time.begin() + std::ptrdiff_t((i + 1) * n));
      for (std::size_t k = 0; k < n; ++k) {
        const double* t = &c.probe_tip[3 * (i * n + k)];
        rec.tip.push_back({t[0], t[1], t[2]});
      }
      rec.max_strain = c.probe_max_strain[i];
      rec.dissipated = c.probe_dissipated[i];
      probe_rate_[i] = c.probe_rate[i];
      // a variation that failed before stays frozen (its state in the
      // checkpoint is its start, at rest; its masses are zeroed again)
      if (i < c.probe_failed_at.size() && std::isfinite(c.probe_failed_at[i]) && !opt_.probes.empty())
        freeze(i, c.probe_failed_at[i], false);
    }
    // the observables so far (the scene's own: the checkpoint carries its text)
    const std::size_t m = rec_columns(), k = s_.observables.size();
    if (c.probe_observed.size() != probes_.size() * m || c.probe_observed_last.size() != probes_.size() * k)
      throw SceneError(s_.source + ": the checkpoint's observable records do not match the scene's " +
                       std::to_string(k) + " [[observables]] (a damaged file?)");
    for (std::size_t i = 0; i < probes_.size(); ++i) {
      Observed& o = probes_[i].observed;
      o.value.assign(c.probe_observed.begin() + std::ptrdiff_t(i * m), c.probe_observed.begin() + std::ptrdiff_t((i + 1) * m));
      o.last.assign(c.probe_observed_last.begin() + std::ptrdiff_t(i * k),
                    c.probe_observed_last.begin() + std::ptrdiff_t((i + 1) * k));
      o.time = c.time;
    }
  }
  std::size_t rec_columns() const { return probes_.empty() ? 0 : probes_[0].observed.value.size(); }

  void write_frame(h5::Writer& w, const Energies& e) {
    gather_positions(b_, pos_);
    if (s_.sim.output_directors) gather_directors(b_, dir_);
    h5::EnergyRow row;
    static_cast<Energies&>(row) = e;
    row.dissipated = dissipated_;
    if (s_.has_contact) {
      const ContactStats cs = contact_stats(b_);
      row.contacts = double(cs.contacts);
      row.max_penetration = cs.max_penetration;
      res_.max_contacts = std::max(res_.max_contacts, cs.contacts);
      res_.list_capacity = cs.list_capacity;
      res_.list_growths = cs.list_growths;
      res_.solve_sweeps = cs.solve_sweeps;
      res_.solve_steps = cs.solve_steps;
      res_.solve_stalled = cs.solve_stalled;
      res_.max_penetration = std::max(res_.max_penetration, cs.max_penetration);
    }
    w.append_frame(b_.state.time, pos_.data(), dir_.data(), row);
  }

  // From sample point to sample point (every kSampleSteps-th step, every
  // frame, the last step) until the end, Ctrl-C or --until.
  void loop(std::unique_ptr<h5::Writer>& w) {
    using clock = std::chrono::steady_clock;
    Profile profile;
    const Exec ex{std::max(1, opt_.threads), opt_.profile ? &profile : nullptr};
    const std::int64_t stop_request = opt_.until >= 0 ? std::llround(opt_.until / res_.dt) : total_;
    const auto t0 = clock::now();
    auto last_print = t0;
    std::int64_t step = b_.state.steps;
    while (step < total_) {
      const std::int64_t next =
          std::min({round_up(step, kSampleSteps), round_up(step, per_frame_), total_, next_observation(step)});
      const std::int64_t prev = step;
      advance_to(next, ex);
      step = next;
      const Energies e = scene_energies(b_, choice_);
      dissipated_ += 0.5 * (last_rate_ + e.dissipation) * (double(next - prev) * res_.dt);
      last_rate_ = e.dissipation;
      if (!probe_list_.empty()) sample_probes(false);
      check_validity(e);
      // (the frame points stay sample points whichever frames are written:
      // the probes' samples, and so a sweep's summary, do not depend on it)
      if (opt_.frames != RunOptions::Frames::none &&
          ((opt_.frames == RunOptions::Frames::all && step % per_frame_ == 0) || step == total_))
        write_frame(*w, e);
      const auto now = clock::now();
      if (parts_ && step < total_ && std::chrono::duration<double>(now - part_start_).count() >= opt_.checkpoint_every)
        roll(w);
      if (opt_.progress && (std::chrono::duration<double>(now - last_print).count() > 0.5 || step == total_)) {
        last_print = now;
        progress(step, std::chrono::duration<double>(now - t0).count());
      }
      if (((opt_.interrupt && *opt_.interrupt) || step >= stop_request) && step < total_) {
        res_.interrupted = true;
        break;
      }
    }
    if (opt_.progress) std::fputc('\n', stderr);
    res_.wall_s = std::chrono::duration<double>(clock::now() - t0).count();
    res_.steps = step;
    res_.time = b_.state.time;
    res_.frames = part_frames_ + w->frames();
    res_.element_steps_per_s = double(step - res_.first_step) * double(res_.elements) / std::max(res_.wall_s, 1e-9);
    res_.stages = profile.total();
    res_.state_hash = state_hash(b_);
  }

  // Steps to `next`. In a sweep (probes), a variation whose state stops
  // being finite is frozen (freeze_failed) and the others go on; a plain
  // run throws NonFiniteError.
  void advance_to(std::int64_t next, const Exec& ex) {
    while (b_.state.steps < next) {
      try {
        advance_scene(b_, choice_, T(res_.dt), next - b_.state.steps, ex);
      } catch (const NonFiniteError&) {
        if (opt_.probes.empty() || !freeze_failed()) throw;
      }
    }
  }

  // The slots [first, last) of rod r, its ghosts included.
  std::pair<int, int> rod_slots(int r) const {
    const int first = b_.rods[std::size_t(r)].offset;
    return {first, r + 1 < b_.rod_count() ? b_.rods[std::size_t(r) + 1].offset : b_.slots()};
  }

  // Variation p's rods back to their state at the run's start, at rest
  // (reset; a continued run's checkpoint holds that state already), every
  // unknown fixed (zero inverse masses), so that they no longer move (it
  // stopped being finite at time t); ProbeRecord::failed_at and a line in
  // the run's validity summary say so.
  void freeze(std::size_t p, double t, bool reset = true) {
    const Probe& pr = opt_.probes[p];
    for (int r = pr.rods_begin; r < pr.rods_end; ++r) {
      const auto [first, last] = rod_slots(r);
      for (int k = first; k < last; ++k) {
        for (int a = 0; a < 3; ++a) b_.model.elem_inv_inertia[a][k] = T(0);
        b_.model.node_inv_mass[k] = T(0);
        if (!reset) continue;
        for (int a = 0; a < 3; ++a) {
          b_.state.node_x[a][k] = start_.node_x[a][k];
          b_.state.node_v[a][k] = T(0);
          b_.state.elem_w[a][k] = T(0);
        }
        for (int a = 0; a < 9; ++a) b_.state.elem_Q[a][k] = start_.elem_Q[a][k];
        if (b_.state.node_xc[0].size() != 0)
          for (int a = 0; a < 3; ++a) b_.state.node_xc[a][k] = T(0);
      }
    }
    probes_[p].failed_at = t;
    std::ostringstream os;
    os << "variation " << p << " (rods " << pr.rods_begin << "-" << pr.rods_end - 1 << ") stopped being finite at t = "
       << t << " s: frozen from there on, its summary is NaN; the other variations went on";
    failures_.push_back(os.str());
  }

  // The variations with a non-finite entry (advance stopped at the first
  // such step): their rods' slots back to their state at the run's start,
  // at rest, every unknown fixed (zero inverse masses), so that they no
  // longer move; ProbeRecord::failed_at and a line in the run's validity
  // summary say so. Rods do not touch across variations (sweeps refuse
  // rod–rod contact), so the others are unaffected. false: none found.
  bool freeze_failed() {
    const State<T>& s = b_.state;
    auto finite_slot = [&](int k) {
      for (int a = 0; a < 3; ++a)
        if (!std::isfinite(s.node_x[a][k]) || !std::isfinite(s.node_v[a][k]) || !std::isfinite(s.elem_w[a][k]))
          return false;
      for (int a = 0; a < 9; ++a)
        if (!std::isfinite(s.elem_Q[a][k])) return false;
      return true;
    };
    bool any = false;
    for (std::size_t p = 0; p < opt_.probes.size(); ++p) {
      const Probe& pr = opt_.probes[p];
      bool bad = false;
      for (int r = pr.rods_begin; r < pr.rods_end && !bad; ++r)
        for (int k = rod_slots(r).first; k < rod_slots(r).second && !bad; ++k) bad = !finite_slot(k);
      if (!bad) continue;
      any = true;
      freeze(p, b_.state.time);
    }
    return any;
  }

  // The validity monitor at a sample point: a new kind of violation is
  // reported through RunOptions::on_warning, or stops the run (ValidityError)
  // with [simulation] validity.on_violation = "error".
  void check_validity(const Energies& e) {
    std::vector<std::string> news;
    monitor_->check(b_, e, b_.state.time, news);
    for (const std::string& m : news) {
      if (s_.sim.validity.error) throw ValidityError(s_.source + ": " + m);
      if (opt_.on_warning) opt_.on_warning(m);
    }
  }

  void progress(std::int64_t step, double wall) const {
    const double rate = double(step - res_.first_step) * double(res_.elements) / std::max(wall, 1e-9);
    const double left = double(total_ - step) * double(res_.elements) / std::max(rate, 1e-300);
    std::fprintf(stderr, "\r[%3d%%] t = %.6g / %.6g s  step %lld / %lld  %.3g element-steps/s  ETA %s   ",
                 int(100.0 * double(step) / double(total_)), b_.state.time, duration_, (long long)step,
                 (long long)total_, rate, eta(left).c_str());
    std::fflush(stderr);
  }

  h5::Checkpoint checkpoint(const h5::Writer& w) const {
    h5::Checkpoint c;
    detail::save_state(b_, c);
    c.dt = res_.dt;
    c.dissipated = dissipated_;
    c.last_rate = last_rate_;
    c.frames_written = frames_before_ + w.frames();
    if (monitor_) {
      c.validity_energy0 = monitor_->energy0();
      c.validity_scale = monitor_->scale();
    }
    c.scene_text = s_.text;
    c.scene_source = s_.source;
    if (probes_.empty()) return c;
    c.probe_count = std::int64_t(probes_.size());
    c.probe_samples = std::int64_t(probes_[0].time.size());
    for (std::size_t i = 0; i < probes_.size(); ++i) {
      const ProbeRecord& rec = probes_[i];
      c.probe_time.insert(c.probe_time.end(), rec.time.begin(), rec.time.end());
      for (const Vec3& t : rec.tip) c.probe_tip.insert(c.probe_tip.end(), t.begin(), t.end());
      c.probe_max_strain.push_back(rec.max_strain);
      c.probe_dissipated.push_back(rec.dissipated);
      c.probe_rate.push_back(probe_rate_[i]);
      c.probe_observed.insert(c.probe_observed.end(), rec.observed.value.begin(), rec.observed.value.end());
      c.probe_observed_last.insert(c.probe_observed_last.end(), rec.observed.last.begin(), rec.observed.last.end());
      c.probe_failed_at.push_back(rec.failed_at);
    }
    return c;
  }

  const Scene& s_;
  const RunOptions& opt_;
  const h5::Checkpoint* restart_;
  const StepChoice choice_;
  RodBatch<T> b_;
  RunResult res_;
  double duration_ = 0;
  std::int64_t total_ = 0, per_frame_ = 1, frames_before_ = 0;
  std::optional<ValidityMonitor<T>> monitor_;
  State<T> start_;                     // the state at the run's start (a sweep's failed variations return to it)
  std::vector<std::string> failures_;  // a line per failed variation
  const bool parts_ = opt_.checkpoint_every > 0;
  int part_ = 0;  // parts begun
  std::int64_t part_frames_ = 0;  // frames in the parts this run closed
  std::chrono::steady_clock::time_point part_start_;
  double dissipated_ = 0, last_rate_ = 0;
  // the sweep's probes, or for a run with observables one over all its rods
  const std::vector<Probe> probe_list_ =
      !opt_.probes.empty() || s_.observables.empty() ? opt_.probes
                                                     : std::vector<Probe>{{0, 0, int(s_.rods.size())}};
  std::vector<ProbeRecord> probes_;
  std::vector<double> probe_rate_;
  std::vector<std::int64_t> observation_steps_;  // sorted
  std::vector<T> pos_, dir_;
};

}  // namespace

namespace {
RunResult run_from(const Scene& s, const RunOptions& opt, const h5::Checkpoint* restart, StaticCache* cache = nullptr) {
  check_h5_output(opt.output, s.inputs, "output");
  if (s.sim.precision == Precision::float32) return SceneRun<float>(s, opt, restart, cache).run();
  return SceneRun<double>(s, opt, restart, cache).run();
}
}  // namespace

RunResult run_scene(const Scene& s, const RunOptions& opt, const h5::Checkpoint* restart, StaticCache* cache) {
  return run_from(s, opt, restart, cache);
}

RunResult run_scene(const Scene& s, const RunOptions& opt, const h5::Checkpoint* restart) {
  if (!opt.resume || restart) return run_from(s, opt, restart);
  // resume: from the last complete part's checkpoint (the .tmp of a part
  // that was being written is removed), or from the start
  const std::vector<std::string> parts = list_parts(opt.output, true);
  RunOptions ro = opt;
  if (parts.empty()) {
    if (opt.on_note)
      opt.on_note("note: resume: no checkpoint of " + opt.output + " yet (" + parts_dir(opt.output) +
                  " holds no complete part): running from the start");
    ro.resume = false;
    return run_from(s, ro, nullptr);
  }
  const h5::Checkpoint c = h5::read_checkpoint(parts.back());
  if (c.scene_text != s.text)
    throw SceneError(s.source + ": resume: the parts in " + parts_dir(opt.output) +
                     " were made from a different scene text (the scene file changed?)");
  if (opt.on_note) {
    char line[64];
    std::snprintf(line, sizeof line, " (t = %.6g s, step %lld)", c.time, (long long)c.steps);
    opt.on_note("resuming from " + parts.back() + line);
  }
  return run_from(s, ro, &c);
}

std::string stage_report(const StageTimes& st) {
  const double total = st.total();
  if (!(total > 0)) return {};
  std::string out;
  char line[160];
  for (int i = 0; i < kStageCount; ++i) {
    if (st.calls[std::size_t(i)] == 0) continue;
    std::snprintf(line, sizeof line, "  %-15s %10.4f s  %5.1f %%  %lld calls\n", stage_name(Stage(i)),
                  st.seconds[std::size_t(i)], 100 * st.seconds[std::size_t(i)] / total, (long long)st.calls[std::size_t(i)]);
    out += line;
  }
  std::snprintf(line, sizeof line, "  %-15s %10.4f s\n", "total", total);
  return out + line;
}

}  // namespace manyrods::scene
