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
#include <limits>
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

// A CSV file's header (its first line that is not empty or a # comment):
// the fields, trimmed; ln its line number
std::vector<std::string> csv_header(std::ifstream& in, int& ln) {
  std::string line;
  std::vector<std::string> head;
  while (std::getline(in, line)) {
    ++ln;
    if (trim(line).empty() || trim(line)[0] == '#') continue;
    head = split(line, ',');
    for (std::string& h : head) h = trim(h);
    break;
  }
  return head;
}

// observable,value,sigma (read_measurements): the rows after the header
// `head` (on line ln) of the file `in`
Measurements read_scalars(std::ifstream& in, const std::string& path, const std::vector<std::string>& head, int ln,
                          const Scene& s) {
  if (head.size() != 3 || head[1] != "value" || head[2] != "sigma")
    throw SceneError(path + ":" + std::to_string(ln) +
                     ": a scalars file's header must be observable,value,sigma (sigma: each scalar's noise, in its unit)");
  const std::vector<std::string> columns = observable_columns(s.observables);
  Measurements m;
  m.path = path;
  std::vector<int> first(columns.size(), 0);
  std::string line;
  while (std::getline(in, line)) {
    ++ln;
    if (trim(line).empty() || trim(line)[0] == '#') continue;
    const std::string where = path + ":" + std::to_string(ln);
    const std::vector<std::string> f = split(line, ',');
    if (f.size() != 3) throw SceneError(where + ": " + std::to_string(f.size()) + " columns, the header has 3");
    ScalarMeasurement sm;
    sm.name = trim(f[0]);
    const auto it = std::find(columns.begin(), columns.end(), sm.name);
    if (it == columns.end()) {
      std::string known;
      for (const std::string& c : columns) known += (known.empty() ? "" : ", ") + c;
      throw SceneError(where + ": the scene has no observable '" + sm.name + "' (its [[observables]]: " +
                       (known.empty() ? std::string("none") : known) + ")");
    }
    sm.column = int(it - columns.begin());
    if (first[std::size_t(sm.column)])
      throw SceneError(where + ": observable '" + sm.name + "' given again (first on line " +
                       std::to_string(first[std::size_t(sm.column)]) + ")");
    first[std::size_t(sm.column)] = ln;
    sm.value = finite_number(trim(f[1]), where + ": value");
    sm.sigma = finite_number(trim(f[2]), where + ": sigma");
    if (!(sm.sigma > 0)) throw SceneError(where + ": sigma must be > 0");
    m.scalars.push_back(sm);
  }
  if (m.scalars.empty()) throw SceneError(path + ": no measurements (only a header)");
  return m;
}

Measurements read_csv(const std::string& path, const Scene& s) {
  std::ifstream in(path);
  if (!in) throw SceneError(path + ": cannot open the measurements");
  Measurements m;
  m.path = path;
  std::string line;
  int ln = 0;
  const std::vector<std::string> head = csv_header(in, ln);
  if (!head.empty() && head[0] == "observable") return read_scalars(in, path, head, ln, s);
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
  if (!m.scalars.empty()) return m;
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

Measurements read_measurements(const std::vector<std::string>& paths, const Scene& s) {
  if (paths.empty()) throw SceneError("calibrate: no measurements (give --data FILE)");
  Measurements all;
  std::string tracks_from, scalars_from;
  for (const std::string& p : paths) {
    Measurements m = read_measurements(p, s);
    all.path += (all.path.empty() ? "" : ", ") + p;
    if (!m.scalars.empty()) {
      if (!scalars_from.empty()) throw SceneError(p + ": a second file of scalars (the first: " + scalars_from + "); give one");
      scalars_from = p;
      all.scalars = std::move(m.scalars);
    } else {
      if (!tracks_from.empty()) throw SceneError(p + ": a second file of tracks (the first: " + tracks_from + "); give one");
      tracks_from = p;
      all.time = std::move(m.time);
      all.tracks = std::move(m.tracks);
    }
  }
  return all;
}

// ---- the calibration ------------------------------------------------------------------

namespace {

// One batch of candidates (values [candidate][parameter]): each one's
// simulated positions at the measured times, [track][time][3], and its
// measured scalars (NaN for a candidate whose run failed). Among MPI ranks
// (opt.shards) each runs a contiguous share of the candidates as its batch
// and the shares are gathered: a candidate's run does not depend on the
// others in its batch (one step for all, rods independent), so the result
// is that of one batch.
struct Evaluator {
  const std::string& text;
  const std::string& source;
  const Measurements& data;
  const CalibrateOptions& opt;
  std::vector<std::string> names;
  std::vector<Observable> obs;  // the scene's own, then the tracks' (position, at the measured times)
  int own_columns = 0;          // the scene's observables' columns (the first ones)
  double dt = 0;
  bool dt_auto = false;
  std::string work;  // the batch runs' file
  double duration = 0;

  using Tracks = std::vector<std::vector<std::array<double, 3>>>;
  struct Sim {
    Tracks tracks;
    std::vector<double> scalars;
  };

  // the first refusal's message (a candidate the scene's validation refuses)
  mutable std::string refused;
  // an interrupt (on any rank) stopped the last batch
  mutable bool stopped = false;

  std::size_t values_per_sim() const { return 3 * data.tracks.size() * data.time.size() + data.scalars.size(); }

  std::vector<Sim> run(const std::vector<std::vector<double>>& all) const {
    const Shards& sh = opt.shards;
    if (sh.ranks <= 1) {
      std::vector<Sim> out = run_here(all);
      stopped = opt.interrupt && *opt.interrupt;
      return out;
    }
    const std::size_t n = all.size(), R = std::size_t(sh.ranks), per = values_per_sim();
    if (double(n) * double(per) > double(std::numeric_limits<int>::max()))
      throw SceneError("calibrate: a generation's tracks (" + std::to_string(n) + " candidates x " + std::to_string(per) +
                       " values) exceed what MPI gathers in one call (2^31 - 1 values): measure fewer nodes or times");
    auto lo = [&](std::size_t r) { return n * r / R; };
    const std::size_t r = std::size_t(sh.rank);
    const std::vector<Sim> mine =
        run_here({all.begin() + std::ptrdiff_t(lo(r)), all.begin() + std::ptrdiff_t(lo(r + 1))});
    stopped = !sh.all_ok(!(opt.interrupt && *opt.interrupt));
    if (stopped) return {};
    std::vector<double> flat;
    flat.reserve(mine.size() * per);
    for (const Sim& sim : mine) {
      for (const auto& track : sim.tracks)
        for (const auto& x : track) flat.insert(flat.end(), x.begin(), x.end());
      flat.insert(flat.end(), sim.scalars.begin(), sim.scalars.end());
    }
    std::vector<int> counts(R);
    for (std::size_t q = 0; q < R; ++q) counts[q] = int((lo(q + 1) - lo(q)) * per);
    const std::vector<double> every = sh.all_gather(flat, counts);
    std::vector<Sim> out(n, blank());
    std::size_t i = 0;
    for (Sim& sim : out) {
      for (auto& track : sim.tracks)
        for (auto& x : track)
          for (double& v : x) v = every[i++];
      for (double& v : sim.scalars) v = every[i++];
    }
    return out;
  }

 private:
  Sim blank() const {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    return {Tracks(data.tracks.size(), std::vector<std::array<double, 3>>(data.time.size(), {nan, nan, nan})),
            std::vector<double>(data.scalars.size(), nan)};
  }

  std::vector<Sim> run_here(const std::vector<std::vector<double>>& all) const {
    const std::size_t T = data.time.size();
    std::vector<Sim> out(all.size(), blank());
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
    // the sweep's scene and probes run without its /sweep tables (run_sweep
    // would write a column per track, component and measured time, each a
    // compressed dataset: most of a generation's time, for a file removed
    // here; only the probes are read)
    ro.probes = sw.probes;
    const RunResult r = run_scene(sw.scene, ro);
    std::error_code ec;
    std::filesystem::remove(work, ec);
    for (std::size_t v = 0; v < points.size(); ++v) {
      const ProbeRecord& rec = r.probes[v];
      if (!std::isnan(rec.failed_at)) continue;  // (a failed run: NaN)
      const std::vector<double> val = observed_values(rec.observed);
      Sim& sim = out[index[v]];
      const std::size_t base = std::size_t(own_columns);
      for (std::size_t k = 0; k < data.tracks.size(); ++k)
        for (int a = 0; a < 3; ++a)
          for (std::size_t i = 0; i < T; ++i) sim.tracks[k][i][std::size_t(a)] = val[base + (3 * k + std::size_t(a)) * T + i];
      for (std::size_t q = 0; q < data.scalars.size(); ++q) sim.scalars[q] = val[std::size_t(data.scalars[q].column)];
    }
    return out;
  }
};

// the tracks' noise (σ = 1 m where none is given)
double noise(const Track& t, const CalibrateOptions& opt) {
  if (!std::isnan(t.sigma)) return t.sigma;
  return std::isnan(opt.sigma) ? 1.0 : opt.sigma;
}

// the whitened residuals of a candidate's tracks and scalars against the
// data (finite samples only, in a fixed order: the tracks', then the
// scalars'); NaN entries where the run failed
std::vector<double> residuals(const Evaluator::Sim& sim, const Measurements& data, const CalibrateOptions& opt) {
  std::vector<double> r;
  for (std::size_t k = 0; k < data.tracks.size(); ++k) {
    const double s = noise(data.tracks[k], opt);
    for (std::size_t i = 0; i < data.time.size(); ++i)
      for (int a = 0; a < 3; ++a) {
        const double m = data.tracks[k].x[i][std::size_t(a)];
        if (std::isfinite(m)) r.push_back((sim.tracks[k][i][std::size_t(a)] - m) / s);
      }
  }
  for (std::size_t q = 0; q < data.scalars.size(); ++q)
    r.push_back((sim.scalars[q] - data.scalars[q].value) / data.scalars[q].sigma);
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

// ---- the search's state file (CalibrateOptions::state) --------------------------------

// FNV-1a over what decides the search: the scene text, the fit, the
// measurements, the seed, λ and the default noise (not the budget, the
// tolerance or the threads: a calibration continued with more generations
// or other threads goes on the same search)
std::uint64_t fingerprint(const std::string& text, const Scene& scene, const std::vector<FitParameter>& fit,
                          const Measurements& data, const CalibrateOptions& opt, int lambda) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  auto bytes = [&](const void* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) h = (h ^ static_cast<const unsigned char*>(p)[i]) * 0x100000001b3ull;
  };
  auto str = [&](const std::string& x) { bytes(x.data(), x.size() + 1); };  // (with its end)
  auto num = [&](double x) { bytes(&x, sizeof x); };
  str(text);
  for (const std::string& in : scene.inputs) {  // (its meshes and curves: their contents; the scene's own is the text)
    if (in == scene.source) continue;
    std::ifstream f(in, std::ios::binary);
    std::ostringstream all;
    all << f.rdbuf();
    str(in), str(all.str());
  }
  for (const FitParameter& p : fit) {
    str(p.key);
    const int k = int(p.kind);
    bytes(&k, sizeof k);
    num(p.lo), num(p.hi), num(p.mean), num(p.std);
  }
  for (double t : data.time) num(t);
  for (const Track& t : data.tracks) {
    str(t.name), num(t.sigma);
    for (const auto& x : t.x) num(x[0]), num(x[1]), num(x[2]);
  }
  for (const ScalarMeasurement& m : data.scalars) str(m.name), num(m.value), num(m.sigma);
  bytes(&opt.seed, sizeof opt.seed);
  bytes(&lambda, sizeof lambda);
  num(opt.sigma);
  return h;
}

// The state as text (written to path.tmp, then renamed: a stop while it is
// written leaves the last one whole):
//   manyrods calibrate state 1
//   fingerprint F
//   generations G evaluations E converged 0|1
//   best f u_1 … u_d
//   history f_1 σ_1 … f_G σ_G
//   cmaes …                              (CmaEs::save)
void write_state(const std::string& path, std::uint64_t print, const CmaEs& es, const std::vector<double>& best_u,
                 double best, const Calibration& c) {
  std::string out = "manyrods calibrate state 1\n";
  char buf[96];
  std::snprintf(buf, sizeof buf, "fingerprint %016llx\n", static_cast<unsigned long long>(print));
  out += buf;
  std::snprintf(buf, sizeof buf, "generations %d evaluations %d converged %d\nbest %a", c.generations, c.evaluations,
                int(c.converged), best);
  out += buf;
  for (double u : best_u) std::snprintf(buf, sizeof buf, " %a", u), out += buf;
  out += "\nhistory";
  for (std::size_t g = 0; g < c.history_best.size(); ++g)
    std::snprintf(buf, sizeof buf, " %a %a", c.history_best[g], c.history_step[g]), out += buf;
  out += "\n" + es.save() + "\n";
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary);
    f << out;
    if (!f.flush()) throw SceneError(path + ": cannot write the calibration's state");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw SceneError(path + ": cannot rename " + tmp + " to it: " + ec.message());
}

void read_state(const std::string& path, std::uint64_t print, CmaEs& es, std::vector<double>& best_u, double& best,
                Calibration& c) {
  std::ifstream in(path, std::ios::binary);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  auto bad = [&](const std::string& why) {
    return SceneError(path + ": not the state of a calibration (" + why +
                      "); remove it to start afresh");
  };
  if (lines.size() != 6 || lines[0] != "manyrods calibrate state 1") throw bad("its first line, or its lines");
  unsigned long long f = 0;
  if (std::sscanf(lines[1].c_str(), "fingerprint %llx", &f) != 1) throw bad("line 2");
  if (f != print)
    throw SceneError(path + ": the state of a calibration with other inputs (the scene, the measurements, --fit, "
                            "--seed, --population or --sigma differ); remove it to start afresh, or give those of "
                            "the calibration it continues");
  int conv = 0;
  if (std::sscanf(lines[2].c_str(), "generations %d evaluations %d converged %d", &c.generations, &c.evaluations,
                  &conv) != 3 || c.generations < 1)
    throw bad("line 3");
  std::istringstream b(lines[3]);
  std::string word;
  b >> word;
  auto hex = [&](std::istringstream& is, double& x) {
    std::string t;
    if (!(is >> t)) return false;
    char* end = nullptr;
    x = std::strtod(t.c_str(), &end);
    return end && *end == 0;
  };
  if (word != "best" || !hex(b, best)) throw bad("line 4");
  for (double& u : best_u)
    if (!hex(b, u)) throw bad("line 4");
  std::istringstream hi(lines[4]);
  hi >> word;
  c.history_best.assign(std::size_t(c.generations), 0), c.history_step.assign(std::size_t(c.generations), 0);
  for (int g = 0; g < c.generations; ++g)
    if (!hex(hi, c.history_best[std::size_t(g)]) || !hex(hi, c.history_step[std::size_t(g)])) throw bad("line 5");
  if (word != "history" || !es.restore(lines[5])) throw bad("line 6");
  c.converged = conv != 0;
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
  c.data = data;
  for (const Track& t : data.tracks) c.sigma_given = c.sigma_given || !std::isnan(t.sigma);
  c.sigma_given = c.sigma_given || !std::isnan(opt.sigma);
  // (scalars come with their noise; tracks without would weigh 1 m against it)
  if (!data.scalars.empty() && !data.tracks.empty() && !c.sigma_given)
    throw SceneError(data.path + ": tracks without their noise cannot be weighed against the scalars' (give --sigma, or "
                     "a sigma column)");
  c.sigma_given = c.sigma_given || !data.scalars.empty();
  for (std::size_t j = 0; j < d; ++j) {
    // (a prior weighs against the data in units of their noise: with σ
    // unknown, σ = 1 m would let it outweigh any data in millimetres)
    if (fit[j].prior() && !c.sigma_given)
      throw SceneError("--fit " + fit[j].key + ": a prior needs the measurements' noise (--sigma, or a sigma column)");
    for (std::size_t i = 0; i < j; ++i)
      if (fit[i].key == fit[j].key) throw SceneError("--fit " + fit[j].key + ": given twice");
  }
  // (the scene's own observables only where scalars are measured; the
  // tracks' columns named as no scene's can be: # is not a name character)
  Evaluator ev{text, source, data, opt, {}, {}, 0, 0, base.sim.dt_auto, "", 0, {}, false};
  if (!data.scalars.empty()) ev.obs = base.observables;
  ev.own_columns = int(observable_columns(ev.obs).size());
  for (const FitParameter& p : fit) ev.names.push_back(p.key);
  for (std::size_t k = 0; k < data.tracks.size(); ++k)
    for (int a = 0; a < 3; ++a) {
      Observable o;
      o.name = "#track_" + std::to_string(k) + "_" + "xyz"[a];
      o.quantity = Observable::Quantity::position;
      o.rod = data.tracks[k].rod;
      o.node = data.tracks[k].node;
      o.component = a;
      o.reduce = Observable::Reduce::at;
      o.times = data.time;
      ev.obs.push_back(o);
    }
  // (tracks only: up to their last time; scalars reduce over the whole run)
  ev.duration = data.scalars.empty() && !data.time.empty() ? std::min(base.sim.duration, data.time.back())
                                                           : base.sim.duration;
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

  auto objective = [&](const Evaluator::Sim& sim, const std::vector<double>& theta, double* data_part) {
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
  const std::uint64_t print = fingerprint(text, base, fit, data, opt, es.lambda());
  if (!opt.state.empty() && std::filesystem::exists(opt.state)) {
    read_state(opt.state, print, es, best_u, best, c);
    c.resumed = c.generations;
  }
  // (MPI: every rank must continue from the same generation, or their
  // shares would mix generations: a state that only some ranks see)
  if (opt.shards.ranks > 1 &&
      opt.shards.min_all(double(c.resumed)) != -opt.shards.min_all(-double(c.resumed)))
    throw SceneError(opt.state + ": the MPI ranks do not all see this state file (some continue from it, some "
                     "not): put the output where every rank reads it");
  for (int gen = c.generations; !c.converged && gen < opt.max_generations; ++gen) {
    std::vector<std::vector<double>> u = es.ask();
    for (auto& x : u)
      for (double& v : x) v = reflect_unit(v);
    std::vector<std::vector<double>> pts;
    for (const auto& x : u) pts.push_back(to_values(x));
    const std::vector<Evaluator::Sim> sims = ev.run(pts);
    if (ev.stopped) {
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
    c.converged = es.step() * es.max_axis() < opt.tolerance;
    if (!opt.state.empty() && opt.shards.rank == 0) write_state(opt.state, print, es, best_u, best, c);
    if (opt.on_generation) opt.on_generation(gen + 1, best, es.step());
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
  const std::vector<Evaluator::Sim> sims = ev.run(pts);
  if (ev.stopped) return stopped();  // (during the uncertainty's batch)
  c.best = pts[0];
  c.misfit = objective(sims[0], th, &c.data_misfit);
  c.fitted = sims[0].tracks;
  c.fitted_scalars = sims[0].scalars;
  const std::vector<double> r0 = residuals(sims[0], data, opt);
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
  // s² from the residuals where the noise was not given, over the samples
  // that carry something: one whose residual is exactly zero and that no
  // parameter moves (a coordinate the data and every run leave at the same
  // value, e.g. y of a swing in the xz plane measured from a run) is no
  // degree of freedom, and counted it would shrink s²
  Eigen::Index informative = 0;
  for (Eigen::Index i = 0; i < J.rows(); ++i)
    informative += r0[std::size_t(i)] != 0 || J.row(i).cwiseAbs().maxCoeff() != 0 || !J.row(i).allFinite();
  c.samples = std::int64_t(informative);
  const double dof = double(informative) - double(d);
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

std::string check_calibration_outputs(const std::string& output, const std::string& csv,
                                      std::vector<std::string> inputs, const std::string& output_name,
                                      const std::string& csv_name) {
  check_h5_output(output, inputs, output_name);
  inputs.push_back(output);
  if (!csv.empty()) {
    check_extension(csv, {".csv"}, csv_name, "the fitted parameters (CSV)");
    check_not_input(csv, inputs, csv_name);
    inputs.push_back(csv);
  }
  const std::string state = output + ".calibrate-state";
  check_not_input(state, inputs, "the search's state (beside " + output_name + ")");
  // (written at the end, after the whole calibration: their folders checked now)
  for (const std::string& f : {output, csv}) {
    if (f.empty()) continue;
    const std::filesystem::path dir =
        std::filesystem::path(f).parent_path().empty() ? std::filesystem::path(".") : std::filesystem::path(f).parent_path();
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec))
      throw SceneError(f + ": the folder " + dir.string() + " does not exist (nothing was run)");
    if (std::filesystem::is_directory(f, ec)) throw SceneError(f + ": is a folder, not a file (nothing was run)");
  }
  return state;
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
    const Measurements& m = c.data;
    if (!m.tracks.empty() && c.fitted.size() == m.tracks.size()) {
      std::vector<h5::Column> tracks{{"time", m.time}};
      std::vector<std::string> names;
      for (std::size_t k = 0; k < m.tracks.size(); ++k) {
        names.push_back(m.tracks[k].name);
        for (int a = 0; a < 3; ++a)
          for (const char* which : {"measured", "fitted"}) {
            h5::Column col{std::string(which) + "_" + std::to_string(k) + "_" + "xyz"[a], {}};
            const auto& x = which[0] == 'm' ? m.tracks[k].x : c.fitted[k];
            for (const auto& p : x) col.values.push_back(p[std::size_t(a)]);
            tracks.push_back(std::move(col));
          }
      }
      w.write_table("calibration_tracks", tracks, "tracks", names);
    }
    if (!m.scalars.empty() && c.fitted_scalars.size() == m.scalars.size()) {
      std::vector<h5::Column> sc{{"measured", {}}, {"sigma", {}}, {"fitted", c.fitted_scalars}};
      std::vector<std::string> names;
      for (const ScalarMeasurement& q : m.scalars)
        names.push_back(q.name), sc[0].values.push_back(q.value), sc[1].values.push_back(q.sigma);
      w.write_table("calibration_scalars", sc, "rows", names);
    }
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
