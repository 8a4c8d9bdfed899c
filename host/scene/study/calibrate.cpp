// host/scene/study/calibrate.cpp — fitting a scene's parameters to measured
// node tracks by CMA-ES, each generation one sweep batch
// (include/manyrods/calibrate.h; docs/scenes.md "Calibration").
#include "manyrods/calibrate.h"

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>

#include <unistd.h>

#include "manyrods/rng.h"
#include "manyrods/sampling.h"
#include "manyrods/sweep.h"
#include "study/cmaes.h"
#include "study/text.h"

namespace manyrods::scene {

namespace {

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r") - a + 1);
}

}  // namespace

// ---- parameters -----------------------------------------------------------------

double FitParameter::theta_lo() const {
  switch (kind) {
    case Kind::range: return lo;
    case Kind::log_range: return std::log(lo);
    case Kind::normal: return mean - 4 * std;
    case Kind::lognormal: return std::log(mean) - 4 * std;
  }
  return lo;
}
double FitParameter::theta_hi() const {
  switch (kind) {
    case Kind::range: return hi;
    case Kind::log_range: return std::log(hi);
    case Kind::normal: return mean + 4 * std;
    case Kind::lognormal: return std::log(mean) + 4 * std;
  }
  return hi;
}
double FitParameter::value(double th) const { return log() ? std::exp(th) : th; }
double FitParameter::theta(double v) const { return log() ? std::log(v) : v; }

FitParameter parse_fit(const std::string& arg) {
  const std::string what = "--fit " + arg;
  const auto eq = arg.find('=');
  if (eq == std::string::npos || eq == 0)
    throw SceneError(what + ": expected KEY=SPEC (e.g. rods.0.material.youngs_modulus=log:1e5:1e7)");
  FitParameter p;
  p.key = arg.substr(0, eq);
  const std::vector<std::string> f = split(arg.substr(eq + 1), ':');
  auto need = [&](std::size_t n, const char* form) {
    if (f.size() != n) throw SceneError(what + ": expected " + form);
  };
  if (f.empty()) throw SceneError(what + ": no SPEC after '='");
  if (f[0] == "log") {
    need(3, "log:lo:hi");
    p.kind = FitParameter::Kind::log_range;
    p.lo = finite_number(f[1], what), p.hi = finite_number(f[2], what);
    if (!(p.lo > 0)) throw SceneError(what + ": a log range needs lo > 0");
  } else if (f[0] == "normal") {
    need(3, "normal:mean:std");
    p.kind = FitParameter::Kind::normal;
    p.mean = finite_number(f[1], what), p.std = finite_number(f[2], what);
    if (!(p.std > 0)) throw SceneError(what + ": a prior needs std > 0 (it has no mass otherwise)");
  } else if (f[0] == "lognormal") {
    need(3, "lognormal:median:sigma");
    p.kind = FitParameter::Kind::lognormal;
    p.mean = finite_number(f[1], what), p.std = finite_number(f[2], what);
    if (!(p.mean > 0)) throw SceneError(what + ": a log-normal prior needs median > 0");
    if (!(p.std > 0)) throw SceneError(what + ": a prior needs sigma > 0 (it has no mass otherwise)");
  } else {
    if (f.size() == 3 && f[0] == "uniform") {
      p.lo = finite_number(f[1], what), p.hi = finite_number(f[2], what);
    } else {
      need(2, "lo:hi, log:lo:hi, normal:mean:std or lognormal:median:sigma");
      p.lo = finite_number(f[0], what), p.hi = finite_number(f[1], what);
    }
    p.kind = FitParameter::Kind::range;
  }
  if (!p.prior() && !(p.hi > p.lo)) throw SceneError(what + ": the range is empty (needs lo < hi)");
  return p;
}

// ---- measurements ------------------------------------------------------------------

namespace {

// "ROD:NODE" against the scene (SceneError naming `where`)
Track parse_track(const std::string& name, const Scene& s, const std::string& where) {
  const std::vector<std::string> f = split(name, ':');
  if (f.size() != 2)
    throw SceneError(where + ": track '" + name + "' is not ROD:NODE (a rod index and a node index)");
  const double rod = finite_number(trim(f[0]), where + ": track '" + name + "' rod"),
               node = finite_number(trim(f[1]), where + ": track '" + name + "' node");
  const int nrods = int(s.rods.size());
  if (rod != std::floor(rod) || rod < 0 || rod >= nrods)
    throw SceneError(where + ": track '" + name + "': the scene has no rod " + trim(f[0]) + " (rods 0.." +
                     std::to_string(nrods - 1) + ")");
  Track t;
  t.name = name;
  t.rod = int(rod);
  const int nodes = int(s.rods[std::size_t(t.rod)].nodes.size());
  if (node != std::floor(node) || node < -nodes || node >= nodes)
    throw SceneError(where + ": track '" + name + "': rod " + std::to_string(t.rod) + " has no node " + trim(f[1]) +
                     " (nodes 0.." + std::to_string(nodes - 1) + ", or negative from the end)");
  t.node = node < 0 ? nodes + int(node) : int(node);
  return t;
}

Measurements read_run_output(const std::string& path, const Scene& s) {
  const h5::Reader rd(path);
  const h5::Output& o = rd.output();
  Measurements m;
  m.path = path;
  m.time = o.time;
  const std::size_t rods = o.node_offsets.empty() ? 0 : o.node_offsets.size() - 1;
  if (rods != s.rods.size())
    throw SceneError(path + ": a run of " + std::to_string(rods) + " rods, the scene has " +
                     std::to_string(s.rods.size()) + " (measurements from a run of this scene are its nodes' tracks)");
  for (std::size_t r = 0; r < rods; ++r) {
    const std::int64_t n = o.node_offsets[r + 1] - o.node_offsets[r];
    if (n != std::int64_t(s.rods[r].nodes.size()))
      throw SceneError(path + ": rod " + std::to_string(r) + " has " + std::to_string(n) + " nodes, the scene's " +
                       std::to_string(s.rods[r].nodes.size()));
    for (std::int64_t j = 0; j < n; ++j) {
      Track t;
      t.name = std::to_string(r) + ":" + std::to_string(j);
      t.rod = int(r), t.node = int(j);
      t.x.resize(m.time.size());
      m.tracks.push_back(std::move(t));
    }
  }
  std::vector<double> pos;
  for (std::size_t f = 0; f < m.time.size(); ++f) {
    rd.read_positions(std::int64_t(f), pos);
    std::size_t k = 0;
    for (std::size_t r = 0; r < rods; ++r)
      for (std::int64_t j = o.node_offsets[r]; j < o.node_offsets[r + 1]; ++j, ++k)
        for (int a = 0; a < 3; ++a) m.tracks[k].x[f][std::size_t(a)] = pos[std::size_t(3 * j + a)];
  }
  return m;
}

Measurements read_csv(const std::string& path, const Scene& s) {
  std::ifstream in(path);
  if (!in) throw SceneError(path + ": cannot open the measurements");
  Measurements m;
  m.path = path;
  std::string line;
  int ln = 0;
  std::vector<std::string> head;
  while (std::getline(in, line)) {
    ++ln;
    if (trim(line).empty() || trim(line)[0] == '#') continue;
    head = split(line, ',');
    for (std::string& h : head) h = trim(h);
    break;
  }
  const bool with_sigma = head.size() == 6 && head[5] == "sigma";
  if (!(head.size() == 5 || with_sigma) || head[0] != "time" || head[1] != "track" || head[2] != "x" ||
      head[3] != "y" || head[4] != "z")
    throw SceneError(path + ":" + std::to_string(ln) + ": the header must be time,track,x,y,z[,sigma]");
  struct Row {
    double t;
    std::size_t track;
    std::array<double, 3> x;
    int line;
  };
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    ++ln;
    if (trim(line).empty() || trim(line)[0] == '#') continue;
    const std::string where = path + ":" + std::to_string(ln);
    const std::vector<std::string> f = split(line, ',');
    if (f.size() != head.size())
      throw SceneError(where + ": " + std::to_string(f.size()) + " columns, the header has " +
                       std::to_string(head.size()));
    Row row;
    row.line = ln;
    row.t = finite_number(trim(f[0]), where + ": time");
    const std::string name = trim(f[1]);
    std::size_t k = 0;
    while (k < m.tracks.size() && m.tracks[k].name != name) ++k;
    if (k == m.tracks.size()) m.tracks.push_back(parse_track(name, s, where));
    row.track = k;
    for (int a = 0; a < 3; ++a) {
      const std::string v = trim(f[std::size_t(2 + a)]);
      row.x[std::size_t(a)] = v.empty() || v == "nan" || v == "NaN" ? std::numeric_limits<double>::quiet_NaN()
                                                                      : finite_number(v, where + ": " + head[std::size_t(2 + a)]);
    }
    if (with_sigma) {
      const double sg = finite_number(trim(f[5]), where + ": sigma");
      if (!(sg > 0)) throw SceneError(where + ": sigma must be > 0");
      Track& t = m.tracks[k];
      if (!std::isnan(t.sigma) && t.sigma != sg)
        throw SceneError(where + ": track '" + name + "' has sigma " + trim(f[5]) + " here and another before (one per track)");
      t.sigma = sg;
    }
    rows.push_back(row);
  }
  if (rows.empty()) throw SceneError(path + ": no measurements (only a header)");
  for (const Row& r : rows) m.time.push_back(r.t);
  std::sort(m.time.begin(), m.time.end());
  m.time.erase(std::unique(m.time.begin(), m.time.end()), m.time.end());
  for (Track& t : m.tracks)
    t.x.assign(m.time.size(), {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
                               std::numeric_limits<double>::quiet_NaN()});
  std::vector<std::vector<int>> seen(m.tracks.size(), std::vector<int>(m.time.size(), 0));
  for (const Row& r : rows) {
    const std::size_t i = std::size_t(std::lower_bound(m.time.begin(), m.time.end(), r.t) - m.time.begin());
    if (seen[r.track][i])
      throw SceneError(path + ":" + std::to_string(r.line) + ": track '" + m.tracks[r.track].name + "' at time " +
                       trim(std::to_string(r.t)) + " given again (first on line " + std::to_string(seen[r.track][i]) + ")");
    seen[r.track][i] = r.line;
    m.tracks[r.track].x[i] = r.x;
  }
  return m;
}

}  // namespace

Measurements read_measurements(const std::string& path, const Scene& s) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  Measurements m = ext == ".csv" ? read_csv(path, s) : read_run_output(path, s);
  if (m.time.empty()) throw SceneError(path + ": no measured times");
  for (double t : m.time)
    if (t < 0 || t > s.sim.duration * (1 + 1e-12))
      throw SceneError(path + ": time " + std::to_string(t) + " s lies outside the scene's run (0 to " +
                       std::to_string(s.sim.duration) + " s)");
  for (const Track& t : m.tracks) {
    bool any = false;
    for (const auto& x : t.x)
      for (double v : x) any = any || std::isfinite(v);
    if (!any) throw SceneError(path + ": track '" + t.name + "' has no finite sample (all NaN)");
  }
  return m;
}

// ---- the calibration ------------------------------------------------------------------

namespace {

// One batch of candidates (values [candidate][parameter]): each one's
// simulated positions at the measured times, [candidate][track][time][3]
// (NaN for a candidate whose run failed).
struct Evaluator {
  const std::string& text;
  const std::string& source;
  const std::vector<FitParameter>& fit;
  const Measurements& data;
  const CalibrateOptions& opt;
  std::vector<std::string> names;
  std::vector<Observable> obs;
  double dt = 0;
  bool dt_auto = false;
  std::string work;  // the batch runs' file
  double duration = 0;

  using Tracks = std::vector<std::vector<std::array<double, 3>>>;

  // the first refusal's message (a candidate the scene's validation refuses)
  mutable std::string refused;

  std::vector<Tracks> run(const std::vector<std::vector<double>>& all) const {
    const std::size_t T = data.time.size();
    const std::vector<std::array<double, 3>> none(
        T, {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
            std::numeric_limits<double>::quiet_NaN()});
    std::vector<Tracks> out(all.size(), Tracks(data.tracks.size(), none));
    // candidates the scene refuses (a τE below its bound for τS, …) are left
    // out: their tracks stay NaN, their misfit infinite
    std::vector<std::vector<double>> points;
    std::vector<std::size_t> index;
    for (std::size_t v = 0; v < all.size(); ++v) {
      std::vector<Override> ov;
      for (std::size_t j = 0; j < names.size(); ++j) ov.push_back({names[j], all[v][j]});
      try {
        parse_scene(text, source, ov);
      } catch (const SceneError& e) {
        if (refused.empty()) refused = e.what();
        continue;
      }
      points.push_back(all[v]);
      index.push_back(v);
    }
    if (points.empty()) return out;
    Sweep sw = make_sweep(text, source, names, points);
    sw.scene.observables = obs;
    if (dt_auto) {
      sw.scene.sim.dt_auto = false;
      sw.scene.sim.dt = dt;
    }
    // a candidate stiffer than the step allows (the scene's own step, or
    // one beyond the corners of the box the auto step was resolved over)
    // runs anyway, blows up and ranks last: the generation is not refused
    sw.scene.sim.force_dt = true;
    RunOptions ro;
    ro.output = work;
    ro.threads = opt.threads;
    ro.frames = RunOptions::Frames::none;
    ro.duration = duration;
    ro.interrupt = opt.interrupt;
    const SweepRun r = run_sweep(sw, ro);
    std::error_code ec;
    std::filesystem::remove(work, ec);
    for (std::size_t v = 0; v < points.size(); ++v) {
      const ProbeRecord& rec = r.run.probes[v];
      const std::vector<double> val = observed_values(rec.observed);
      Tracks& tr = out[index[v]];
      const bool failed = !std::isnan(rec.failed_at);
      for (std::size_t k = 0; k < data.tracks.size(); ++k)
        for (int a = 0; a < 3; ++a)
          for (std::size_t i = 0; i < T; ++i)
            tr[k][i][std::size_t(a)] =
                failed ? std::numeric_limits<double>::quiet_NaN() : val[(3 * k + std::size_t(a)) * T + i];
    }
    return out;
  }
};

// the tracks' noise (σ = 1 m where none is given)
double noise(const Track& t, const CalibrateOptions& opt) {
  if (!std::isnan(t.sigma)) return t.sigma;
  return std::isnan(opt.sigma) ? 1.0 : opt.sigma;
}

// the whitened residuals of simulated tracks against the data (finite
// samples only, in a fixed order); NaN entries where the run failed
std::vector<double> residuals(const Evaluator::Tracks& sim, const Measurements& data, const CalibrateOptions& opt) {
  std::vector<double> r;
  for (std::size_t k = 0; k < data.tracks.size(); ++k) {
    const double s = noise(data.tracks[k], opt);
    for (std::size_t i = 0; i < data.time.size(); ++i)
      for (int a = 0; a < 3; ++a) {
        const double m = data.tracks[k].x[i][std::size_t(a)];
        if (std::isfinite(m)) r.push_back((sim[k][i][std::size_t(a)] - m) / s);
      }
  }
  return r;
}

double prior_term(const std::vector<FitParameter>& fit, const std::vector<double>& theta) {
  double p = 0;
  for (std::size_t j = 0; j < fit.size(); ++j)
    if (fit[j].prior()) {
      const double c = fit[j].kind == FitParameter::Kind::lognormal ? std::log(fit[j].mean) : fit[j].mean;
      p += ((theta[j] - c) / fit[j].std) * ((theta[j] - c) / fit[j].std);
    }
  return p;
}

}  // namespace

namespace {
std::atomic<std::uint64_t> calibration_count{0};  // (each calibration's batch file its own, threads too)
}  // namespace

Calibration calibrate(const std::string& text, const std::string& source, const std::vector<FitParameter>& fit,
                      const Measurements& data, const CalibrateOptions& opt) {
  if (fit.empty()) throw SceneError("calibrate: nothing to fit (give --fit KEY=SPEC)");
  const Scene base = parse_scene(text, source);
  const std::size_t d = fit.size();
  Calibration c;
  c.fit = fit;
  Evaluator ev{text, source, fit, data, opt, {}, {}, 0, base.sim.dt_auto, "", 0, {}};
  for (const FitParameter& p : fit) ev.names.push_back(p.key);
  for (std::size_t k = 0; k < data.tracks.size(); ++k)
    for (int a = 0; a < 3; ++a) {
      Observable o;
      o.name = "track_" + std::to_string(k) + "_" + "xyz"[a];
      o.quantity = Observable::Quantity::position;
      o.rod = data.tracks[k].rod;
      o.node = data.tracks[k].node;
      o.component = a;
      o.reduce = Observable::Reduce::at;
      o.times = data.time;
      ev.obs.push_back(o);
    }
  ev.duration = std::min(base.sim.duration, data.time.back());
  if (!(ev.duration > 0)) ev.duration = base.sim.duration;
  ev.work = (std::filesystem::temp_directory_path() /
             ("manyrods-calibrate-" + std::to_string(long(::getpid())) + "-" + std::to_string(++calibration_count) +
              "-" + std::to_string(std::uint64_t(std::hash<std::string>{}(source + text))) + ".h5"))
                .string();
  // dt = "auto": one step for every candidate, the smallest stable step over
  // the corners of the search box (a candidate's misfit must not depend on
  // the others in its generation)
  // a point u of the search's unit box: its θ, its values
  auto theta_of_u = [&](const std::vector<double>& u) {
    std::vector<double> th(d);
    for (std::size_t j = 0; j < d; ++j) th[j] = fit[j].theta_lo() + u[j] * (fit[j].theta_hi() - fit[j].theta_lo());
    return th;
  };
  auto to_values = [&](const std::vector<double>& u) {
    std::vector<double> v = theta_of_u(u);
    for (std::size_t j = 0; j < d; ++j) v[j] = fit[j].value(v[j]);
    return v;
  };
  if (ev.dt_auto) {
    std::vector<std::vector<double>> corners;
    for (std::size_t m = 0; m < (std::size_t(1) << std::min<std::size_t>(d, 10)); ++m) {
      std::vector<double> u(d, 0.5);
      for (std::size_t j = 0; j < std::min<std::size_t>(d, 10); ++j) u[j] = (m >> j) & 1 ? 1.0 : 0.0;
      std::vector<Override> ov;
      const std::vector<double> v = to_values(u);
      for (std::size_t j = 0; j < d; ++j) ov.push_back({ev.names[j], v[j]});
      try {
        parse_scene(text, source, ov);
      } catch (const SceneError&) {
        continue;  // (a corner the scene refuses: no candidate runs there)
      }
      corners.push_back(v);
    }
    if (corners.empty()) corners.push_back(to_values(std::vector<double>(d, 0.5)));  // (its error, if any, names the key)
    const Scene sc = make_sweep(text, source, ev.names, corners).scene;
    ev.dt = sc.sim.precision == Precision::float32 ? scene_dt(sc, build_scene_batch<float>(sc))
                                                   : scene_dt(sc, build_scene_batch<double>(sc));
  } else {
    ev.dt = base.sim.dt;
  }
  c.dt = ev.dt;
  c.duration = ev.duration;
  for (const Track& t : data.tracks) c.sigma_given = c.sigma_given || !std::isnan(t.sigma);
  c.sigma_given = c.sigma_given || !std::isnan(opt.sigma);
  for (std::size_t j = 0; j < d; ++j) {
    // (a prior weighs against the data in units of their noise: with σ
    // unknown, σ = 1 m would let it outweigh any data in millimetres)
    if (fit[j].prior() && !c.sigma_given)
      throw SceneError("--fit " + fit[j].key + ": a prior needs the measurements' noise (--sigma, or a sigma column)");
    for (std::size_t i = 0; i < j; ++i)
      if (fit[i].key == fit[j].key) throw SceneError("--fit " + fit[j].key + ": given twice");
  }

  auto objective = [&](const Evaluator::Tracks& sim, const std::vector<double>& theta, double* data_part) {
    const std::vector<double> r = residuals(sim, data, opt);
    double chi2 = 0;
    for (double x : r) chi2 += x * x;
    if (!std::isfinite(chi2)) chi2 = HUGE_VAL;
    if (data_part) *data_part = chi2;
    return chi2 + prior_term(fit, theta);
  };

  // CMA-ES in u ∈ [0, 1]^d
  CmaEs es(int(d), std::vector<double>(d, 0.5), 0.3, opt.population, opt.seed);
  std::vector<double> best_u(d, 0.5);
  double best = HUGE_VAL;
  for (int gen = 0; gen < opt.max_generations; ++gen) {
    std::vector<std::vector<double>> u = es.ask();
    for (auto& x : u)
      for (double& v : x) v = reflect_unit(v);
    std::vector<std::vector<double>> pts;
    for (const auto& x : u) pts.push_back(to_values(x));
    const std::vector<Evaluator::Tracks> sims = ev.run(pts);
    if (opt.interrupt && *opt.interrupt) {
      c.interrupted = true;
      break;
    }
    std::vector<double> f(u.size());
    for (std::size_t k = 0; k < u.size(); ++k) {
      f[k] = objective(sims[k], theta_of_u(u[k]), nullptr);
      if (f[k] < best) best = f[k], best_u = u[k];
    }
    if (gen == 0 && !(best < HUGE_VAL))
      throw SceneError(source + ": no candidate of the first generation could run" +
                       (ev.refused.empty() ? std::string(" (every run failed)") : ": " + ev.refused));
    es.tell(u, f);
    c.evaluations += int(u.size());
    c.generations = gen + 1;
    c.history_best.push_back(best);
    c.history_step.push_back(es.step());
    if (opt.on_generation) opt.on_generation(gen + 1, best, es.step());
    if (es.step() * es.max_axis() < opt.tolerance) {
      c.converged = true;
      break;
    }
  }

  // interrupted: the best so far, no uncertainty
  auto stopped = [&] {
    c.interrupted = true;
    c.best = to_values(best_u);
    c.misfit = best;
    c.sigma.assign(d, std::numeric_limits<double>::quiet_NaN());
    c.theta_sigma = c.sigma;
    c.determined.assign(d, false);
    return c;
  };
  if (c.interrupted) return stopped();
  // the Laplace estimate: the residuals' Jacobian in θ by central
  // differences at the best (the best and its 2d neighbours, one batch)
  const std::vector<double> th = theta_of_u(best_u);
  std::vector<std::vector<double>> pts{to_values(best_u)};
  std::vector<double> h(d);
  for (std::size_t j = 0; j < d; ++j) {
    h[j] = 1e-4 * (fit[j].theta_hi() - fit[j].theta_lo());
    for (double s : {1.0, -1.0}) {
      std::vector<double> t = th;
      t[j] += s * h[j];
      std::vector<double> v(d);
      for (std::size_t i = 0; i < d; ++i) v[i] = fit[i].value(t[i]);
      pts.push_back(v);
    }
  }
  const std::vector<Evaluator::Tracks> sims = ev.run(pts);
  if (opt.interrupt && *opt.interrupt) return stopped();  // (during the uncertainty's batch)
  c.best = pts[0];
  c.misfit = objective(sims[0], th, &c.data_misfit);
  c.fitted = sims[0];
  const std::vector<double> r0 = residuals(sims[0], data, opt);
  c.samples = std::int64_t(r0.size());
  Eigen::MatrixXd J(Eigen::Index(r0.size()), Eigen::Index(d));
  for (std::size_t j = 0; j < d; ++j) {
    // (one-sided where a neighbour was refused or failed: an optimum on a bound)
    const std::vector<double> rp = residuals(sims[1 + 2 * j], data, opt), rm = residuals(sims[2 + 2 * j], data, opt);
    auto finite = [](const std::vector<double>& r) {
      return std::all_of(r.begin(), r.end(), [](double x) { return std::isfinite(x); });
    };
    const bool p_ok = finite(rp), m_ok = finite(rm);
    for (std::size_t i = 0; i < r0.size(); ++i)
      J(Eigen::Index(i), Eigen::Index(j)) = p_ok && m_ok ? (rp[i] - rm[i]) / (2 * h[j])
                                            : p_ok       ? (rp[i] - r0[i]) / h[j]
                                            : m_ok       ? (r0[i] - rm[i]) / h[j]
                                                         : std::numeric_limits<double>::quiet_NaN();
  }
  Eigen::MatrixXd F = J.transpose() * J;
  for (std::size_t j = 0; j < d; ++j)
    if (fit[j].prior()) F(Eigen::Index(j), Eigen::Index(j)) += 1 / (fit[j].std * fit[j].std);
  // s² from the residuals where the noise was not given
  const double dof = double(c.samples) - double(d);
  const double s2 = c.sigma_given ? 1.0 : (dof > 0 ? c.data_misfit / dof : HUGE_VAL);
  // in units of the search ranges: a direction whose deviation exceeds half
  // the range is flat (not determined by the data)
  Eigen::VectorXd w(static_cast<Eigen::Index>(d));
  for (std::size_t j = 0; j < d; ++j) w[Eigen::Index(j)] = fit[j].theta_hi() - fit[j].theta_lo();
  const Eigen::MatrixXd Fu = w.asDiagonal() * F * w.asDiagonal();
  // the covariance in range units, Σ_k (s²/λ_k) v_k v_kᵀ over F's eigenpairs
  // (λ_k ≤ 0, a direction the data do not see, as the smallest positive
  // number: its variance is then far above any range); a parameter whose
  // deviation exceeds half its range is not determined by the data. A
  // Jacobian that is not finite (both neighbours of a parameter failed)
  // determines nothing.
  c.determined.assign(d, true);
  Eigen::MatrixXd cov_u = Eigen::MatrixXd::Zero(Eigen::Index(d), Eigen::Index(d));
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig;
  if (Fu.allFinite()) eig.compute(Fu);
  if (!Fu.allFinite() || eig.info() != Eigen::Success) {
    c.determined.assign(d, false);
  } else {
    const Eigen::VectorXd lam = eig.eigenvalues();
    const Eigen::MatrixXd V = eig.eigenvectors();
    for (Eigen::Index k = 0; k < Eigen::Index(d); ++k)
      cov_u += (s2 / std::max(lam[k], std::numeric_limits<double>::min())) * V.col(k) * V.col(k).transpose();
    for (std::size_t j = 0; j < d; ++j)
      c.determined[j] = cov_u(Eigen::Index(j), Eigen::Index(j)) <= 0.25;
  }
  c.covariance.assign(d, std::vector<double>(d));
  c.theta_sigma.resize(d), c.sigma.resize(d);
  for (std::size_t i = 0; i < d; ++i) {
    for (std::size_t j = 0; j < d; ++j)
      c.covariance[i][j] = c.determined[i] && c.determined[j] ? cov_u(Eigen::Index(i), Eigen::Index(j)) * w[Eigen::Index(i)] * w[Eigen::Index(j)]
                                                              : std::numeric_limits<double>::quiet_NaN();
    c.theta_sigma[i] = std::sqrt(c.covariance[i][i]);
    c.sigma[i] = fit[i].log() ? c.best[i] * c.theta_sigma[i] : c.theta_sigma[i];
  }
  return c;
}

RunResult run_best_fit(const std::string& text, const std::string& source, const Calibration& c,
                       const std::string& output, int threads, const volatile std::sig_atomic_t* interrupt) {
  const std::vector<FitParameter>& fit = c.fit;
  std::vector<Override> best;
  for (std::size_t j = 0; j < fit.size(); ++j) best.push_back({fit[j].key, c.best[j]});
  Scene s = parse_scene(text, source, best);
  s.sim.dt_auto = false, s.sim.dt = c.dt;
  RunOptions ro;
  ro.output = output;
  ro.threads = threads;
  ro.duration = c.duration;
  ro.interrupt = interrupt;
  ro.before_finish = [&](h5::Writer& w, const std::vector<ProbeRecord>&) {
    std::vector<h5::Column> table;
    for (std::size_t j = 0; j < fit.size(); ++j)
      table.push_back({fit[j].key, {c.best[j], c.sigma[j], c.theta_sigma[j], c.determined[j] ? 1.0 : 0.0,
                                    fit[j].value(fit[j].theta_lo()), fit[j].value(fit[j].theta_hi())}});
    w.write_table("calibration", table, "rows", {"value", "sigma", "sigma_theta", "determined", "lo", "hi"});
    std::vector<double> gen(c.history_best.size());
    for (std::size_t g = 0; g < gen.size(); ++g) gen[g] = double(g + 1);
    w.write_table("calibration_history", {{"generation", gen}, {"best_misfit", c.history_best}, {"step", c.history_step}});
  };
  return run_scene(s, ro);
}

std::vector<std::string> calibration_lines(const Calibration& c) {
  std::vector<std::string> out;
  for (std::size_t j = 0; j < c.fit.size(); ++j) {
    char buf[256];
    if (c.determined[j])
      std::snprintf(buf, sizeof buf, "%s = %.6g ± %.2g", c.fit[j].key.c_str(), c.best[j], c.sigma[j]);
    else
      std::snprintf(buf, sizeof buf, "%s = %.6g (not determined by the data: a flat direction of the misfit)",
                    c.fit[j].key.c_str(), c.best[j]);
    out.emplace_back(buf);
  }
  return out;
}

void write_calibration_csv(const std::string& path, const Calibration& c) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) throw SceneError(path + ": cannot write");
    out.precision(17);
    out << "key,value,sigma,determined,lo,hi,misfit\n";
    for (std::size_t j = 0; j < c.fit.size(); ++j)
      out << c.fit[j].key << ',' << c.best[j] << ',' << c.sigma[j] << ',' << (c.determined[j] ? 1 : 0) << ','
          << c.fit[j].value(c.fit[j].theta_lo()) << ',' << c.fit[j].value(c.fit[j].theta_hi()) << ',' << c.misfit << '\n';
    if (!out) {
      out.close();
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
      throw SceneError(path + ": cannot write");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw SceneError(path + ": cannot rename " + tmp + " to it: " + ec.message());
}

}  // namespace manyrods::scene
