// tools/plot.cpp — `manyrods plot` (docs/scenes.md "Plots"): writes data
// files and a gnuplot script (plots.gp) into the plot directory and runs
// gnuplot on it.
//
//   tips.png, energy.png  the tips of up to six rods and the energy budget over time
//   shapes.png            the rods at up to four times, projected on the two axes
//                         along which the nodes spread most, with the colliders,
//                         and a second view of the third axis when it has extent
//   shapes.gif            up to 60 frames of the first view, on fixed axes
//   sweep_*.png           a sweep's summary columns, and sweep_shapes.png: the
//                         variations at either end of one column at the last frame
//   calibration*.png      a calibration's measured against fitted tracks and
//                         scalars, and its search per generation
#include "plot.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "manyrods/contact.h"
#include "manyrods/h5io.h"
#include "manyrods/scene.h"
#include "manyrods/sweep.h"

namespace manyrods::cli {
namespace {

namespace fs = std::filesystem;
using scene::is_sweep_error_column;
using scene::sweep_error_column;

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("''") : std::string(1, c);
  return q + "'";
}

// Up to `most` of 0 … n−1, spread evenly, first and last included.
std::vector<std::int64_t> spread(std::int64_t n, std::int64_t most) {
  std::vector<std::int64_t> picked;
  const std::int64_t k = std::min(n, most);
  for (std::int64_t i = 0; i < k; ++i) picked.push_back(k == 1 ? 0 : std::llround(double(i) * double(n - 1) / double(k - 1)));
  return picked;
}

std::vector<int> spread_rods(const h5::Output& o, int most) {
  std::vector<int> rods;
  for (std::int64_t r : spread(std::int64_t(o.node_offsets.size()) - 1, most)) rods.push_back(int(r));
  return rods;
}

// A parameter's short name: the last part of its key path ("tau_extension"
// for rods.0.damping.tau_extension; "initial_tip_force.0" keeps its index).
std::string short_key(const std::string& key) {
  std::size_t dot = key.rfind('.');
  if (dot != std::string::npos && dot + 1 < key.size() && std::isdigit(static_cast<unsigned char>(key[dot + 1])))
    dot = key.rfind('.', dot - 1);
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

// A sweep whose variations' first rods make sense (from 0, increasing,
// within the batch: a damaged file's do not index rods here).
bool is_sweep(const h5::Output& o) {
  const std::int64_t rods = std::int64_t(o.node_offsets.size()) - 1;
  const auto& f = o.sweep_first_rod;
  return o.has_sweep && !f.empty() && f[0] == 0 && std::is_sorted(f.begin(), f.end()) && f.back() < rods &&
         std::adjacent_find(f.begin(), f.end()) == f.end();
}

// The sweep variation rod r belongs to.
std::size_t variation_of(const h5::Output& o, int r) {
  const auto it = std::upper_bound(o.sweep_first_rod.begin(), o.sweep_first_rod.end(), r);
  return it == o.sweep_first_rod.begin() ? 0 : std::size_t(it - o.sweep_first_rod.begin() - 1);
}

// The rods of sweep variation v: [first, end).
std::pair<int, int> variation_rods(const h5::Output& o, std::size_t v) {
  const int rods = int(o.node_offsets.size()) - 1;
  return {o.sweep_first_rod[v], v + 1 < o.sweep_first_rod.size() ? int(o.sweep_first_rod[v + 1]) : rods};
}

// Group g's name ("group g" without one); in a sweep without the variation
// its copy is for ("cable@2" is "cable": labels give the variation apart).
std::string group_name(const h5::Output& o, int g) {
  const bool named = g >= 0 && std::size_t(g) < o.group_names.size() && !o.group_names[std::size_t(g)].empty();
  std::string name = named ? o.group_names[std::size_t(g)] : "group " + std::to_string(g);
  const std::size_t at = name.rfind('@');
  if (is_sweep(o) && at != std::string::npos && at + 1 < name.size() &&
      name.find_first_not_of("0123456789", at + 1) == std::string::npos)
    name.resize(at);
  return name;
}

// Rod r by its group's name and its index in the group: "cable[0]" (in a
// sweep, its index in its variation's copy of the group); "rod r" in a file
// without groups.
std::string rod_name(const h5::Output& o, int r) {
  if (std::size_t(r) >= o.rod_group.size()) return "rod " + std::to_string(r);
  const int g = o.rod_group[std::size_t(r)];
  const int first = is_sweep(o) ? o.sweep_first_rod[variation_of(o, r)] : 0;
  int k = 0;
  for (int i = first; i < r; ++i) k += o.rod_group[std::size_t(i)] == g;
  return group_name(o, g) + "[" + std::to_string(k) + "]";
}

// A sweep variation's parameter values: "variation 2: tau_extension=0.03".
std::string variation_label(const h5::Output& o, std::size_t v) {
  std::ostringstream l;
  l.precision(4);
  l << "variation " << v << ":";
  for (const h5::Column& c : o.sweep_parameters) l << ' ' << short_key(c.name) << '=' << (v < c.values.size() ? c.values[v] : NAN);
  return l.str();
}

// The legend of rod r: its name ("cable[0]"), in a sweep its variation's
// parameter values (after its name when a variation has several rods).
std::string rod_label(const h5::Output& o, int r) {
  if (!is_sweep(o)) return rod_name(o, r);
  const std::size_t v = variation_of(o, r);
  const auto [first, end] = variation_rods(o, v);
  return (end - first > 1 ? rod_name(o, r) + " " : "") + variation_label(o, v);
}

// What a sweep varied, for titles: "tau_extension, youngs_modulus (64 variations)".
std::string varied(const h5::Output& o) {
  std::string t;
  for (const h5::Column& c : o.sweep_parameters) t += (t.empty() ? "" : ", ") + short_key(c.name);
  return t + " (" + std::to_string(o.sweep_parameters[0].values.size()) + " variations)";
}

std::string number(double x, int digits = 4) {
  std::ostringstream s;
  s.precision(digits);
  s << x;
  return s.str();
}

// noenhanced: names such as damping_ratio are printed as they are, not as
// gnuplot's subscripts
void tips_and_energy_script(std::ostream& gp, const h5::Output& o, const std::string& dir,
                            const std::vector<int>& shown, const std::string& tips, const std::string& energy) {
  gp << "set terminal pngcairo size 1200,900 noenhanced\nset grid\nset key outside right\n";
  const std::string what = o.has_sweep && !o.sweep_parameters.empty() ? ": sweep of " + varied(o) : "";
  gp << "set output " << quote(dir + "/tips.png") << "\nset multiplot layout 3,1 title " << quote("tip trajectories" + what)
     << "\n";
  const char* axis[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    gp << "set xlabel 'time (s)'\nset ylabel 'tip " << axis[a] << " (m)'\nplot ";
    for (std::size_t i = 0; i < shown.size(); ++i)
      gp << (i ? ", " : "") << quote(tips) << " using 1:" << 2 + 3 * i + a << " with lines title "
         << quote(rod_label(o, shown[i]));
    gp << "\n";
  }
  gp << "unset multiplot\n";
  gp << "set output " << quote(dir + "/energy.png")
     << "\nset title " << quote("energy budget (dissipated = integral of 2 D_v dt)" + what) << "\n"
     << "set xlabel 'time (s)'\nset ylabel 'energy (J)'\nplot " << quote(energy)
     << " using 1:2 with lines title 'kinetic', '' using 1:3 with lines title 'elastic', '' using 1:4 with "
        "lines title "
        "'potential', '' using 1:5 with lines lw 2 title 'mechanical', '' using 1:6 with lines title "
        "'dissipated (KV)', "
        "'' using 1:7 with lines dt 2 lw 2 title 'mechanical + dissipated'\n";
}

// A calibration's plots (appended to `made`; include/manyrods/calibrate.h
// run_best_fit's tables): calibration.png, up to four measured tracks
// (points) against the fitted ones (lines), x, y and z over time, titled
// with the fitted values; calibration_scalars.png, the measured scalars
// with their ±σ against the fitted ones; calibration_history.png, the best
// misfit and the search's step per generation. Data in calibration*.dat.
void calibration_script(std::ostream& gp, const h5::Output& o, const std::string& dir, std::vector<std::string>& made) {
  std::string fitted;  // "E = 1.2e6 ± 3e4, …" from /calibration
  for (const h5::Column& c : o.calibration) {
    if (c.values.size() < 4) continue;
    fitted += (fitted.empty() ? "" : ", ") + short_key(c.name) + " = " + number(c.values[0]);
    fitted += c.values[3] != 0 ? " +- " + number(c.values[1], 2) : " (not determined)";
  }
  gp << "set terminal pngcairo size 1200,900 noenhanced\nset grid\nset key outside right\nunset title\n";
  const std::size_t tracks = o.calibration_track_names.size();
  if (!o.calibration_tracks.empty() && o.calibration_tracks.size() == 1 + 6 * tracks && tracks > 0) {
    const std::string dat = dir + "/calibration.dat";
    std::ofstream d(dat);
    d.precision(12);
    std::vector<std::int64_t> shown = spread(std::int64_t(tracks), 4);
    const std::size_t T = o.calibration_tracks[0].values.size();
    for (std::size_t i = 0; i < T; ++i) {
      d << o.calibration_tracks[0].values[i];
      for (std::int64_t k : shown)  // (columns measured_k_x, fitted_k_x, … in the file: 1 + 6k + 2a + which)
        for (int which = 0; which < 2; ++which)
          for (int a = 0; a < 3; ++a) {
            const double v = o.calibration_tracks[std::size_t(1 + 6 * k + 2 * a + which)].values[i];
            d << ' ';
            if (std::isfinite(v)) d << v; else d << "NaN";
          }
      d << '\n';
    }
    gp << "set output " << quote(dir + "/calibration.png") << "\nset multiplot layout 3,1 title "
       << quote("calibration: measured (points) and fitted (lines) tracks; " + fitted) << "\n";
    for (int a = 0; a < 3; ++a) {
      gp << "set xlabel 'time (s)'\nset ylabel '" << "xyz"[a] << " (m)'\nplot ";
      for (std::size_t i = 0; i < shown.size(); ++i) {
        const std::string name = "track " + o.calibration_track_names[std::size_t(shown[i])];
        const std::size_t col = 2 + 6 * i;
        gp << (i ? ", " : "") << quote(dat) << " using 1:" << col + std::size_t(a) << " with points pt 7 ps 0.6 lc "
           << i + 1 << " title " << quote(name + " measured") << ", '' using 1:" << col + 3 + std::size_t(a)
           << " with lines lw 2 lc " << i + 1 << " title " << quote(name + " fitted");
      }
      gp << "\n";
    }
    gp << "unset multiplot\n";
    made.push_back(dir + "/calibration.png");
  }
  const std::size_t scalars = o.calibration_scalar_names.size();
  if (o.calibration_scalars.size() == 3 && scalars > 0) {
    const std::string dat = dir + "/calibration_scalars.dat";
    std::ofstream d(dat);
    d.precision(12);
    for (std::size_t q = 0; q < scalars; ++q)
      d << q << ' ' << o.calibration_scalars[0].values[q] << ' ' << o.calibration_scalars[1].values[q] << ' '
        << o.calibration_scalars[2].values[q] << ' ' << o.calibration_scalar_names[q] << '\n';  // (names: letters, digits, _ . - @)
    gp << "set output " << quote(dir + "/calibration_scalars.png") << "\nset title "
       << quote("calibration: measured scalars (+- sigma) and the fit's; " + fitted)
       << "\nset xlabel 'observable'\nset ylabel 'value (its unit)'\nset xrange [-0.5:" << double(scalars) - 0.5
       << "]\nplot " << quote(dat) << " using 1:2:3:xtic(5) with yerrorbars pt 7 title 'measured', '' using 1:4 with "
       << "points pt 6 ps 2 lw 2 title 'fitted'\nset xrange [*:*]\nset xtics autofreq\n";
    made.push_back(dir + "/calibration_scalars.png");
  }
  if (o.calibration_history.size() == 3 && !o.calibration_history[0].values.empty()) {
    const std::string dat = dir + "/calibration_history.dat";
    std::ofstream d(dat);
    d.precision(12);
    for (std::size_t g = 0; g < o.calibration_history[0].values.size(); ++g)
      d << o.calibration_history[0].values[g] << ' ' << o.calibration_history[1].values[g] << ' '
        << o.calibration_history[2].values[g] << '\n';
    gp << "set output " << quote(dir + "/calibration_history.png")
       << "\nset title 'calibration: the search (CMA-ES), one batch per generation'\nset xlabel 'generation'\n"
          "set ylabel 'best misfit (chi^2)'\nset y2label 'step (fraction of the ranges)'\nset logscale y\n"
          "set logscale y2\nset ytics nomirror\nset y2tics\nplot "
       << quote(dat) << " using 1:2 with lines lw 2 title 'best misfit', '' using 1:3 axes x1y2 with lines title 'step'\n"
       << "unset logscale y\nunset logscale y2\nunset y2tics\nset ytics mirror\nunset y2label\n";
    made.push_back(dir + "/calibration_history.png");
  }
}

// A sweep's plots (appended to `made`): each summary column against the
// first varied parameter (points; the fitted period and damping ratio with
// their standard errors as error bars), its histogram, and, for 16
// variations or more, the running mean with its 95 % interval against the
// number of variations (in the order they were drawn: the convergence of
// a sampled design). Data in sweep.dat (first parameter, then the columns).
void sweep_script(std::ostream& gp, const h5::Output& o, const std::string& dir, std::vector<std::string>& made) {
  const std::string sweep = dir + "/sweep.dat";
  std::ofstream s(sweep);
  s.precision(12);
  const std::size_t n = o.sweep_parameters[0].values.size();
  for (std::size_t i = 0; i < n; ++i) {
    s << i << ' ' << o.sweep_parameters[0].values[i];
    for (const h5::Column& c : o.sweep_summary) s << ' ' << (std::isfinite(c.values[i]) ? c.values[i] : NAN);
    s << '\n';
  }
  const std::string x = o.sweep_parameters[0].name, what = "sweep of " + varied(o);
  auto column = [&](const std::string& name) -> int {  // gnuplot column of a summary column, 0 if none
    for (std::size_t c = 0; c < o.sweep_summary.size(); ++c)
      if (o.sweep_summary[c].name == name) return int(c) + 3;
    return 0;
  };
  gp << "set key inside top right\n";
  for (std::size_t c = 0; c < o.sweep_summary.size(); ++c) {
    const std::string& y = o.sweep_summary[c].name;
    if (is_sweep_error_column(y)) continue;  // the error bars of its column's plot
    // a column without a finite value (a period the runs were too short
    // for, a crossing never reached) has nothing to plot
    if (std::none_of(o.sweep_summary[c].values.begin(), o.sweep_summary[c].values.end(),
                     [](double v) { return std::isfinite(v); })) {
      std::fprintf(stderr, "manyrods plot: %s: no finite value in any variation, not plotted\n", y.c_str());
      continue;
    }
    const int col = int(c) + 3;
    const std::string& error = sweep_error_column(y);
    const int err = error.empty() ? 0 : column(error);
    const std::string png = dir + "/sweep_" + y + ".png";
    gp << "set output " << quote(png) << "\nset title " << quote(y + " against " + short_key(x) + " — " + what)
       << "\nset xlabel " << quote(x) << "\nset ylabel " << quote(y) << "\nplot " << quote(sweep) << " using 2:"
       << col;
    if (err)
      gp << ":" << err << " with yerrorbars pt 7 ps 0.6 title " << quote(y + " ± standard error of the fit") << "\n";
    else
      gp << " with points pt 7 ps 0.6 title " << quote(y) << "\n";
    made.push_back(png);
    // histogram: 20 bins over the finite values' range
    const auto& v = o.sweep_summary[c].values;
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (double a : v)
      if (std::isfinite(a)) lo = std::min(lo, a), hi = std::max(hi, a);
    if (!(hi > lo)) continue;
    const double w = (hi - lo) / 20;
    std::vector<int> count(20, 0);
    for (double a : v)
      if (std::isfinite(a)) ++count[std::min(19, int((a - lo) / w))];
    const std::string hist_dat = dir + "/sweep_" + y + "_histogram.dat", hist = dir + "/sweep_" + y + "_histogram.png";
    std::ofstream hd(hist_dat);
    hd.precision(12);
    for (int b = 0; b < 20; ++b) hd << lo + (b + 0.5) * w << ' ' << count[std::size_t(b)] << '\n';
    gp << "set output " << quote(hist) << "\nset title " << quote("histogram of " + y + " — " + what)
       << "\nset xlabel " << quote(y) << "\nset ylabel 'variations'\nset style fill solid 0.5\nset boxwidth " << w
       << "\nplot " << quote(hist_dat) << " using 1:2 with boxes title "
       << quote(y + " (" + std::to_string(n) + " variations, NaN left out)") << "\nunset style\nset boxwidth\n";
    made.push_back(hist);
    if (n < 16) continue;
    // running mean and its 95 % interval (CLT) over the first k variations
    const std::string conv_dat = dir + "/sweep_" + y + "_convergence.dat";
    std::ofstream cd(conv_dat);
    cd.precision(12);
    double sum = 0, sum2 = 0;
    int k = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!std::isfinite(v[i])) continue;
      ++k, sum += v[i], sum2 += v[i] * v[i];
      if (k < 2) continue;
      const double mean = sum / k, sd = std::sqrt(std::max(0.0, (sum2 - k * mean * mean) / (k - 1)));
      cd << i + 1 << ' ' << mean << ' ' << mean - 1.959964 * sd / std::sqrt(k) << ' '
         << mean + 1.959964 * sd / std::sqrt(k) << '\n';
    }
    const std::string conv = dir + "/sweep_" + y + "_convergence.png";
    gp << "set output " << quote(conv) << "\nset title " << quote("running mean of " + y + " — " + what)
       << "\nset xlabel 'variations'\nset ylabel " << quote(y) << "\nset logscale x\nplot " << quote(conv_dat)
       << " using 1:3:4 with filledcurves fs transparent solid 0.25 title '95 % interval of the mean (CLT)', '' "
          "using 1:2 with lines lw 2 title 'mean'\nunset logscale x\n";
    made.push_back(conv);
  }
}

// ---- shapes: the rods drawn in 2-D views ------------------------------------------

const char kAxis[3] = {'x', 'y', 'z'};

struct Box {
  Vec3 lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  void add(const double* p) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) return;
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  }
  bool empty() const { return !(lo[0] <= hi[0]); }
  double extent(int a) const { return hi[a] - lo[a]; }
};

// A view: lab axis h drawn across, v drawn up, looking along the third.
struct View {
  int h = 0, v = 2;
  double stretch = 1;  // the vertical scale over the horizontal one (> 1: a flat view exaggerated)
  int depth() const { return 3 - h - v; }
  std::string name() const { return std::string(1, kAxis[h]) + kAxis[v]; }
};

// The views of a picture and its axis ranges (the same in every frame).
struct Projection {
  View main, second;
  bool has_second = false;
  Vec3 lo{}, hi{};
  double span(int a) const { return hi[a] - lo[a]; }
};

// The two axes along which the nodes spread most make the main view (the
// gravity axis instead of the second when it spreads at least half as much:
// a side view), the gravity axis (if one of them) drawn up, else the later
// of the two (z before y before x); the second view shows the third axis
// against the main view's horizontal one when the nodes spread along it by
// more than 5 % of the largest extent. Ranges: the nodes' box and 5 % of the
// largest extent around it, at least 15 % of it along every axis.
Projection choose_projection(const Box& b, int gravity_axis) {
  std::array<int, 3> ax{0, 1, 2};
  std::stable_sort(ax.begin(), ax.end(), [&](int a, int c) { return b.extent(a) > b.extent(c); });
  if (gravity_axis == ax[2] && b.extent(ax[2]) >= 0.5 * b.extent(ax[1])) std::swap(ax[1], ax[2]);
  Projection p;
  if (gravity_axis == ax[0] || gravity_axis == ax[1])
    p.main = {ax[0] + ax[1] - gravity_axis, gravity_axis};
  else
    p.main = {std::min(ax[0], ax[1]), std::max(ax[0], ax[1])};
  double big = b.extent(ax[0]);
  if (!(big > 0)) big = std::max(1e-3, std::fabs(b.lo[ax[0]]));  // a single point
  p.has_second = b.extent(ax[2]) > 0.05 * big;
  p.second = {p.main.h, ax[2]};
  for (int a = 0; a < 3; ++a) {
    const double mid = 0.5 * (b.lo[a] + b.hi[a]), half = std::max(0.5 * b.extent(a) + 0.05 * big, 0.075 * big);
    p.lo[a] = mid - half, p.hi[a] = mid + half;
  }
  // A view whose nodes spread up by less than 5 % of their spread across (a
  // taut cable's sag, a stiff beam's deflection) is stretched up, by a round
  // factor, to about a quarter of its width: equal scales would show a line.
  for (View* w : {&p.main, &p.second}) {
    const double across = b.extent(w->h), up = b.extent(w->v);
    if (!(up > 0) || up >= 0.05 * across) continue;
    p.lo[w->v] = b.lo[w->v] - 0.1 * up, p.hi[w->v] = b.hi[w->v] + 0.1 * up;
    const double want = 0.25 * p.span(w->h) / p.span(w->v), decade = std::pow(10.0, std::floor(std::log10(want)));
    w->stretch = want >= 5 * decade ? 5 * decade : want >= 2 * decade ? 2 * decade : decade;
  }
  return p;
}

// The axis gravity points along (−1: none, or not along an axis).
int gravity_axis(const Vec3& g) {
  const double n = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  for (int a = 0; a < 3; ++a)
    if (n > 0 && std::fabs(g[a]) > 0.9 * n) return a;
  return -1;
}

using Point = std::array<double, 2>;
using Polyline = std::vector<Point>;

Vec3 rotate(const Pose& P, const Vec3& x) {
  Vec3 y{};
  for (int i = 0; i < 3; ++i) y[i] = P.rotation[3 * i] * x[0] + P.rotation[3 * i + 1] * x[1] + P.rotation[3 * i + 2] * x[2];
  return y;
}

Vec3 place(const Pose& P, const Vec3& x) {
  Vec3 y = rotate(P, x);
  for (int i = 0; i < 3; ++i) y[i] += P.translation[i];
  return y;
}

Polyline circle(Point c, double r) {
  Polyline l;
  for (int i = 0; i <= 72; ++i) {
    const double a = 2 * std::numbers::pi * i / 72;
    l.push_back({c[0] + r * std::cos(a), c[1] + r * std::sin(a)});
  }
  return l;
}

// Clips segment l (two points) to the box [lo, hi] (Liang–Barsky); false
// when nothing of it is inside.
bool clip(Polyline& l, Point lo, Point hi) {
  double t0 = 0, t1 = 1;
  const Point a = l[0], d{l[1][0] - l[0][0], l[1][1] - l[0][1]};
  for (int k = 0; k < 2; ++k) {
    for (const auto& [pk, qk] : {std::pair{-d[k], a[k] - lo[k]}, std::pair{d[k], hi[k] - a[k]}}) {
      if (pk == 0) {
        if (qk < 0) return false;
        continue;
      }
      const double r = qk / pk;
      if (pk < 0) t0 = std::max(t0, r);
      else t1 = std::min(t1, r);
    }
  }
  if (t0 > t1) return false;
  l = {{a[0] + t0 * d[0], a[1] + t0 * d[1]}, {a[0] + t1 * d[0], a[1] + t1 * d[1]}};
  return true;
}

const char* kind_name(ColliderKind k) {
  switch (k) {
    case ColliderKind::plane: return "plane";
    case ColliderKind::sphere: return "sphere";
    case ColliderKind::capsule: return "capsule";
    case ColliderKind::mesh: return "mesh, its bounding box";
  }
  return "collider";
}

// Collider c at pose P seen in view w (ranges from p), as polylines; none
// for a plane seen face-on (its normal within about 11° of the line of
// sight: it fills the view). A plane is drawn as its line at the view's
// mid-depth with short ticks on the solid side; a mesh as its bounding box.
std::vector<Polyline> outline(const Collider& c, const Pose& P, View w, const Projection& p) {
  auto at = [&](const Vec3& x) { return Point{x[w.h], x[w.v]}; };
  std::vector<Polyline> out;
  switch (c.kind) {
    case ColliderKind::plane: {
      const Vec3 q = place(P, c.point), n = rotate(P, c.normal);
      const double nh = n[w.h], nv = n[w.v], s = std::hypot(nh, nv), nn = std::sqrt(nh * nh + nv * nv + n[w.depth()] * n[w.depth()]);
      if (!(s > 0.2 * nn)) return out;
      const int d = w.depth();
      const double c0 = nh * q[w.h] + nv * q[w.v] - n[d] * (0.5 * (p.lo[d] + p.hi[d]) - q[d]);
      const Point mid{0.5 * (p.lo[w.h] + p.hi[w.h]), 0.5 * (p.lo[w.v] + p.hi[w.v])};
      const double off = (nh * mid[0] + nv * mid[1] - c0) / (s * s);
      const Point foot{mid[0] - off * nh, mid[1] - off * nv}, dir{-nv / s, nh / s}, in{-nh / s, -nv / s};
      const double reach = std::hypot(p.span(w.h), p.span(w.v)), tick = reach / 40;
      const Point lo{p.lo[w.h], p.lo[w.v]}, hi{p.hi[w.h], p.hi[w.v]};
      Polyline line{{foot[0] - reach * dir[0], foot[1] - reach * dir[1]}, {foot[0] + reach * dir[0], foot[1] + reach * dir[1]}};
      if (!clip(line, lo, hi)) return out;  // (off the view)
      out.push_back(line);
      for (int i = -40; i <= 40; ++i) {  // hatching on the solid side
        const Point a{foot[0] + i * tick * dir[0], foot[1] + i * tick * dir[1]};
        Polyline h{a, {a[0] + 0.7 * tick * (in[0] - dir[0]), a[1] + 0.7 * tick * (in[1] - dir[1])}};
        if (clip(h, lo, hi)) out.push_back(h);
      }
      return out;
    }
    case ColliderKind::sphere:
      out.push_back(circle(at(place(P, c.center)), c.radius));
      return out;
    case ColliderKind::capsule: {
      const Point a = at(place(P, c.a)), b = at(place(P, c.b));
      out.push_back(circle(a, c.radius));
      out.push_back(circle(b, c.radius));
      const double len = std::hypot(b[0] - a[0], b[1] - a[1]);
      if (len > 1e-9 * c.radius) {
        const Point n{-(b[1] - a[1]) / len * c.radius, (b[0] - a[0]) / len * c.radius};
        out.push_back({{a[0] + n[0], a[1] + n[1]}, {b[0] + n[0], b[1] + n[1]}});
        out.push_back({{a[0] - n[0], a[1] - n[1]}, {b[0] - n[0], b[1] - n[1]}});
      }
      return out;
    }
    case ColliderKind::mesh: {
      if (!c.grid) return out;
      std::vector<Vec3> corners = c.grid->vertices;
      if (corners.empty())  // the distance grid's corners
        for (int i = 0; i < 8; ++i) {
          Vec3 x = c.grid->origin;
          for (int a = 0; a < 3; ++a) x[a] += (i >> a & 1) * c.grid->spacing * std::max(0, c.grid->n[a] - 1);
          corners.push_back(x);
        }
      double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
      for (const Vec3& x : corners) {
        const Point q = at(place(P, x));
        for (int k = 0; k < 2; ++k) lo[k] = std::min(lo[k], q[k]), hi[k] = std::max(hi[k], q[k]);
      }
      if (!(lo[0] <= hi[0])) return out;
      out.push_back({{lo[0], lo[1]}, {hi[0], lo[1]}, {hi[0], hi[1]}, {lo[0], hi[1]}, {lo[0], lo[1]}});
      return out;
    }
  }
  return out;
}

// The colliders of the scene stored in the file: the scene's colliders and
// gravity axis, or none (with a note) where the scene does not parse here
// (a mesh file not found from this directory).
struct SceneInfo {
  std::vector<Collider> colliders;
  int gravity = -1;
};

SceneInfo scene_info(const h5::Output& o, const std::string& in) {
  SceneInfo s;
  if (o.scene_text.empty()) return s;
  try {
    const scene::Scene sc = scene::parse_scene(o.scene_text, o.scene_source);
    s.colliders = sc.contact.colliders;
    s.gravity = gravity_axis(sc.sim.gravity);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "manyrods plot: the scene stored in %s does not parse here (%s): shapes drawn without colliders\n",
                 in.c_str(), e.what());
  }
  return s;
}

// The colliders at time t in view w: each one's name ("head (sphere)",
// with the time for a moving one) and outline (none: a plane seen face-on
// or off the view).
struct Outline {
  std::string name;
  std::vector<Polyline> lines;
};

std::vector<Outline> outlines(const std::vector<Collider>& cs, double t, View w, const Projection& p) {
  std::vector<Outline> out;
  for (const Collider& c : cs) {
    const Pose P = c.motion ? c.motion->at(t) : Pose{};
    out.push_back({(c.name.empty() ? std::string("collider") : c.name) + " (" + kind_name(c.kind) +
                       (c.motion ? ", at t = " + number(t) + " s" : "") + ")",
                   outline(c, P, w, p)});
  }
  return out;
}

// Polylines as gnuplot blocks (one blank line after each).
void write_lines(std::ostream& out, const std::vector<Polyline>& lines) {
  for (const Polyline& l : lines) {
    for (const Point& q : l) out << q[0] << ' ' << q[1] << '\n';
    out << '\n';
  }
}

// One frame of rods as a gnuplot index: a block of x y z lines per rod,
// headed by comments naming the frame and the rod.
void write_frame(std::ostream& out, const h5::Output& o, const std::vector<double>& pos, const std::vector<int>& rods,
                 const std::vector<std::string>& names, std::int64_t f) {
  out << "# frame " << f << ", t = " << o.time[std::size_t(f)] << " s\n";
  for (std::size_t i = 0; i < rods.size(); ++i) {
    out << "# " << names[i] << '\n';
    for (std::int64_t j = o.node_offsets[std::size_t(rods[i])]; j < o.node_offsets[std::size_t(rods[i]) + 1]; ++j)
      out << pos[3 * j] << ' ' << pos[3 * j + 1] << ' ' << pos[3 * j + 2] << '\n';
    out << '\n';
  }
  out << '\n';
}

// A curve of a panel: an index of a data file (−1: all of it) drawn with
// `style`; columns "3d": x y z (the panel picks two), else the panel's two.
struct Series {
  std::string file;
  int index = -1;
  bool xyz = true;
  std::string style, title;
};

std::string axis_label(int a) { return std::string(1, kAxis[a]) + " (m)"; }

// A panel's settings and plot command: view w on p's ranges.
void panel(std::ostream& gp, const Projection& p, View w, const std::vector<Series>& series) {
  gp << "set xrange [" << p.lo[w.h] << ":" << p.hi[w.h] << "]\nset yrange [" << p.lo[w.v] << ":" << p.hi[w.v]
     << "]\nset xlabel " << quote(axis_label(w.h)) << "\nset ylabel " << quote(axis_label(w.v)) << "\nplot ";
  for (std::size_t i = 0; i < series.size(); ++i) {
    const Series& s = series[i];
    if (s.file.empty()) {  // a legend line only (colliders none of which shows in this view)
      gp << (i ? ", \\\n  " : "") << "keyentry with lines " << s.style << " title " << quote(s.title);
      continue;
    }
    gp << (i ? ", \\\n  " : "") << quote(s.file) << (s.index >= 0 ? " index " + std::to_string(s.index) : "")
       << " using " << (s.xyz ? std::to_string(w.h + 1) + ":" + std::to_string(w.v + 1) : "1:2") << " with lines "
       << s.style << ' ' << (s.title.empty() ? "notitle" : "title " + quote(s.title));
  }
  gp << '\n';
}

// The view names for titles: "x–z" and its kind when it is one.
std::string view_name(View w, int gravity) {
  const std::string n = std::string(1, kAxis[w.h]) + "–" + kAxis[w.v];
  const std::string stretched = w.stretch != 1 ? ", " + std::string(1, kAxis[w.v]) + " stretched ×" + number(w.stretch) : "";
  if (gravity >= 0 && w.v == gravity) return "side view " + n + stretched;
  if (gravity >= 0 && w.depth() == gravity) return "top view " + n + stretched;
  return n + " view" + stretched;
}

// A picture's geometry in pixels: one or two panels (p.has_second: the
// second view below the first, or beside it when both are tall) drawn at a
// common scale (metres per pixel the same across and up, and in both
// panels: equal aspect by construction, but for a view's stretch), the
// legend to the right of them.
struct Area {
  int left = 0, top = 0, width = 0, height = 0;
};

struct Geometry {
  int width = 0, height = 0;
  std::vector<Area> panels;
  int key_left = 0, key_top = 0;
};

// `key_px`: the legend's width; `big`: the longest side of the panels in pixels.
Geometry geometry(const Projection& p, int key_px, double big, bool titled_panels) {
  const int L = 90, R = 25, B = 60, head = 40, T = titled_panels ? 38 : 8;
  const double sh = p.span(p.main.h), sv = p.span(p.main.v) * p.main.stretch,
               sd = p.has_second ? p.span(p.second.v) * p.second.stretch : 0;
  Geometry g;
  if (!p.has_second) {
    const double s = std::min(big / sh, 0.8 * big / sv);
    const Area a{L, head + T, int(s * sh), int(s * sv)};
    g.panels = {a};
    g.width = L + a.width + R + key_px, g.height = a.top + a.height + B;
  } else if (sv + sd <= 1.6 * sh) {  // stacked, the horizontal axes lined up
    const double s = std::min(big / sh, big / (sv + sd));
    const Area a{L, head + T, int(s * sh), int(s * sv)};
    const Area b{L, a.top + a.height + B + T, int(s * sh), int(s * sd)};
    g.panels = {a, b};
    g.width = L + a.width + R + key_px, g.height = b.top + b.height + B;
  } else {  // beside
    const double s = std::min(0.6 * big / sh, 0.8 * big / std::max(sv, sd));
    const Area a{L, head + T, int(s * sh), int(s * sv)};
    const Area b{a.left + a.width + R + L, head + T, int(s * sh), int(s * sd)};
    g.panels = {a, b};
    g.width = b.left + b.width + R + key_px, g.height = head + T + std::max(a.height, b.height) + B;
  }
  g.key_left = g.width - key_px + 10, g.key_top = head + T;
  g.width = std::max(g.width, 480), g.height = std::max(g.height, 240);
  return g;
}

// The legend's width for these titles (about `char_px` a character).
int key_width(const std::vector<std::vector<Series>>& lists, int char_px) {
  std::size_t longest = 0;
  for (const auto& l : lists)
    for (const Series& s : l) longest = std::max(longest, s.title.size());
  return std::clamp(int(longest) * char_px + 100, 150, 900);
}

// The margins that put the plot of the next `plot` command on area a.
void margins(std::ostream& gp, const Geometry& g, const Area& a) {
  auto x = [&](int px) { return double(px) / g.width; };
  auto y = [&](int px) { return 1 - double(px) / g.height; };
  gp << "set lmargin at screen " << x(a.left) << "\nset rmargin at screen " << x(a.left + a.width)
     << "\nset tmargin at screen " << y(a.top) << "\nset bmargin at screen " << y(a.top + a.height) << '\n';
}

void key_at(std::ostream& gp, const Geometry& g) {
  gp << "set key at screen " << double(g.key_left) / g.width << ',' << 1 - double(g.key_top) / g.height
     << " left top Left reverse\n";
}

// A picture: `title` over the panel(s) of p showing `curves` (drawn over the
// colliders of each view: `main_extra`, `second_extra`).
void picture(std::ostream& gp, const std::string& png, const std::string& title, const Projection& p, int gravity,
             const std::vector<Series>& curves, const std::vector<Series>& main_extra,
             const std::vector<Series>& second_extra) {
  const Geometry g = geometry(p, key_width({curves, main_extra}, 8), 1000, p.has_second);
  gp << "reset\nset terminal pngcairo size " << g.width << ',' << g.height
     << " noenhanced font ',11'\nset output " << quote(png) << "\nset grid\nset clip two\n";
  key_at(gp, g);
  auto both = [](std::vector<Series> a, const std::vector<Series>& b) {
    a.insert(a.begin(), b.begin(), b.end());
    return a;
  };
  margins(gp, g, g.panels[0]);
  if (!p.has_second) {
    gp << "set title " << quote(title + " — " + view_name(p.main, gravity)) << '\n';
    panel(gp, p, p.main, both(curves, main_extra));
    return;
  }
  gp << "set multiplot title " << quote(title) << '\n';
  gp << "set title " << quote(view_name(p.main, gravity)) << '\n';
  panel(gp, p, p.main, both(curves, main_extra));
  gp << "set title " << quote(view_name(p.second, gravity)) << "\nunset key\n";
  margins(gp, g, g.panels[1]);
  panel(gp, p, p.second, both(curves, second_extra));
  gp << "unset multiplot\n";
}

// The groups of the rods drawn, for titles: "cable", "cable, hair".
std::string group_list(const h5::Output& o, const std::vector<int>& rods) {
  std::vector<std::string> gs;
  for (int r : rods) {
    const std::string g = std::size_t(r) < o.rod_group.size() ? group_name(o, o.rod_group[std::size_t(r)]) : "rods";
    if (std::find(gs.begin(), gs.end(), g) == gs.end()) gs.push_back(g);
  }
  std::string t;
  for (std::size_t i = 0; i < gs.size() && i < 3; ++i) t += (i ? ", " : "") + gs[i];
  return gs.size() > 3 ? t + ", …" : t;
}

const char* kFrameColours[4] = {"#8c8c8c", "#1f77b4", "#2ca02c", "#d62728"};

// The sweep variations at either end of one summary column: the tip's final
// deflection where it has a spread, else the first column that has.
struct SweepEnds {
  bool ok = false;
  std::string column;
  std::size_t vmin = 0, vmax = 0;
  double min = 0, max = 0;
  std::vector<int> rods_min, rods_max;  // (up to 100 each)
};

SweepEnds sweep_ends(const h5::Output& o) {
  SweepEnds e;
  if (!is_sweep(o) || o.sweep_summary.empty()) return e;
  auto try_column = [&](const h5::Column& c) {
    if (is_sweep_error_column(c.name) || c.values.size() != o.sweep_first_rod.size()) return false;
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    std::size_t vlo = 0, vhi = 0;
    for (std::size_t v = 0; v < c.values.size(); ++v) {
      if (!std::isfinite(c.values[v])) continue;
      if (c.values[v] < lo) lo = c.values[v], vlo = v;
      if (c.values[v] > hi) hi = c.values[v], vhi = v;
    }
    if (!(hi - lo > 1e-9 * std::max(std::fabs(lo), std::fabs(hi)))) return false;  // (round-off is no spread)
    e = {true, c.name, vlo, vhi, lo, hi, {}, {}};
    return true;
  };
  bool found = false;
  for (const h5::Column& c : o.sweep_summary)
    if (c.name == "tip_deflection_final_m" && try_column(c)) found = true;
  for (std::size_t i = 0; !found && i < o.sweep_summary.size(); ++i) found = try_column(o.sweep_summary[i]);
  if (!found) return e;
  for (auto [v, rods] : {std::pair{e.vmin, &e.rods_min}, std::pair{e.vmax, &e.rods_max}}) {
    const auto [first, end] = variation_rods(o, v);
    for (std::int64_t k : spread(end - first, 100)) rods->push_back(first + int(k));
  }
  return e;
}

// shapes.png, shapes.gif and, for a sweep, sweep_shapes.png: reads every
// frame once (the box of all nodes sets the views), writing the tips
// (tips.dat) on the way.
void shapes_script(std::ostream& gp, const h5::Reader& rd, const std::string& in, const std::string& dir,
                   const std::vector<int>& tip_rods, const std::string& tips_file, std::vector<std::string>& made) {
  const h5::Output& o = rd.output();
  const std::int64_t frames = rd.frames();
  const int rods = int(o.node_offsets.size()) - 1;
  const std::vector<int> shown = spread_rods(o, 200);
  std::vector<std::string> names;
  for (int r : shown) names.push_back(rod_label(o, r));
  // four times for a few rods; many (a groom) are a tangle at four: the first and last
  const std::vector<std::int64_t> still = spread(frames, shown.size() > 12 ? 2 : 4), anim = spread(frames, 60);
  const SweepEnds ends = sweep_ends(o);
  std::vector<std::string> names_min, names_max;
  for (int r : ends.rods_min) names_min.push_back(rod_label(o, r));
  for (int r : ends.rods_max) names_max.push_back(rod_label(o, r));

  const std::string shapes_dat = dir + "/shapes.dat", anim_dat = dir + "/shapes_animation.dat",
                    sweep_dat = dir + "/sweep_shapes.dat";
  std::ofstream tips(tips_file), shapes(shapes_dat), animation(anim_dat);
  std::ofstream sweep_out;
  if (ends.ok) sweep_out.open(sweep_dat);
  for (std::ofstream* f : {&tips, &shapes, &animation, &sweep_out}) f->precision(10);
  Box box, sweep_box;
  bool same_start = ends.rods_min.size() == ends.rods_max.size();  // the two sweep variations start alike
  std::vector<double> pos;
  for (std::int64_t f = 0; f < frames; ++f) {
    rd.read_positions(f, pos);
    tips << o.time[std::size_t(f)];
    for (int r : tip_rods) {
      const std::int64_t j = o.node_offsets[std::size_t(r) + 1] - 1;
      tips << ' ' << pos[3 * j] << ' ' << pos[3 * j + 1] << ' ' << pos[3 * j + 2];
    }
    tips << '\n';
    for (std::int64_t j = 0; j < o.node_offsets[std::size_t(rods)]; ++j) box.add(&pos[3 * j]);
    if (std::binary_search(still.begin(), still.end(), f)) write_frame(shapes, o, pos, shown, names, f);
    if (std::binary_search(anim.begin(), anim.end(), f)) write_frame(animation, o, pos, shown, names, f);
    if (ends.ok && (f == 0 || f == frames - 1)) {
      write_frame(sweep_out, o, pos, ends.rods_min, names_min, f);
      write_frame(sweep_out, o, pos, ends.rods_max, names_max, f);
      for (const std::vector<int>* rs : {&ends.rods_min, &ends.rods_max})
        for (int r : *rs)
          for (std::int64_t j = o.node_offsets[std::size_t(r)]; j < o.node_offsets[std::size_t(r) + 1]; ++j)
            sweep_box.add(&pos[3 * j]);
      for (std::size_t i = 0; f == 0 && same_start && i < ends.rods_min.size(); ++i) {
        const std::int64_t a = o.node_offsets[std::size_t(ends.rods_min[i])], b = o.node_offsets[std::size_t(ends.rods_max[i])];
        const std::int64_t n = o.node_offsets[std::size_t(ends.rods_min[i]) + 1] - a;
        same_start = n == o.node_offsets[std::size_t(ends.rods_max[i]) + 1] - b &&
                     std::equal(pos.begin() + 3 * a, pos.begin() + 3 * (a + n), pos.begin() + 3 * b);
      }
    }
  }
  if (box.empty()) {
    std::fprintf(stderr, "manyrods plot: %s: no finite node position in any frame: no shapes drawn\n", in.c_str());
    return;
  }
  const SceneInfo sc = scene_info(o, in);
  const Projection p = choose_projection(box, sc.gravity);
  const std::string shown_what = std::to_string(shown.size()) + (int(shown.size()) < rods ? " of " + std::to_string(rods) : "") +
                                 (rods == 1 ? " rod" : " rods") + " (" + group_list(o, shown) + ")";

  // the colliders at time t as series of the views of pr (their outlines in
  // <stem>_<view>.dat, an index each; more than six: one index, one legend
  // line). The legend (the first view's) names each collider drawn in either
  // view, and says so of one drawn in neither (a plane seen face-on).
  using Views = std::pair<std::vector<Series>, std::vector<Series>>;
  auto collider_series = [&](const std::string& stem, double t, const Projection& pr) {
    Views s;
    if (sc.colliders.empty()) return s;
    const std::string style = "lc rgb '#444444' lw 1.5";
    std::vector<Outline> in_view[2];
    std::vector<int> index[2];
    for (int k = 0; k < (pr.has_second ? 2 : 1); ++k) {
      const View w = k ? pr.second : pr.main;
      const std::string file = stem + "_" + w.name() + ".dat";
      std::ofstream c(file);
      c.precision(10);
      in_view[k] = outlines(sc.colliders, t, w, pr);
      std::vector<Series>& out = k ? s.second : s.first;
      if (sc.colliders.size() > 6) {
        for (const Outline& x : in_view[k]) write_lines(c, x.lines);
        out.push_back({file, -1, false, style, std::to_string(sc.colliders.size()) + " colliders at t = " + number(t) + " s"});
        continue;
      }
      int n = 0;
      for (const Outline& x : in_view[k]) {
        index[k].push_back(x.lines.empty() ? -1 : n);
        if (x.lines.empty()) continue;
        write_lines(c, x.lines);
        c << '\n';
        out.push_back({file, n++, false, style, x.name});
      }
    }
    if (sc.colliders.size() > 6) return s;
    s.first.clear();  // again, in the colliders' order, with the legend lines
    for (std::size_t i = 0; i < sc.colliders.size(); ++i) {
      const std::string& name = in_view[0][i].name;
      if (index[0][i] >= 0)
        s.first.push_back({stem + "_" + pr.main.name() + ".dat", index[0][i], false, style, name});
      else if (pr.has_second && index[1][i] >= 0)
        s.first.push_back({"", -1, false, style, name});
      else
        s.first.push_back({"", -1, false, style + " dt 3", name + ": not drawn (seen face-on, or out of view)"});
    }
    return s;
  };
  const double t0 = o.time[std::size_t(still.front())];
  std::vector<Series> curves;
  for (std::size_t i = 0; i < still.size(); ++i) {
    const int colour = i + 1 == still.size() ? 3 : i == 0 ? 0 : int(i);  // grey first, red last
    curves.push_back({shapes_dat, int(i), true,
                      std::string("lc rgb '") + kFrameColours[colour] + "' lw " + (i + 1 == still.size() ? "2" : "1.5") +
                          (i == 0 && still.size() > 1 ? " dt 2" : ""),
                      "t = " + number(o.time[std::size_t(still[i])]) + " s"});
  }
  const std::string shapes_png = dir + "/shapes.png";
  const Views cs = collider_series(dir + "/colliders", t0, p);
  picture(gp, shapes_png, "rod shapes: " + shown_what, p, sc.gravity, curves, cs.first, cs.second);
  made.push_back(shapes_png);

  // the animation: the first view, the first frame in grey under each frame
  {
    const std::string gif = dir + "/shapes.gif", coll = dir + "/shapes_animation_colliders.dat";
    bool colliders = false;
    std::string legend;  // (their names without the time: each frame shows its own)
    for (const Collider& c : sc.colliders)
      legend += (legend.empty() ? "" : ", ") + (c.name.empty() ? std::string("collider") : c.name);
    if (sc.colliders.size() > 3) legend = std::to_string(sc.colliders.size()) + " colliders";
    if (!sc.colliders.empty()) {
      std::ofstream c(coll);
      c.precision(10);
      for (std::int64_t f : anim) {  // an index per frame
        for (const Outline& x : outlines(sc.colliders, o.time[std::size_t(f)], p.main, p)) {
          write_lines(c, x.lines);
          colliders = colliders || !x.lines.empty();
        }
        c << '\n';
      }
    }
    Projection one = p;
    one.has_second = false;
    auto series = [&](int i) {  // frame i of the animation over the first frame, the colliders under both
      std::vector<Series> s = {{anim_dat, 0, true, "lc rgb '#bbbbbb' lw 1", "t = " + number(o.time[0]) + " s"},
                               {anim_dat, i, true, "lc rgb '#1f77b4' lw 1.5", shown.size() == 1 ? names[0] : "rods"}};
      if (colliders) s.insert(s.begin(), {coll, i, false, "lc rgb '#444444' lw 1.5", legend});
      return s;
    };
    const Geometry g = geometry(one, key_width({series(0)}, 7), 600, false);
    gp << "reset\nset terminal gif animate delay 8 loop 0 optimize size " << g.width << ',' << g.height
       << " noenhanced font 'DejaVu Sans,9'\nset output " << quote(gif) << "\nset grid\nset clip two\n";
    key_at(gp, g);
    margins(gp, g, g.panels[0]);
    for (std::size_t i = 0; i < anim.size(); ++i) {
      const double t = o.time[std::size_t(anim[i])];
      gp << "set title " << quote(shown_what + ", " + view_name(p.main, sc.gravity) + ": t = " + number(t) + " s") << '\n';
      panel(gp, p, p.main, series(int(i)));
    }
    gp << "unset output\n";
    made.push_back(gif);
  }

  // a sweep: its two extreme variations at the last frame
  if (ends.ok && !sweep_box.empty()) {
    const Projection q = choose_projection(sweep_box, sc.gravity);
    const int last = frames > 1 ? 2 : 0;  // the index of the last frame's blocks
    const double t_end = o.time[std::size_t(frames - 1)];
    const std::string lo = variation_label(o, ends.vmin) + " (least: " + number(ends.min) + ")",
                      hi = variation_label(o, ends.vmax) + " (most: " + number(ends.max) + ")";
    const std::string start = "t = " + number(o.time[0]) + " s";
    std::vector<Series> s;
    if (frames > 1 && same_start)
      s.push_back({sweep_dat, 0, true, "lc rgb '#8c8c8c' lw 1 dt 2", start + " (both)"});
    else if (frames > 1) {
      s.push_back({sweep_dat, 0, true, "lc rgb '#9ecae1' lw 1 dt 2", start + ", variation " + std::to_string(ends.vmin)});
      s.push_back({sweep_dat, 1, true, "lc rgb '#fcae91' lw 1 dt 2", start + ", variation " + std::to_string(ends.vmax)});
    }
    s.push_back({sweep_dat, last, true, "lc rgb '#1f77b4' lw 2", lo});
    s.push_back({sweep_dat, last + 1, true, "lc rgb '#d62728' lw 2", hi});
    const std::string png = dir + "/sweep_shapes.png";
    const Views cs = collider_series(dir + "/sweep_colliders", t_end, q);
    picture(gp, png,
            "sweep of " + varied(o) + ": least and most " + ends.column + ", at t = " + number(t_end) + " s", q,
            sc.gravity, s, cs.first, cs.second);
    made.push_back(png);
  }
}

// Writes the script to dir/plots.gp and runs gnuplot on it.
int run_gnuplot(const std::string& dir, const std::string& script_text, const std::vector<std::string>& made) {
  const std::string script = dir + "/plots.gp";
  std::ofstream(script) << script_text;
  const std::string log = dir + "/gnuplot.log";
  const int rc = std::system(("gnuplot " + quote(script) + " 2> " + quote(log)).c_str());
  if (rc != 0) {
    std::fprintf(stderr, "manyrods plot: gnuplot failed (exit %d); is gnuplot installed? script: %s, messages: %s\n",
                 rc, script.c_str(), log.c_str());
    return 1;
  }
  for (const std::string& m : made) std::fprintf(stderr, "manyrods: wrote %s\n", m.c_str());
  return 0;
}

void energy_data(const h5::Output& o, std::int64_t frames, const std::string& energy) {
  std::ofstream e(energy);
  e.precision(12);
  for (std::int64_t f = 0; f < frames; ++f) {
    const h5::EnergyRow& r = o.energy[std::size_t(f)];
    const double mech = r.kinetic + r.elastic + r.potential;
    e << o.time[std::size_t(f)] << ' ' << r.kinetic << ' ' << r.elastic << ' ' << r.potential << ' ' << mech << ' '
      << r.dissipated << ' ' << mech + r.dissipated << '\n';
  }
}

}  // namespace

int plot(const std::string& in, std::string dir) {
  if (dir.empty()) dir = fs::path(in).replace_extension("").string() + "_plots";
  {  // every file the plots write into dir ends with one of these: the input must not be one
    std::error_code ec;
    const std::string ext = fs::path(in).extension().string();
    const fs::path parent = fs::path(in).has_parent_path() ? fs::path(in).parent_path() : fs::path(".");
    for (const char* e : {".dat", ".png", ".gif", ".gp", ".log"})
      if (ext == e && fs::exists(dir, ec) && fs::equivalent(parent, dir, ec)) {
        std::fprintf(stderr,
                     "manyrods plot: %s: the plots write %s files into --out-dir %s, which holds the input; give "
                     "another --out-dir (nothing was written)\n",
                     in.c_str(), e, dir.c_str());
        return 2;
      }
  }
  auto make_dir = [&] {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec || !fs::is_directory(dir) || access(dir.c_str(), W_OK) != 0) {
      std::fprintf(stderr, "manyrods plot: --out-dir %s: cannot create or write this directory (%s)\n", dir.c_str(),
                   ec ? ec.message().c_str() : "not a writable directory");
      return false;
    }
    return true;
  };
  if (h5::is_sweep_index(in)) {  // a chunked sweep: its sweep plots (the frames stay in the chunks)
    const h5::SweepIndex x = h5::read_sweep_index(in);
    h5::Output o;
    o.has_sweep = true;
    o.sweep_parameters = x.parameters;
    o.sweep_summary = x.summary;
    o.scene_text = x.scene_text;
    o.scene_source = x.scene_source;
    if (!make_dir()) return 2;
    std::ostringstream gp;
    gp << "set terminal pngcairo size 1200,900 noenhanced\nset grid\n";
    std::vector<std::string> made;
    if (!o.sweep_parameters.empty()) sweep_script(gp, o, dir, made);
    return run_gnuplot(dir, gp.str(), made);
  }
  const h5::Reader rd(in);
  const h5::Output& o = rd.output();
  if (!make_dir()) return 2;
  std::ostringstream gp, shapes;
  std::vector<std::string> made, made_shapes;
  if (rd.frames() > 0) {
    const std::vector<int> shown = spread_rods(o, 6);
    const std::string tips = dir + "/tips.dat", energy = dir + "/energy.dat";
    energy_data(o, rd.frames(), energy);
    shapes_script(shapes, rd, in, dir, shown, tips, made_shapes);
    tips_and_energy_script(gp, o, dir, shown, tips, energy);
    made = {dir + "/tips.png", dir + "/energy.png"};
  } else {  // (a sweep with --frames none)
    std::fprintf(stderr, "manyrods plot: %s has no frames: no tips, energies or shapes to plot\n", in.c_str());
    gp << "set terminal pngcairo size 1200,900 noenhanced\nset grid\n";
  }
  if (o.has_sweep && !o.sweep_parameters.empty()) sweep_script(gp, o, dir, made);
  if (!o.calibration_history.empty()) calibration_script(gp, o, dir, made);
  made.insert(made.end(), made_shapes.begin(), made_shapes.end());
  return run_gnuplot(dir, gp.str() + shapes.str(), made);
}

}  // namespace manyrods::cli
