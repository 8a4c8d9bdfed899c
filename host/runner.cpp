// host/runner.cpp — a scene run into an HDF5 file (host/runner.h).
#include "host/runner.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "host/scene_run.h"

namespace manyrods::scene {
namespace {

std::int64_t round_up(std::int64_t s, std::int64_t m) { return (s / m + 1) * m; }

template <class T, std::size_t N>
void to_bytes(const std::array<Array<T>, N>& a, std::vector<unsigned char>& out) {
  out.clear();
  for (const Array<T>& x : a) {
    const auto* p = reinterpret_cast<const unsigned char*>(x.data());
    out.insert(out.end(), p, p + x.size() * sizeof(T));
  }
}
template <class T, std::size_t N>
void from_bytes(std::array<Array<T>, N>& a, const std::vector<unsigned char>& in) {
  std::size_t off = 0;
  for (Array<T>& x : a) {
    std::memcpy(x.data(), in.data() + off, x.size() * sizeof(T));
    off += x.size() * sizeof(T);
  }
}

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

template <class T>
RunResult run(const Scene& s, const RunOptions& opt, const h5::Checkpoint* restart) {
  using clock = std::chrono::steady_clock;
  const StepChoice choice = step_choice(s);
  RodBatch<T> b = build_scene_batch<T>(s, restart == nullptr);
  RunResult res;
  res.dt = restart ? restart->dt : scene_dt(s, b);
  res.elements = b.element_count();
  const T dt = T(res.dt);
  const double duration = opt.duration > 0 ? opt.duration : s.sim.duration;
  if (!(duration / res.dt < 1e15))
    throw SceneError(s.source + ": duration / dt = " + std::to_string(duration / res.dt) +
                     " steps is beyond any run");
  const std::int64_t total = std::max<std::int64_t>(1, std::llround(duration / res.dt));
  const std::int64_t per_frame = std::max<std::int64_t>(1, std::llround(s.sim.output_interval / res.dt));
  res.total_steps = total;
  double dissipated = 0, last_rate = 0;
  std::int64_t frames_before = 0;
  if (restart) {
    if (restart->float32 != std::is_same_v<T, float>)
      throw SceneError(s.source + ": the checkpoint holds " + (restart->float32 ? "float" : "double") +
                       " data, the scene's precision differs");
    if (restart->slots != b.slots())
      throw SceneError(s.source + ": the checkpoint has " + std::to_string(restart->slots) +
                       " slots, the scene's batch " + std::to_string(b.slots()) + " (a different scene?)");
    from_bytes(b.state.node_x, restart->node_x);
    from_bytes(b.state.node_v, restart->node_v);
    from_bytes(b.state.elem_Q, restart->elem_Q);
    from_bytes(b.state.elem_w, restart->elem_w);
    if (!restart->node_xc.empty() && b.state.node_xc[0].size()) from_bytes(b.state.node_xc, restart->node_xc);
    b.state.time = restart->time;
    b.state.steps = restart->steps;
    dissipated = restart->dissipated;
    last_rate = restart->last_rate;
    frames_before = restart->frames_written;
  } else {
    last_rate = scene_energies(b, choice).dissipation;
  }
  res.first_step = b.state.steps;
  if (res.first_step >= total)
    throw SceneError(s.source + ": the run is already at step " + std::to_string(res.first_step) + " of " +
                     std::to_string(total) + " (give a longer --duration to continue it)");

  h5::Layout layout;
  layout.float32 = std::is_same_v<T, float>;
  layout.directors = s.sim.output_directors;
  layout.node_offsets.push_back(0);
  layout.element_offsets.push_back(0);
  for (int r = 0; r < b.rod_count(); ++r) {
    layout.node_offsets.push_back(layout.node_offsets.back() + b.elements(r) + 1);
    layout.element_offsets.push_back(layout.element_offsets.back() + b.elements(r));
    layout.rod_group.push_back(s.rod_group[r]);
    layout.rod_width.push_back(s.groups[s.rod_group[r]].width);
  }
  for (const RodGroup& g : s.groups) layout.group_names.push_back(g.name);
  h5::RunInfo info{s.text, s.source, s.sim.integrator == Integrator::pefrl ? "pefrl" : "position_verlet",
                   res.dt};
  h5::Writer w(opt.output, layout, info);

  std::vector<T> pos, dir;
  std::vector<ProbeRecord> probes(opt.probes.size());
  std::vector<double> probe_rate(opt.probes.size(), 0);
  auto sample_probes = [&](bool first) {
    for (std::size_t i = 0; i < opt.probes.size(); ++i) {
      const Probe& p = opt.probes[i];
      ProbeRecord& rec = probes[i];
      rec.time.push_back(b.state.time);
      rec.tip.push_back(b.position(p.tip_rod, b.elements(p.tip_rod)));
      Energies e;
      for (int r = p.rods_begin; r < p.rods_end; ++r) {
        const Energies er = scene_energies(b, choice, r);
        e.kinetic += er.kinetic;
        e.elastic += er.elastic;
        e.potential += er.potential;
        e.dissipation += er.dissipation;
        const double st = max_strain(b, r, s.groups[s.rod_group[r]].width);
        if (!(st <= rec.max_strain)) rec.max_strain = st;
      }
      if (!first) {
        const std::size_t n = rec.time.size();
        rec.dissipated += 0.5 * (probe_rate[i] + e.dissipation) * (rec.time[n - 1] - rec.time[n - 2]);
      }
      probe_rate[i] = e.dissipation;
      rec.final_energy = e;
    }
  };
  auto write_frame = [&](const Energies& e) {
    gather_positions(b, pos);
    if (layout.directors) gather_directors(b, dir);
    h5::EnergyRow row{e.kinetic, e.elastic, e.potential, dissipated, e.dissipation};
    w.append_frame(b.state.time, pos.data(), dir.data(), row);
  };

  // The first frame: the initial state, or a restart's state when it lies on
  // the frame grid (then the restarted file's frames are exactly those of
  // the uninterrupted run from there on).
  if (b.state.steps % per_frame == 0) write_frame(scene_energies(b, choice));
  if (restart && !opt.probes.empty()) {
    // a sweep continued: its records so far, as the uninterrupted run has
    // them at this step (which it sampled already)
    if (restart->probe_count == 0)
      throw SceneError(s.source + ": the checkpoint has no sweep records (/checkpoint/probes): a sweep file "
                                  "written before sweeps could be continued; run the sweep again");
    if (restart->probe_count != std::int64_t(opt.probes.size()))
      throw SceneError(s.source + ": the checkpoint holds records of " + std::to_string(restart->probe_count) +
                       " variations, the sweep has " + std::to_string(opt.probes.size()));
    const std::size_t n = std::size_t(restart->probe_samples);
    for (std::size_t i = 0; i < probes.size(); ++i)
      if (restart->probe_time[(i + 1) * n - 1] != restart->time)
        throw SceneError(s.source + ": the sweep records of variation " + std::to_string(i) + " end at t = " +
                         std::to_string(restart->probe_time[(i + 1) * n - 1]) + " s, the checkpoint is at " +
                         std::to_string(restart->time) + " s (a damaged file?)");
    for (std::size_t i = 0; i < probes.size(); ++i) {
      ProbeRecord& rec = probes[i];
      rec.time.assign(restart->probe_time.begin() + std::ptrdiff_t(i * n),
                      restart->probe_time.begin() + std::ptrdiff_t((i + 1) * n));
      for (std::size_t k = 0; k < n; ++k) {
        const double* t = &restart->probe_tip[3 * (i * n + k)];
        rec.tip.push_back({t[0], t[1], t[2]});
      }
      rec.max_strain = restart->probe_max_strain[i];
      rec.dissipated = restart->probe_dissipated[i];
      probe_rate[i] = restart->probe_rate[i];
    }
  } else {
    sample_probes(true);
  }
  const Exec ex{std::max(1, opt.threads)};
  const std::int64_t stop_request = opt.until >= 0 ? std::llround(opt.until / res.dt) : total;
  const auto t0 = clock::now();
  auto last_print = t0;
  std::int64_t step = b.state.steps;
  const bool tty_progress = opt.progress;
  while (step < total) {
    const std::int64_t next = std::min({round_up(step, kSampleSteps), round_up(step, per_frame), total});
    const std::int64_t prev = step;
    advance_scene(b, choice, dt, next - step, ex);
    step = next;
    const Energies e = scene_energies(b, choice);
    dissipated += 0.5 * (last_rate + e.dissipation) * (double(next - prev) * res.dt);
    last_rate = e.dissipation;
    if (!opt.probes.empty()) sample_probes(false);
    if (step % per_frame == 0 || step == total) write_frame(e);
    const auto now = clock::now();
    const double wall = std::chrono::duration<double>(now - t0).count();
    if (tty_progress && (std::chrono::duration<double>(now - last_print).count() > 0.5 || step == total)) {
      last_print = now;
      const double rate = double(step - res.first_step) * double(res.elements) / std::max(wall, 1e-9);
      const double left = double(total - step) * double(res.elements) / std::max(rate, 1e-300);
      std::fprintf(stderr, "\r[%3d%%] t = %.6g / %.6g s  step %lld / %lld  %.3g element-steps/s  ETA %s   ",
                   int(100.0 * double(step) / double(total)), b.state.time, duration, (long long)step,
                   (long long)total, rate, eta(left).c_str());
      std::fflush(stderr);
    }
    const bool stop_now = (opt.interrupt && *opt.interrupt) || step >= stop_request;
    if (stop_now && step < total) {
      res.interrupted = true;
      break;
    }
  }
  if (tty_progress) std::fputc('\n', stderr);
  res.wall_s = std::chrono::duration<double>(clock::now() - t0).count();
  res.steps = step;
  res.time = b.state.time;
  res.frames = w.frames();
  res.element_steps_per_s = double(step - res.first_step) * double(res.elements) / std::max(res.wall_s, 1e-9);

  h5::Checkpoint c;
  c.float32 = std::is_same_v<T, float>;
  c.slots = b.slots();
  c.time = b.state.time;
  c.dt = res.dt;
  c.steps = b.state.steps;
  c.dissipated = dissipated;
  c.last_rate = last_rate;
  c.frames_written = frames_before + w.frames();
  c.scene_text = s.text;
  c.scene_source = s.source;
  to_bytes(b.state.node_x, c.node_x);
  to_bytes(b.state.node_v, c.node_v);
  to_bytes(b.state.elem_Q, c.elem_Q);
  to_bytes(b.state.elem_w, c.elem_w);
  if (b.state.node_xc[0].size()) to_bytes(b.state.node_xc, c.node_xc);
  if (!probes.empty()) {
    c.probe_count = std::int64_t(probes.size());
    c.probe_samples = std::int64_t(probes[0].time.size());
    for (std::size_t i = 0; i < probes.size(); ++i) {
      const ProbeRecord& rec = probes[i];
      c.probe_time.insert(c.probe_time.end(), rec.time.begin(), rec.time.end());
      for (const Vec3& t : rec.tip) c.probe_tip.insert(c.probe_tip.end(), t.begin(), t.end());
      c.probe_max_strain.push_back(rec.max_strain);
      c.probe_dissipated.push_back(rec.dissipated);
      c.probe_rate.push_back(probe_rate[i]);
    }
  }
  w.write_checkpoint(c);
  if (opt.before_finish) opt.before_finish(w, probes);
  w.finish();
  res.probes = std::move(probes);
  return res;
}

}  // namespace

RunResult run_scene(const Scene& s, const RunOptions& opt, const h5::Checkpoint* restart) {
  if (s.sim.precision == Precision::float32) return run<float>(s, opt, restart);
  return run<double>(s, opt, restart);
}

}  // namespace manyrods::scene
