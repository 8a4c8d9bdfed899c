// host/scene/study/sweep.cpp — parameter sweeps (include/manyrods/sweep.h).
#include "manyrods/sweep.h"
#include "setup/static_cache.h"
#include "study/text.h"

#include "manyrods/isa.h"
#include "manyrods/rng.h"

#include <algorithm>
#include <map>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <tuple>
#include <utility>

namespace manyrods::scene {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double parse_number(const std::string& s, const std::string& arg) { return finite_number(s, "--vary " + arg); }


struct Extremum {
  double t, u;
};

// Vertex of the parabola through samples i−1, i, i+1 (their times need not
// be evenly spaced: a sweep samples every 64 steps and at every frame),
// from Newton's divided differences: u(t) = u₀ + d₀₁ (t − t₀) + a (t − t₀)(t − t₁).
Extremum refine(const std::vector<double>& t, const std::vector<double>& u, std::size_t i) {
  if (i == 0 || i + 1 >= u.size()) return {t[i], u[i]};
  const double t0 = t[i - 1], t1 = t[i], t2 = t[i + 1];
  const double d01 = (u[i] - u[i - 1]) / (t1 - t0), d12 = (u[i + 1] - u[i]) / (t2 - t1);
  const double a = (d12 - d01) / (t2 - t0);
  if (a == 0) return {t1, u[i]};
  const double tv = std::clamp(0.5 * (t0 + t1) - d01 / (2 * a), t0, t2);
  return {tv, u[i - 1] + d01 * (tv - t0) + a * (tv - t0) * (tv - t1)};
}

}  // namespace

Vary parse_vary(const std::string& arg) {
  const std::size_t eq = arg.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == arg.size())
    throw SceneError("--vary " + arg +
                     ": expected KEY=lo:hi:n, KEY=lo:hi, KEY=uniform:lo:hi, KEY=normal:mean:std[:lo:hi], "
                     "KEY=lognormal:median:sigma, KEY=v1,v2,... (v@weight allowed) or KEY=v");
  Vary v;
  v.key = arg.substr(0, eq);
  const std::string spec = arg.substr(eq + 1);
  auto numbers = [&](const std::vector<std::string>& p, std::size_t from) {
    std::vector<double> x;
    for (std::size_t i = from; i < p.size(); ++i) x.push_back(parse_number(p[i], arg));
    return x;
  };
  const auto p = split(spec, ':');
  if (p[0] == "uniform") {
    if (p.size() != 3) throw SceneError("--vary " + arg + ": uniform:lo:hi");
    const auto x = numbers(p, 1);
    v.lo = x[0], v.hi = x[1];
    if (!(v.lo <= v.hi)) throw SceneError("--vary " + arg + ": uniform needs lo <= hi");
  } else if (p[0] == "normal") {
    if (p.size() != 3 && p.size() != 5)
      throw SceneError("--vary " + arg + ": normal:mean:std or normal:mean:std:lo:hi (truncated)");
    const auto x = numbers(p, 1);
    v.kind = Vary::Kind::normal;
    v.mean = x[0], v.std = x[1];
    v.lo = p.size() == 5 ? x[2] : -HUGE_VAL;
    v.hi = p.size() == 5 ? x[3] : HUGE_VAL;
    if (!(v.std > 0)) throw SceneError("--vary " + arg + ": the standard deviation must be > 0");
    if (!(v.lo < v.hi)) throw SceneError("--vary " + arg + ": the truncation needs lo < hi");
    const double mass = normal_cdf((v.hi - v.mean) / v.std) - normal_cdf((v.lo - v.mean) / v.std);
    if (!(mass > 1e-12))
      throw SceneError("--vary " + arg + ": [lo, hi] holds no probability of this normal distribution");
  } else if (p[0] == "lognormal") {
    if (p.size() != 3) throw SceneError("--vary " + arg + ": lognormal:median:sigma");
    const auto x = numbers(p, 1);
    v.kind = Vary::Kind::lognormal;
    v.mean = x[0], v.std = x[1];
    if (!(v.mean > 0)) throw SceneError("--vary " + arg + ": the median must be > 0");
    if (!(v.std > 0)) throw SceneError("--vary " + arg + ": sigma (of the log) must be > 0");
  } else if (p.size() > 1) {
    if (p.size() != 2 && p.size() != 3) throw SceneError("--vary " + arg + ": a range is lo:hi or lo:hi:n");
    v.lo = parse_number(p[0], arg);
    v.hi = parse_number(p[1], arg);
    if (p.size() == 3) {
      const double n = parse_number(p[2], arg);
      if (n != std::floor(n) || n < 1 || n > 1e7)
        throw SceneError("--vary " + arg + ": n must be a whole number >= 1");
      v.count = int(n);
      if (v.count == 1 && v.lo != v.hi)
        throw SceneError("--vary " + arg + ": one value over a range; give n >= 2 or a single value");
    }
  } else {
    v.kind = Vary::Kind::list;
    const auto items = split(spec, ',');
    int weighted = 0;
    for (const std::string& item : items) {
      const std::size_t at = item.find('@');
      v.values.push_back(parse_number(item.substr(0, at), arg));
      if (at != std::string::npos) {
        ++weighted;
        const double w = parse_number(item.substr(at + 1), arg);
        if (!(w > 0)) throw SceneError("--vary " + arg + ": weight " + item.substr(at + 1) + " must be > 0");
        v.weights.push_back(w);
      }
    }
    if (weighted != 0 && weighted != int(items.size()))
      throw SceneError("--vary " + arg + ": give a weight (v@w) to every value or to none");
  }
  return v;
}

double Vary::at(double u) const {
  switch (kind) {
    case Kind::uniform:
      return lo + (hi - lo) * u;
    case Kind::normal: {
      // inverse CDF of the (truncated) normal: Φ⁻¹ of u mapped into [Φ(a), Φ(b)]
      const double a = normal_cdf((lo - mean) / std), b = normal_cdf((hi - mean) / std);
      return std::clamp(mean + std * normal_quantile(a + (b - a) * u), lo, hi);
    }
    case Kind::lognormal:
      return mean * std::exp(std * normal_quantile(u));
    case Kind::list:
      break;
  }
  if (weights.empty()) return values[std::min(values.size() - 1, std::size_t(u * double(values.size())))];
  double total = 0;
  for (double w : weights) total += w;
  double cum = 0;
  for (std::size_t i = 0; i + 1 < values.size(); ++i) {
    cum += weights[i];
    if (u * total < cum) return values[i];
  }
  return values.back();
}

std::vector<std::vector<double>> sweep_points(const std::vector<Vary>& vary, int samples,
                                              std::uint64_t seed) {
  return sweep_points(vary, make_design("", samples, seed));
}

std::vector<std::vector<double>> sweep_points(const std::vector<Vary>& vary, const Design& design) {
  std::vector<std::vector<double>> pts;
  if (vary.empty()) throw SceneError("sweep: give at least one --vary");
  if (design.kind != DesignKind::grid) {
    pts = unit_points(design, int(vary.size()));
    for (auto& row : pts)
      for (std::size_t d = 0; d < vary.size(); ++d) row[d] = vary[d].at(row[d]);
    return pts;
  }
  std::vector<std::vector<double>> lists;
  for (const Vary& v : vary) {
    if (v.kind == Vary::Kind::list) {
      if (!v.weights.empty())
        throw SceneError("--vary " + v.key + ": weights need a sampled design (--samples N, --design mc|lhs|sobol)");
      lists.push_back(v.values);
    } else if (v.kind != Vary::Kind::uniform) {
      throw SceneError("--vary " + v.key + ": a distribution needs a sampled design (--samples N, --design mc|lhs|sobol)");
    } else {
      if (v.count == 0)
        throw SceneError("--vary " + v.key + "=" + std::to_string(v.lo) + ":" + std::to_string(v.hi) +
                         ": a range without n needs --samples N (random sampling)");
      std::vector<double> l;
      for (int i = 0; i < v.count; ++i)
        l.push_back(v.count == 1 ? v.lo : v.lo + (v.hi - v.lo) * double(i) / double(v.count - 1));
      lists.push_back(std::move(l));
    }
  }
  std::size_t total = 1;
  for (const auto& l : lists) {
    total *= l.size();
    if (total > 10'000'000) throw SceneError("sweep: more than 10 million variations");
  }
  for (std::size_t i = 0; i < total; ++i) {
    std::vector<double> row(lists.size());
    std::size_t k = i;
    for (std::size_t d = lists.size(); d-- > 0;) {  // the last --vary varies fastest
      row[d] = lists[d][k % lists[d].size()];
      k /= lists[d].size();
    }
    pts.push_back(std::move(row));
  }
  return pts;
}

Sweep make_sweep(const std::string& text, const std::string& source, const std::vector<Vary>& vary,
                 const Design& design) {
  std::vector<std::string> names;
  for (const Vary& v : vary) names.push_back(v.key);
  Sweep sw = make_sweep(text, source, std::move(names), sweep_points(vary, design));
  if (design.kind == DesignKind::saltelli) sw.sensitivity_base = design.samples;
  return sw;
}

Sweep make_sweep(const std::string& text, const std::string& source, const std::vector<Vary>& vary,
                 int samples, std::uint64_t seed) {
  return make_sweep(text, source, vary, make_design("", samples, seed));
}

Sweep sweep_of_checkpoint(const h5::Checkpoint& c, const std::string& path) {
  std::vector<std::string> names;
  std::vector<std::vector<double>> points(c.sweep_first_rod.size());
  for (const h5::Column& col : c.sweep_parameters) {
    names.push_back(col.name);
    for (std::size_t i = 0; i < points.size(); ++i) points[i].push_back(col.values[i]);
  }
  Sweep sw = make_sweep(c.scene_text, path + ":/scene", std::move(names), std::move(points));
  sw.sensitivity_base = c.sweep_sensitivity_base;
  for (std::size_t i = 0; i < c.sweep_first_rod.size(); ++i)
    if (sw.first_rod[i] != c.sweep_first_rod[i])
      throw SceneError(path + ": variation " + std::to_string(i) + " starts at rod " +
                       std::to_string(c.sweep_first_rod[i]) + " in the file but at rod " +
                       std::to_string(sw.first_rod[i]) + " when rebuilt (a damaged file?)");
  return sw;
}

Sweep make_sweep(const std::string& text, const std::string& source, std::vector<std::string> names,
                 std::vector<std::vector<double>> points) {
  Sweep sw;
  sw.names = std::move(names);
  sw.points = std::move(points);
  const std::vector<std::string>& keys = sw.names;
  sw.scene.source = source;
  sw.scene.text = text;
  sw.first_rod.push_back(0);
  for (std::size_t i = 0; i < sw.points.size(); ++i) {
    std::vector<Override> ov;
    for (std::size_t d = 0; d < keys.size(); ++d) ov.push_back({keys[d], sw.points[i][d]});
    Scene s;
    try {
      s = parse_scene(text, source, ov);
    } catch (const SceneError& e) {
      std::ostringstream os;
      os.precision(10);
      os << e.what() << " (variation " << i << ":";
      for (std::size_t d = 0; d < keys.size(); ++d) os << " " << keys[d] << "=" << sw.points[i][d];
      os << ")";
      throw SceneError(os.str());
    }
    if (i == 0) {
      sw.scene.sim = s.sim;
      sw.scene.inputs = s.inputs;
      sw.scene.observables = s.observables;  // (the same in every variation: only numbers are varied)
      for (const std::string& col : observable_columns(s.observables))
        for (const std::vector<std::string>* taken : {&sweep_summary_names(), &keys})
          if (std::find(taken->begin(), taken->end(), col) != taken->end())
            throw SceneError(source + ": observables: \"" + col + "\" is the name of a " +
                             (taken == &keys ? "varied parameter" : "summary column") + " already; give it another name");
    }
    // colliders touch each variation's rods alone; rod–rod contact would let
    // the variations (one batch, the same place) touch each other
    if (s.contact.rod_rod || s.contact.self)
      throw SceneError(source + ": contact.rod_rod/self: a sweep runs its variations in one batch, where they "
                                "would touch each other; sweep this scene without rod-rod contact, or run each "
                                "variation with `manyrods run`");
    if (s.has_contact) {
      const std::vector<Friction> rf = sw.scene.contact.rod_friction;
      const std::vector<char> rh = sw.scene.contact.rod_has_friction;
      sw.scene.contact = s.contact;
      sw.scene.contact.rod_friction.insert(sw.scene.contact.rod_friction.begin(), rf.begin(), rf.end());
      sw.scene.contact.rod_has_friction.insert(sw.scene.contact.rod_has_friction.begin(), rh.begin(), rh.end());
      sw.scene.has_contact = true;
    }
    const int group0 = int(sw.scene.groups.size()), rod0 = int(sw.scene.rods.size());
    std::string suffix = std::to_string(i);
    suffix.insert(suffix.begin(), '@');  // not "@" + …: GCC 12 false -Wrestrict (bug 105329)
    for (RodGroup g : s.groups) {
      g.first_rod += rod0;
      g.name.append(suffix);
      sw.scene.groups.push_back(g);
    }
    for (std::size_t r = 0; r < s.rods.size(); ++r) {
      s.rods[r].name.append(suffix);
      sw.scene.rods.push_back(std::move(s.rods[r]));
      sw.scene.rod_group.push_back(group0 + s.rod_group[r]);
    }
    sw.first_rod.push_back(int(sw.scene.rods.size()));
    sw.probes.push_back({rod0, rod0, int(sw.scene.rods.size())});
    if (sw.scene.rods.size() > std::size_t(std::numeric_limits<int>::max() / 2))
      throw SceneError(source + ": the sweep has too many rods (run it in chunks: --chunk N)");
  }
  try {
    check_batch_size(sw.scene);
  } catch (const SceneError& e) {  // how many variations would fit in half of the memory
    const double per = double(estimated_batch_bytes(sw.scene)) / double(sw.points.size());
    const double fit = std::floor(0.5 * double(physical_memory()) / per);
    throw SceneError(std::string(e.what()) + "; run the sweep in chunks: --chunk " +
                     std::to_string(static_cast<long long>(std::clamp(fit, 1.0, 1e6))) +
                     " (variations that fit in half of it)");
  }
  return sw;
}

namespace {
// Slope of y against x by least squares and its standard error (NaN with
// fewer than three points).
std::pair<double, double> fit_slope(const std::vector<double>& x, const std::vector<double>& y) {
  const double m = double(x.size());
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < x.size(); ++i) mx += x[i] / m, my += y[i] / m;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
  const double slope = sxy / sxx;
  if (x.size() < 3) return {slope, kNaN};
  double ssr = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = y[i] - my - slope * (x[i] - mx);
    ssr += r * r;
  }
  return {slope, std::sqrt(ssr / (m - 2) / sxx)};
}
}  // namespace

Oscillation analyse_oscillation(const std::vector<double>& t, const std::vector<double>& u, double small) {
  // Turning points with hysteresis (Billauer's peak detection): a maximum
  // counts once the signal has fallen below it by a fifth of the last
  // swing (max − min), a minimum once it has risen by as much, so that the
  // ripples of higher modes riding on the fundamental are not taken for
  // its peaks; the first swing's threshold is a fifth of the whole range.
  // End samples are not turning points.
  std::vector<Extremum> maxima, minima;
  if (u.size() < 3) return {kNaN, kNaN, 0, kNaN, kNaN};
  double delta = 0.2 * (*std::max_element(u.begin(), u.end()) - *std::min_element(u.begin(), u.end()));
  std::size_t imax = 0, imin = 0;
  bool want_max = u[1] >= u[0];  // rising: the next turning point is a maximum
  for (std::size_t i = 1; i < u.size(); ++i) {
    if (u[i] > u[imax]) imax = i;
    if (u[i] < u[imin]) imin = i;
    if (want_max && u[i] < u[imax] - delta) {
      if (imax > 0) maxima.push_back(refine(t, u, imax));
      if (!minima.empty() && !maxima.empty()) delta = 0.2 * (maxima.back().u - minima.back().u);
      want_max = false;
      imin = i;
    } else if (!want_max && u[i] > u[imin] + delta) {
      if (imin > 0) minima.push_back(refine(t, u, imin));
      if (!minima.empty() && !maxima.empty()) delta = 0.2 * (maxima.back().u - minima.back().u);
      want_max = true;
      imax = i;
    }
  }
  // peak-to-peak amplitude of each maximum with the minimum that follows it
  std::vector<Extremum> pp;
  std::size_t j = 0;
  for (const Extremum& m : maxima) {
    while (j < minima.size() && minima[j].t <= m.t) ++j;
    if (j == minima.size()) break;
    pp.push_back({m.t, m.u - minima[j].u});
  }
  Oscillation o{kNaN, kNaN, 0, kNaN, kNaN};
  if (pp.empty()) return o;
  // the small-amplitude window: from the first cycle at most a quarter of the
  // first one's amplitude (or below `small`) down to 1 % of the first
  const double top = std::max(0.25 * pp[0].u, small);
  std::size_t first = 0;
  while (first < pp.size() && pp[first].u > top) ++first;
  std::size_t last = first;
  while (last + 1 < pp.size() && pp[last + 1].u > 0.01 * pp[0].u) ++last;
  if (first >= pp.size() || last < first + 2) return o;  // fewer than three peaks: no estimate
  std::vector<double> k, tk, lp;
  for (std::size_t i = first; i <= last; ++i) {
    k.push_back(double(i));
    tk.push_back(pp[i].t);
    lp.push_back(std::log(pp[i].u));
  }
  o.cycles = int(last - first);
  std::tie(o.period, o.period_err) = fit_slope(k, tk);
  auto [slope, slope_err] = fit_slope(k, lp);
  const double decrement = -slope, four_pi2 = 4 * std::numbers::pi * std::numbers::pi;
  o.damping_ratio = decrement / std::sqrt(four_pi2 + decrement * decrement);
  o.damping_ratio_err = slope_err * four_pi2 / std::pow(four_pi2 + decrement * decrement, 1.5);
  return o;
}

std::vector<h5::Column> sweep_parameters(const Sweep& sw) {
  std::vector<h5::Column> cols;
  for (std::size_t d = 0; d < sw.names.size(); ++d) {
    h5::Column c{sw.names[d], {}};
    for (const auto& p : sw.points) c.values.push_back(p[d]);
    cols.push_back(std::move(c));
  }
  return cols;
}

namespace {
// run_sweep, the batch's static states taken from `cache` where it has them.
SweepRun run_sweep_cached(const Sweep& sw, RunOptions opt, const h5::Checkpoint* restart, StaticCache* cache) {
  SweepRun out;
  opt.probes = sw.probes;
  out.parameters = sweep_parameters(sw);
  opt.before_finish = [&](h5::Writer& w, const std::vector<ProbeRecord>& rec) {
    out.summary = sweep_summary(sw, rec);
    out.statistics = sweep_statistics(out.summary);
    std::vector<std::int32_t> first(sw.first_rod.begin(), sw.first_rod.end() - 1);
    w.write_sweep(out.parameters, out.summary, first, sw.sensitivity_base);
    w.add_sweep_table("statistics", out.statistics, "statistics", sweep_statistic_names());
    if (sw.sensitivity_base > 0) {
      out.sensitivity = sweep_sensitivity(out.summary, sw.sensitivity_base, int(sw.names.size()));
      w.add_sweep_table("sensitivity", out.sensitivity, "indices", sensitivity_names(sw.names));
    }
  };
  out.run = run_scene(sw.scene, opt, restart, cache);
  return out;
}
}  // namespace

SweepRun run_sweep(const Sweep& sw, RunOptions opt, const h5::Checkpoint* restart) {
  return run_sweep_cached(sw, std::move(opt), restart, nullptr);
}

const std::vector<std::string>& sweep_summary_names() {
#define MANYRODS_SUMMARY_NAME(name, error, doc) #name,
  static const std::vector<std::string> names = {MANYRODS_SWEEP_SUMMARY(MANYRODS_SUMMARY_NAME)};
#undef MANYRODS_SUMMARY_NAME
  return names;
}

const std::string& sweep_error_column(const std::string& name) {
#define MANYRODS_SUMMARY_ERROR(column, error, doc) {#column, error},
  static const std::map<std::string, std::string> errors = {MANYRODS_SWEEP_SUMMARY(MANYRODS_SUMMARY_ERROR)};
#undef MANYRODS_SUMMARY_ERROR
  static const std::string none;
  const auto it = errors.find(name);
  return it == errors.end() ? none : it->second;
}

bool is_sweep_error_column(const std::string& name) {
#define MANYRODS_SUMMARY_IS_ERROR(column, error, doc) (name == error) ||
  return !name.empty() && (MANYRODS_SWEEP_SUMMARY(MANYRODS_SUMMARY_IS_ERROR) false);
#undef MANYRODS_SUMMARY_IS_ERROR
}

namespace {
// One variation's built-in summary values, a member per column.
struct SummaryRow {
#define MANYRODS_SUMMARY_MEMBER(name, error, doc) double name = kNaN;
  MANYRODS_SWEEP_SUMMARY(MANYRODS_SUMMARY_MEMBER)
#undef MANYRODS_SUMMARY_MEMBER
};
// Appends a row to the built-in columns (the first of c, in list order).
void append_row(std::vector<h5::Column>& c, const SummaryRow& row) {
  std::size_t k = 0;
#define MANYRODS_SUMMARY_APPEND(name, error, doc) c[k++].values.push_back(row.name);
  MANYRODS_SWEEP_SUMMARY(MANYRODS_SUMMARY_APPEND)
#undef MANYRODS_SUMMARY_APPEND
}
}  // namespace

std::vector<h5::Column> sweep_summary(const Sweep& sw, const std::vector<ProbeRecord>& rec) {
  std::vector<h5::Column> c;
  for (const std::string& n : sweep_summary_names()) c.push_back({n, {}});
  const std::size_t builtin = c.size();
  for (const std::string& n : observable_columns(sw.scene.observables)) c.push_back({n, {}});
  for (std::size_t i = 0; i < rec.size(); ++i) {
    const ProbeRecord& r = rec[i];
    const Vec3 rest = sw.scene.rods[sw.probes[i].tip_rod].nodes.back();
    auto dist = [](const Vec3& a, const Vec3& b) {
      return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                       (a[2] - b[2]) * (a[2] - b[2]));
    };
    double dmax = 0;
    for (const Vec3& x : r.tip) dmax = std::max(dmax, dist(x, rest));
    // oscillation of the tip about its final position, along the initial offset
    // (or, when it starts there, along its largest excursion)
    const Vec3& end = r.tip.back();
    Vec3 far = r.tip.front();
    if (dist(far, end) == 0)
      for (const Vec3& x : r.tip)
        if (dist(x, end) > dist(far, end)) far = x;
    const Vec3 dir{far[0] - end[0], far[1] - end[1], far[2] - end[2]};
    const double nd = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    Oscillation o{kNaN, kNaN, 0, kNaN, kNaN};
    if (nd > 0) {
      std::vector<double> u;
      for (const Vec3& x : r.tip)
        u.push_back(((x[0] - end[0]) * dir[0] + (x[1] - end[1]) * dir[1] + (x[2] - end[2]) * dir[2]) / nd);
      // peak to peak below 10 % of the rod's length is small in any case
      const std::vector<Vec3>& nodes = sw.scene.rods[sw.probes[i].tip_rod].nodes;
      double length = 0;
      for (std::size_t k = 1; k < nodes.size(); ++k) length += dist(nodes[k], nodes[k - 1]);
      o = analyse_oscillation(r.time, u, 0.1 * length);
    }
    SummaryRow row;
    row.tip_deflection_initial_m = dist(r.tip.front(), rest);
    row.tip_deflection_max_m = dmax;
    row.tip_deflection_final_m = dist(r.tip.back(), rest);
    row.period_s = o.period;
    row.period_err_s = o.period_err;
    row.damping_ratio = o.damping_ratio;
    row.damping_ratio_err = o.damping_ratio_err;
    row.cycles = o.cycles;
    row.energy_final_J = r.final_energy.total();
    row.dissipated_J = r.dissipated;
    row.max_strain = r.max_strain;
    row.failed_at_s = r.failed_at;
    append_row(c, row);
    const std::vector<double> observed = observed_values(r.observed);
    for (std::size_t k = builtin; k < c.size(); ++k) c[k].values.push_back(observed[k - builtin]);
    if (std::isfinite(r.failed_at))  // frozen since: no observable of it means anything
      for (h5::Column& col : c)
        if (col.name != "failed_at_s") col.values.back() = kNaN;
  }
  return c;
}

const std::vector<std::string>& sweep_statistic_names() {
  static const std::vector<std::string> names = {"n",      "nan",    "mean", "std", "mean_se", "mean_ci95_lo",
                                                 "mean_ci95_hi", "min", "q05",  "q25", "median",  "q75",
                                                 "q95",    "max"};
  return names;
}

std::vector<h5::Column> sweep_statistics(const std::vector<h5::Column>& summary) {
  std::vector<h5::Column> out;
  for (const h5::Column& c : summary) {
    std::vector<double> x;
    for (double v : c.values)
      if (std::isfinite(v)) x.push_back(v);
    std::sort(x.begin(), x.end());
    const double n = double(x.size());
    double mean = kNaN, sd = kNaN, se = kNaN;
    if (!x.empty()) {
      mean = 0;
      for (double v : x) mean += v;
      mean /= n;
    }
    if (x.size() > 1) {
      double ss = 0;
      for (double v : x) ss += (v - mean) * (v - mean);
      sd = std::sqrt(ss / (n - 1));
      se = sd / std::sqrt(n);
    }
    auto quantile = [&](double p) {  // type 7: x[(n − 1)p], linear between neighbours
      if (x.empty()) return kNaN;
      const double h = (n - 1) * p;
      const std::size_t lo = std::size_t(std::floor(h));
      const std::size_t hi = std::min(lo + 1, x.size() - 1);
      return x[lo] + (h - double(lo)) * (x[hi] - x[lo]);
    };
    constexpr double z = 1.959963984540054;  // Φ⁻¹(0.975)
    out.push_back({c.name,
                   {n, double(c.values.size()) - n, mean, sd, se, mean - z * se, mean + z * se, quantile(0),
                    quantile(0.05), quantile(0.25), quantile(0.5), quantile(0.75), quantile(0.95), quantile(1)}});
  }
  return out;
}

namespace {
// Writes path.tmp with `body`, then renames it to path (a reader never sees
// half a file).
template <class Body>
void write_file(const std::string& path, Body&& body) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) throw SceneError(path + ": cannot write the CSV file");
    out.precision(10);
    body(out);
    if (!out) throw SceneError(path + ": error writing the CSV file");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw SceneError(path + ": cannot rename " + tmp + " to it: " + ec.message());
}
}  // namespace

std::vector<std::string> sensitivity_names(const std::vector<std::string>& parameters) {
  std::vector<std::string> n;
  for (const char* kind : {"S1", "ST"})
    for (const std::string& p : parameters) n.push_back(std::string(kind) + " " + p);
  return n;
}

std::vector<h5::Column> sweep_sensitivity(const std::vector<h5::Column>& summary, int base, int dims) {
  const std::size_t n = std::size_t(base), d = std::size_t(dims);
  std::vector<h5::Column> out;
  for (const h5::Column& c : summary) {
    const std::vector<double>& f = c.values;
    h5::Column col{c.name, std::vector<double>(2 * d, kNaN)};
    if (f.size() != n * (d + 2)) {
      out.push_back(std::move(col));
      continue;
    }
    double m = 0, m2 = 0;
    int cnt = 0;
    for (std::size_t k = 0; k < 2 * n; ++k)
      if (std::isfinite(f[k])) m += f[k], m2 += f[k] * f[k], ++cnt;
    const double mean = cnt > 0 ? m / cnt : kNaN;
    const double var = cnt > 1 ? (m2 - cnt * mean * mean) / (cnt - 1) : kNaN;
    for (std::size_t i = 0; i < d; ++i) {
      double s1 = 0, st = 0;
      int used = 0;
      for (std::size_t k = 0; k < n; ++k) {
        const double fa = f[k], fb = f[n + k], fab = f[(2 + i) * n + k];
        if (!(std::isfinite(fa) && std::isfinite(fb) && std::isfinite(fab))) continue;
        s1 += (fb - mean) * (fab - fa);  // (centred: the mean's square would otherwise dominate the noise)
        st += (fa - fab) * (fa - fab);
        ++used;
      }
      if (used > 0 && var > 0) {
        col.values[i] = s1 / used / var;
        col.values[d + i] = st / used / (2 * var);
      }
    }
    out.push_back(std::move(col));
  }
  return out;
}

void write_sensitivity_csv(const std::string& path, const std::vector<h5::Column>& sensitivity,
                           const std::vector<std::string>& parameters) {
  write_file(path, [&](std::ostream& out) {
    out << "observable,parameter,S1,ST\n";
    const std::size_t d = parameters.size();
    for (const h5::Column& c : sensitivity)
      for (std::size_t i = 0; i < d; ++i) out << c.name << ',' << parameters[i] << ',' << c.values[i] << ',' << c.values[d + i] << '\n';
  });
}

void write_statistics_csv(const std::string& path, const std::vector<h5::Column>& statistics) {
  write_file(path, [&](std::ostream& out) {
    out << "observable";
    for (const std::string& n : sweep_statistic_names()) out << ',' << n;
    out << '\n';
    for (const h5::Column& c : statistics) {
      out << c.name;
      for (double v : c.values) out << ',' << v;
      out << '\n';
    }
  });
}

void write_csv(const std::string& path, const std::vector<h5::Column>& parameters,
               const std::vector<h5::Column>& summary) {
  write_file(path, [&](std::ostream& out) {
    out << "variation";
    for (const auto* cols : {&parameters, &summary})
      for (const h5::Column& c : *cols) out << ',' << c.name;
    out << '\n';
    const std::size_t n = parameters.empty() ? 0 : parameters[0].values.size();
    for (std::size_t i = 0; i < n; ++i) {
      out << i;
      for (const auto* cols : {&parameters, &summary})
        for (const h5::Column& c : *cols) out << ',' << c.values[i];
      out << '\n';
    }
  });
}

namespace {
// (with the initial state, as the run resolves it: stable_dt reads the
// state, e.g. a static deflection under initial loads)
template <class T>
double auto_dt(const Scene& s, StaticCache& cache) {
  return scene_dt(s, build_scene_batch<T>(s, true, &cache));
}
double sweep_dt(const Scene& s, StaticCache& cache) {
  return s.sim.precision == Precision::float32 ? auto_dt<float>(s, cache) : auto_dt<double>(s, cache);
}

using OnChunk = std::function<void(int, int, const RunResult*)>;

// A chunked sweep under way: its variations in chunks of `size`, a file per
// chunk in `dir`, and each chunk's columns once run or read back.
struct Chunks {
  const std::string& text;
  const std::string& source;
  const std::vector<std::string>& names;
  const std::vector<std::vector<double>>& points;
  std::size_t size;
  const Shards& shards;
  ChunkedSweep& out;
  std::filesystem::path dir;
  std::vector<std::vector<h5::Column>> par, sum;

  std::vector<std::vector<double>> points_of(int k) const {
    const std::size_t n = points.size();
    const std::size_t a = std::size_t(k) * size, b = std::min(n, a + size);
    return std::vector<std::vector<double>>(points.begin() + std::ptrdiff_t(a), points.begin() + std::ptrdiff_t(b));
  }
  bool mine(int k) const { return k % shards.ranks == shards.rank; }
  const std::string& file(int k) const { return out.chunk_files[std::size_t(k)]; }
  double read_back(int k);
};

// The chunks' folder (created), their number and their files' names.
void plan_chunks(Chunks& c, const std::string& output) {
  const std::size_t n = c.points.size();
  c.out.chunks = int((n + c.size - 1) / c.size);
  c.dir = output + ".chunks";
  std::error_code ec;
  std::filesystem::create_directories(c.dir, ec);
  if (ec) throw SceneError(output + ": cannot create " + c.dir.string() + ": " + ec.message());
  for (int k = 0; k < c.out.chunks; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "chunk-%05d.h5", k);
    c.out.chunk_files.push_back((c.dir / name).string());
  }
  c.par.resize(std::size_t(c.out.chunks));
  c.sum.resize(std::size_t(c.out.chunks));
}

// a finished chunk's file, read back (SceneError when it holds other
// variations); returns the step it ran with
double Chunks::read_back(int k) {
  const std::vector<std::vector<double>> pts = points_of(k);
  const h5::Reader rd(file(k));
  const h5::Output& o = rd.output();
  bool same = o.has_sweep && o.sweep_parameters.size() == names.size();
  for (std::size_t d = 0; same && d < names.size(); ++d) {
    same = o.sweep_parameters[d].name == names[d] && o.sweep_parameters[d].values.size() == pts.size();
    for (std::size_t i = 0; same && i < pts.size(); ++i) same = o.sweep_parameters[d].values[i] == pts[i][d];
  }
  if (!same)
    throw SceneError(file(k) + ": holds other variations than chunk " + std::to_string(k) +
                     " of this sweep (another sweep's chunks? remove " + dir.string() + " to start anew)");
  par[std::size_t(k)] = o.sweep_parameters;
  sum[std::size_t(k)] = o.sweep_summary;
  return o.dt;
}

// one dt for all chunks: the scene's, or the smallest auto step over them
// (each process resolves its own chunks', then the minimum over all)
double common_dt(Chunks& c, const Scene& base, StaticCache& statics) {
  if (!base.sim.dt_auto) return base.sim.dt;
  double local = HUGE_VAL;
  std::error_code ec;
  for (int k = 0; k < c.out.chunks; ++k) {
    if (!c.mine(k)) continue;
    // a finished chunk ran with the common step: its file says which
    // (the minimum over all chunks), no need to solve its statics again
    if (std::filesystem::exists(c.file(k), ec)) {
      local = std::min(local, c.read_back(k));  // (SceneError for another sweep's chunk)
    } else {
      local = std::min(local, sweep_dt(make_sweep(c.text, c.source, c.names, c.points_of(k)).scene, statics));
    }
  }
  return c.shards.min_all(local);
}

// Runs chunk k into its file (written as file.part, renamed when finished);
// false when it was stopped (Ctrl-C).
bool run_chunk(Chunks& c, int k, const Scene& base, double dt, const RunOptions& opt, StaticCache& statics,
               const OnChunk& on_chunk) {
  const std::string& file = c.file(k);
  Sweep sw = make_sweep(c.text, c.source, c.names, c.points_of(k));
  if (base.sim.dt_auto) {
    sw.scene.sim.dt_auto = false;
    sw.scene.sim.dt = dt;
  }
  RunOptions o = opt;
  o.output = file + ".part";
  SweepRun r = run_sweep_cached(sw, o, nullptr, &statics);
  if (on_chunk) on_chunk(k, c.out.chunks, &r.run);
  if (r.run.interrupted) return false;
  std::error_code ec;
  std::filesystem::rename(o.output, file, ec);
  if (ec) throw SceneError(file + ": cannot rename " + o.output + " to it: " + ec.message());
  c.par[std::size_t(k)] = std::move(r.parameters);
  c.sum[std::size_t(k)] = std::move(r.summary);
  return true;
}

// This process's chunks, each run or (finished before) read back; false
// when one was stopped (the chunks after it are not run).
bool run_chunks(Chunks& c, const Scene& base, double dt, const RunOptions& opt, StaticCache& statics,
                const OnChunk& on_chunk) {
  std::error_code ec;
  for (int k = 0; k < c.out.chunks; ++k) {
    if (!c.mine(k)) continue;
    if (std::filesystem::exists(c.file(k), ec)) {  // finished before (read back already by the dt pass, if any)
      if (c.par[std::size_t(k)].empty()) c.read_back(k);
      ++c.out.reused;
      if (on_chunk) on_chunk(k, c.out.chunks, nullptr);
      continue;
    }
    if (!run_chunk(c, k, base, dt, opt, statics, on_chunk)) return false;
  }
  return true;
}

// All chunks' columns as one sweep's (out.result), and the index's chunk
// files (relative to its folder) with the first variation of each.
void merge_chunks(Chunks& c, h5::SweepIndex& index) {
  namespace fs = std::filesystem;
  std::vector<h5::Column>& parameters = c.out.result.parameters;
  std::vector<h5::Column>& summary = c.out.result.summary;
  index.chunk_first.push_back(0);
  for (int k = 0; k < c.out.chunks; ++k) {
    const auto& p = c.par[std::size_t(k)];
    const auto& s = c.sum[std::size_t(k)];
    if (k == 0) {
      parameters = p;
      summary = s;
    } else {
      for (std::size_t col = 0; col < p.size(); ++col)
        parameters[col].values.insert(parameters[col].values.end(), p[col].values.begin(), p[col].values.end());
      for (std::size_t col = 0; col < s.size(); ++col)
        summary[col].values.insert(summary[col].values.end(), s[col].values.begin(), s[col].values.end());
    }
    index.chunk_files.push_back((fs::path(c.dir.filename()) / fs::path(c.file(k)).filename()).string());
    index.chunk_first.push_back(index.chunk_first.back() + std::int64_t(p.empty() ? 0 : p[0].values.size()));
  }
}

// the chunk files' frames as one sweep's (virtual datasets), when every
// chunk has the same frames (it has: the same dt and schedule)
void index_frames(const Chunks& c, const Scene& base, h5::SweepIndex& index) {
  index.float32 = base.sim.precision == Precision::float32;
  index.directors = base.sim.output_directors;
  index.node_offsets.push_back(0);
  index.element_offsets.push_back(0);
  for (int k = 0; k < c.out.chunks; ++k) {
    const h5::Reader rd(c.file(k));
    const h5::Output& o = rd.output();
    if (k == 0) index.time = o.time;
    if (o.time != index.time) {
      index.chunk_nodes.clear();
      break;
    }
    for (std::size_t r = 1; r < o.node_offsets.size(); ++r) {
      index.node_offsets.push_back(index.node_offsets.back() + o.node_offsets[r] - o.node_offsets[r - 1]);
      index.element_offsets.push_back(index.element_offsets.back() + o.element_offsets[r] - o.element_offsets[r - 1]);
    }
    index.chunk_nodes.push_back(o.node_offsets.back());
    index.chunk_elements.push_back(o.element_offsets.back());
  }
}

// The index of a complete sweep (at `output`): all variations' columns,
// their statistics and sensitivity indices, and the chunks' frames.
void write_index(Chunks& c, const Scene& base, double dt, int sensitivity_base, const std::string& output) {
  h5::SweepIndex index;
  merge_chunks(c, index);
  SweepRun& all = c.out.result;
  all.statistics = sweep_statistics(all.summary);
  if (sensitivity_base > 0) {
    all.sensitivity = sweep_sensitivity(all.summary, sensitivity_base, int(c.names.size()));
    index.sensitivity = all.sensitivity;
    index.sensitivity_names = sensitivity_names(c.names);
  }
  index.parameters = all.parameters;
  index.summary = all.summary;
  index.statistics = all.statistics;
  index.statistic_names = sweep_statistic_names();
  index.scene_text = c.text;
  index.scene_source = c.source;
  index.dt = dt;
  index_frames(c, base, index);
  h5::write_sweep_index(output, index);
}
}  // namespace

ChunkedSweep run_sweep_chunked(const std::string& text, const std::string& source, std::vector<std::string> names,
                               std::vector<std::vector<double>> points, int chunk, RunOptions opt,
                               const std::function<void(int, int, const RunResult*)>& on_chunk, const Shards& shards,
                               int sensitivity_base) {
  if (chunk < 1) throw SceneError("sweep: --chunk must be >= 1");
  if (opt.until >= 0)
    throw SceneError("sweep: --until does not apply to a chunked sweep (Ctrl-C stops it; run it again to continue)");
  if (shards.ranks < 1 || shards.rank < 0 || shards.rank >= shards.ranks) throw SceneError("sweep: bad shard rank");
  ChunkedSweep out;
  const Scene base = parse_scene(text, source);
  check_h5_output(opt.output, base.inputs, "output");
  Chunks c{text, source, names, points, std::size_t(chunk), shards, out, {}, {}, {}};
  plan_chunks(c, opt.output);
  // (the static states the dt pass solves are kept for the chunks' runs, up
  // to 1 GiB: 4.9 kB per variation of the seed cantilever)
  StaticCache statics;
  const double dt = common_dt(c, base, statics);
  const bool stopped = !run_chunks(c, base, dt, opt, statics, on_chunk);
  // every process has finished its chunks (or one stopped: then all keep theirs)
  if (!shards.all_ok(!stopped)) return out;
  out.complete = true;
  out.reused = int(shards.sum_all(out.reused));
  if (shards.rank != 0) return out;  // the index is process 0's
  for (int k = 0; k < out.chunks; ++k)
    if (!c.mine(k)) c.read_back(k);  // the other processes' chunks (a shared folder)
  write_index(c, base, dt, sensitivity_base, opt.output);
  return out;
}

}  // namespace manyrods::scene
