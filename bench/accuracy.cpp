// bench/accuracy.cpp — manyrods-accuracy: speed against error (bench/RESULTS.md
// "Speed against error (`tools/run-accuracy`)").
//
// Runs a grid of configurations (integrator, dt, element count, precision,
// viscous treatment, terms on/off, stiff-rod option) on two cases and
// measures, for each, the wall time, element-steps per second and the error
// of the tip trajectory against a converged reference:
//
//   cantilever  the seed cantilever (seed §5; docs/validation.md "0a Test
//               rods: the seed cantilever and human hair"), τS = τE = 0.02 s,
//               released from its static shape under a 0.05 N tip load,
//               1 s (half a period and more); error = max over 20 frames of
//               |tip − tip_ref| / L. Reference: Position Verlet, implicit
//               KV, double, at n = 160 and 320 and dt = stable_dt/4, combined
//               by Richardson extrapolation in dx (the scheme is second order
//               in space, tests/test_statics.cpp), so the error includes the
//               spatial one of coarse rods.
//   hair        the hair of docs/validation.md "5b Stiff human hair at
//               frame-rate steps" (n = 32) released horizontal under gravity,
//               1 s of swinging; reference: the plain explicit scheme at
//               half its stable step (≈ 2e-8 s), n = 32 (the error is the
//               time error of that discretization; the spatial one is not
//               included).
//
// Writes <out>/pareto.csv (case, integrator, precision, dt, elements,
// options, wall_s, element_steps_per_s, error) and <out>/pareto.md (the
// cheapest configuration reaching 1 %, 0.1 %, 0.01 %); tools/run-accuracy
// plots pareto.png with gnuplot. Single rods on one thread: the rates are
// per rod, not batch throughput (see manyrods-bench for that).
//
//   manyrods-accuracy [--out DIR] [--quick]
//   manyrods-accuracy --float-vs-double   (float against double on the benchmark scenes)
//   manyrods-accuracy --peer DIR          (references and manyrods' rows for a side-by-side
//                                          with another code at equal error, see peer())
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "scenes.h"
#include "host/core/advanced.h"

using namespace manyrods;

namespace {

using Trajectory = std::vector<Vec3>;  // tip position at each frame

constexpr int kFrames = 20;
constexpr double kT = 1.0;

struct Row {
  std::string case_name, integrator, precision;
  double dt;
  int elements;
  std::string options;
  double wall_s, rate, error;
};

// ---- the two cases ----------------------------------------------------------

constexpr double kCantL = 0.3, kHairL = 0.2;

RodSpec cantilever(int n, double tau) {
  RodSpec s = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, kCantL, n);
  s.name = "seed cantilever";
  s.section = Section::rectangle(0.01, 0.01);
  s.material = {1000, 1e6, 0.3};
  s.damping = Damping::shear_extension(tau, tau);
  s.clamped_root = true;
  return s;
}

// The human hair (docs/validation.md "0a Test rods: the seed cantilever and
// human hair"), n = 32, undamped (bench/scenes.h), optionally stiff.
RodSpec hair(bool stiff) {
  RodSpec s = bench::hair_strand(0, 0, false);
  s.stiff_implicit = stiff;
  return s;
}

// The released cantilever's start: static shape under 0.05 N at the tip.
RodBatch<double> cantilever_start(int n, double tau) {
  RodBatch<double> b = build_batch<double>({cantilever(n, tau)});
  b.set_node_force(0, n, {0.05, 0, 0});
  if (!solve_static(b).converged) throw std::runtime_error("cantilever: static solve did not converge");
  b.set_node_force(0, n, {0, 0, 0});
  return b;
}

template <class T>
void copy_state_from(RodBatch<T>& dst, const RodBatch<double>& src) {
  auto cp = [](auto& d, const auto& s) {
    for (std::size_t i = 0; i < d.size(); ++i) d[i] = T(s[i]);
  };
  for (int a = 0; a < 3; ++a) {
    cp(dst.state.node_x[a], src.state.node_x[a]);
    cp(dst.state.node_v[a], src.state.node_v[a]);
    cp(dst.state.elem_w[a], src.state.elem_w[a]);
  }
  for (int a = 0; a < 9; ++a) cp(dst.state.elem_Q[a], src.state.elem_Q[a]);
}

// ---- running one configuration ----------------------------------------------

enum class Kv { implicit, explicit_rate, off };

const char* kv_name(Kv k) {
  return k == Kv::implicit ? "kv=implicit" : k == Kv::explicit_rate ? "kv=explicit" : "kv=off";
}

template <Integrator kI, Kv kK, class T>
void advance_config(RodBatch<T>& b, T dt, std::int64_t steps) {
  constexpr Terms kOff = [] {
    Terms t;
    t.kelvin_voigt = false;
    return t;
  }();
  if constexpr (kK == Kv::off)
    advance<kOff, Viscous::implicit, kI>(b, dt, steps);
  else if constexpr (kK == Kv::explicit_rate)
    advance<kAllTerms, Viscous::explicit_rate, kI>(b, dt, steps);
  else
    advance<kAllTerms, Viscous::implicit, kI>(b, dt, steps);
}

// Steps `b` (already at its start state) through kFrames frames of kT / kFrames;
// dt is rounded down so that each frame is a whole number of steps.
template <Integrator kI, Kv kK, class T>
Trajectory run(RodBatch<T>& b, double dt_max, int tip_node, double* wall, std::int64_t* steps_out, double* dt_used,
               double duration = kT, int frames = kFrames) {
  const double frame = duration / frames;
  const std::int64_t per = std::int64_t(std::ceil(frame / dt_max - 1e-9));
  const T dt = T(frame / double(per));
  Trajectory tips;
  const auto t0 = std::chrono::steady_clock::now();
  for (int f = 0; f < frames; ++f) {
    advance_config<kI, kK>(b, dt, per);
    tips.push_back(b.position(0, tip_node));
  }
  *wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  *steps_out = per * frames;
  *dt_used = double(dt);
  return tips;
}

double max_error(const Trajectory& a, const Trajectory& ref, double L) {
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double d = std::hypot(a[i][0] - ref[i][0], a[i][1] - ref[i][1], a[i][2] - ref[i][2]);
    if (!(d <= worst)) worst = d;  // NaN → NaN
  }
  return worst / L;
}

// ---- the grid ---------------------------------------------------------------

struct Grid {
  std::vector<Row> rows;
  void add(Row r) {
    std::printf("%-10s %-15s %-6s dt %.3e n %3d %-24s wall %8.3f s  %.3e el-steps/s  error %.3e\n",
                r.case_name.c_str(), r.integrator.c_str(), r.precision.c_str(), r.dt, r.elements,
                r.options.c_str(), r.wall_s, r.rate, r.error);
    std::fflush(stdout);
    rows.push_back(std::move(r));
  }
};

template <Integrator kI, Kv kK, class T>
void cantilever_config(Grid& g, int n, double dt, double tau, const Trajectory& ref) {
  const RodBatch<double> start = cantilever_start(n, tau);
  RodBatch<T> b = build_batch<T>({cantilever(n, tau)});
  copy_state_from(b, start);
  double wall = 0, dt_used = 0;
  std::int64_t steps = 0;
  Trajectory tips;
  try {
    tips = run<kI, kK>(b, dt, n, &wall, &steps, &dt_used);
  } catch (const NonFiniteError&) {
    tips.assign(kFrames, {NAN, NAN, NAN});
  }
  g.add({"cantilever", kI == Integrator::pefrl ? "pefrl" : "position_verlet",
         std::is_same_v<T, float> ? "float" : "double", dt_used, n, kv_name(kK), wall,
         double(steps) * n / wall, max_error(tips, ref, kCantL)});
}

template <class T>
void hair_config(Grid& g, bool stiff, double dt, const Trajectory& ref) {
  RodBatch<T> b = build_batch<T>({hair(stiff)}, {0, 0, -9.81});
  double wall = 0, dt_used = 0;
  std::int64_t steps = 0;
  Trajectory tips;
  try {
    tips = run<Integrator::position_verlet, Kv::off>(b, dt, 32, &wall, &steps, &dt_used);
  } catch (const NonFiniteError&) {
    tips.assign(kFrames, {NAN, NAN, NAN});
  }
  g.add({"hair", "position_verlet", std::is_same_v<T, float> ? "float" : "double", dt_used, 32,
         stiff ? "stiff=implicit" : "stiff=off (explicit)", wall, double(steps) * 32 / wall,
         max_error(tips, ref, kHairL)});
}

// The stiff hair's steps: one a 60 Hz frame down to 5e-5 s (each divides
// the 0.05 s frame interval).
constexpr double kHairSteps[] = {1.0 / 60, 1.0 / 120, 1.0 / 240, 1.0 / 480, 1.0 / 960, 5e-4, 2.5e-4, 1e-4, 5e-5};

// The hair's reference: the plain explicit scheme at half its stable step
// (*dt_explicit: that stable step).
Trajectory hair_reference(double* dt_explicit) {
  std::printf("hair reference (plain explicit at half its stable step, n = 32, ~2 min) ...\n");
  std::fflush(stdout);
  RodBatch<double> hb = build_batch<double>({hair(false)}, {0, 0, -9.81});
  *dt_explicit = stable_dt(hb).elastic;
  double wall, dt_used;
  std::int64_t steps;
  const Trajectory href =
      run<Integrator::position_verlet, Kv::off>(hb, 0.5 * *dt_explicit, 32, &wall, &steps, &dt_used);
  std::printf("hair reference: dt %.3e s, %lld steps, %.1f s\n", dt_used, (long long)steps, wall);
  return href;
}

void write_summary(const std::vector<Row>& rows, const std::string& path) {
  std::ofstream md(path);
  md << "| case | error ≤ | cheapest configuration (wall time) | its error |\n|---|---|---|---|\n";
  for (const char* c : {"cantilever", "hair"})
    for (double tol : {1e-2, 1e-3, 1e-4}) {
      const Row* best = nullptr;
      for (const Row& r : rows)
        if (r.case_name == c && r.error <= tol && (!best || r.wall_s < best->wall_s)) best = &r;
      char line[512];
      if (best)
        std::snprintf(line, sizeof line, "| %s | %g %% | %s, %s, n = %d, dt = %.3g s, %s (%.3g s) | %.2e |\n", c,
                      tol * 100, best->integrator.c_str(), best->precision.c_str(), best->elements, best->dt,
                      best->options.c_str(), best->wall_s, best->error);
      else
        std::snprintf(line, sizeof line, "| %s | %g %% | none in the grid | — |\n", c, tol * 100);
      md << line;
      std::printf("%s", line);
    }
}

// Float against double on the benchmark scenes (bench/scenes.h, fewer rods:
// every rod of a scene behaves alike), Kelvin–Voigt off, at the benchmarks'
// step (half of stable_dt), after `steps` steps from the same start: the
// largest node distance over the batch relative to that rod's length.
void float_vs_double(int steps) {
  constexpr Terms kNoKV{true, true, true, true, false, true, true};
  struct Pick {
    const char* name;
    int rods;
  };
  std::printf("float vs double after %d steps at the benchmarks' dt (KV off):\n", steps);
  for (const Pick p : {Pick{"hair", 20}, Pick{"cable", 10}, Pick{"long", 1}, Pick{"mixed", 20}, Pick{"fibers", 20}}) {
    const bench::Scene sc = bench::make_scene(p.name, false, p.rods);
    RodBatch<double> d = build_batch<double>(sc.rods, sc.gravity);
    RodBatch<float> f = build_batch<float>(sc.rods, sc.gravity);
    const double dt = 0.5 * stable_dt<kNoKV>(d).elastic;
    step_n<kNoKV>(d, dt, steps);
    step_n<kNoKV>(f, float(dt), steps);
    double worst = 0, moved = 0;
    for (int r = 0; r < d.rod_count(); ++r) {
      const double L = std::hypot(sc.rods[r].nodes.back()[0] - sc.rods[r].nodes[0][0],
                                  sc.rods[r].nodes.back()[1] - sc.rods[r].nodes[0][1],
                                  sc.rods[r].nodes.back()[2] - sc.rods[r].nodes[0][2]);
      for (int j = 0; j <= d.elements(r); ++j) {
        const Vec3 a = d.position(r, j), b = f.position(r, j), o = sc.rods[r].nodes[j];
        worst = std::max(worst, std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]) / L);
        moved = std::max(moved, std::hypot(a[0] - o[0], a[1] - o[1], a[2] - o[2]) / L);
      }
    }
    std::printf("  %-7s dt %.3g s, %.3g s simulated: max |x_float - x_double| / L = %.2e (largest displacement %.2e L)\n",
                p.name, dt, dt * steps, worst, moved);
  }
}

// ---- side by side with another code at equal error (--peer DIR) -------------
//
// Two cases another Cosserat rod code (PyElastica) can set up identically,
// with manyrods' converged tip trajectories written to DIR so that the other
// code's driver measures its own error against the same reference:
//
//   struck      the seed material with a circular section of area 1e-4 m²
//               (radius 5.642 mm; PyElastica's sections are circles),
//               clamped at z = 0, straight along z, undamped, no gravity,
//               started with the first clamped–free bending mode's velocity
//               v(s) = v0 φ1(s)/φ1(L) along x (v0 = 0.1 m/s: tip amplitude
//               0.029 m ≈ 0.1 L), 2 s (1.1 periods), 40 frames. Reference:
//               Position Verlet, double, n = 160 and 320 at stable_dt/4,
//               Richardson in dx.
//   hair        the hair strand of case (ii), 1 s, 20 frames, its reference
//               (plain explicit at half the stable step, n = 32).
//
// Writes DIR/reference_struck.csv, DIR/reference_hair.csv (frame, t, x, y, z)
// and DIR/manyrods.csv (code, case, precision, dt, elements, wall_s,
// sim_s_per_wall_s, error): manyrods' own grid, one rod on one thread.

constexpr double kStruckT = 2.0, kStruckV0 = 0.1;
constexpr int kStruckFrames = 40;

// φ1(s) of the clamped–free Euler–Bernoulli beam, βL = 1.8751040687.
double mode1(double s) {
  const double bl = 1.8751040687, x = bl * s / kCantL;
  const double sigma = (std::cosh(bl) + std::cos(bl)) / (std::sinh(bl) + std::sin(bl));
  return std::cosh(x) - std::cos(x) - sigma * (std::sinh(x) - std::sin(x));
}

RodSpec struck_cantilever(int n) {
  RodSpec s = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, kCantL, n);
  s.name = "struck cantilever";
  s.section = Section::circle(std::sqrt(1e-4 / std::acos(-1.0)));
  s.material = {1000, 1e6, 0.3};
  s.clamped_root = true;
  s.velocities.resize(std::size_t(n) + 1);
  for (int j = 0; j <= n; ++j) s.velocities[j] = {kStruckV0 * mode1(kCantL * j / n) / mode1(kCantL), 0, 0};
  return s;
}

void write_trajectory(const Trajectory& tips, double duration, const std::string& path) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path);
  f << "frame,t,x,y,z\n";
  f.precision(17);
  for (std::size_t i = 0; i < tips.size(); ++i)
    f << i << ',' << duration * double(i + 1) / double(tips.size()) << ',' << tips[i][0] << ',' << tips[i][1] << ','
      << tips[i][2] << '\n';
}

int peer(const std::string& dir) {
  std::ofstream rows(dir + "/manyrods.csv");
  if (!rows) {
    std::fprintf(stderr, "manyrods-accuracy: cannot write %s/manyrods.csv\n", dir.c_str());
    return 1;
  }
  rows << "code,case,precision,dt,elements,wall_s,sim_s_per_wall_s,error\n";
  auto row = [&](const char* c, const char* prec, double dt, int n, double wall, double duration, double err) {
    std::printf("manyrods %-7s %-6s dt %.3e n %4d wall %8.3f s  %.3e sim s/wall s  error %.3e\n", c, prec, dt, n,
                wall, duration / wall, err);
    std::fflush(stdout);
    rows << "manyrods," << c << ',' << prec << ',' << dt << ',' << n << ',' << wall << ',' << duration / wall << ','
         << err << '\n';
  };
  // (a) the struck cantilever
  auto struck = [&](auto precision, int n, double dt_max, double* wall, double* dt_used) {
    using T = decltype(precision);
    RodBatch<T> b = build_batch<T>({struck_cantilever(n)}, {0, 0, 0});
    std::int64_t steps;
    return run<Integrator::position_verlet, Kv::off>(b, dt_max, n, wall, &steps, dt_used, kStruckT, kStruckFrames);
  };
  auto struck_dt = [](int n) { return stable_dt(build_batch<double>({struck_cantilever(n)}, {0, 0, 0})).elastic; };
  double wall, dt_used;
  const Trajectory r1 = struck(0.0, 160, struck_dt(160) / 4, &wall, &dt_used);
  const Trajectory r2 = struck(0.0, 320, struck_dt(320) / 4, &wall, &dt_used);
  Trajectory ref(r1.size());
  for (std::size_t f = 0; f < ref.size(); ++f)
    for (int d = 0; d < 3; ++d) ref[f][d] = (4 * r2[f][d] - r1[f][d]) / 3;
  std::printf("struck reference: n = 160 vs 320 differ by %.3e L; Richardson correction %.3e L\n",
              max_error(r1, r2, kCantL), max_error(r2, ref, kCantL));
  write_trajectory(ref, kStruckT, dir + "/reference_struck.csv");
  for (int n : {10, 20, 40, 80, 160}) {
    const double dt = 0.9 * struck_dt(n);
    Trajectory t = struck(0.0, n, dt, &wall, &dt_used);
    row("struck", "double", dt_used, n, wall, kStruckT, max_error(t, ref, kCantL));
    t = struck(0.0f, n, dt, &wall, &dt_used);
    row("struck", "float", dt_used, n, wall, kStruckT, max_error(t, ref, kCantL));
  }
  // (b) the hair strand: case (ii)'s configurations, the plain explicit one
  // near its limit as PyElastica steps the strand
  double dt_exp;
  const Trajectory href = hair_reference(&dt_exp);
  write_trajectory(href, kT, dir + "/reference_hair.csv");
  Grid g;
  hair_config<double>(g, false, 0.9 * dt_exp, href);
  for (double dt : kHairSteps) {
    hair_config<double>(g, true, dt, href);
    hair_config<float>(g, true, dt, href);
  }
  for (const Row& r : g.rows)
    row(r.options == "stiff=implicit" ? "hair" : "hair-explicit", r.precision.c_str(), r.dt, r.elements, r.wall_s,
        kT, r.error);
  std::printf("wrote %s/reference_struck.csv, reference_hair.csv, manyrods.csv\n", dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = "bench/results/unknown";
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) {
      out = argv[++i];
    } else if (!std::strcmp(argv[i], "--quick")) {
      quick = true;
    } else if (!std::strcmp(argv[i], "--float-vs-double")) {
      float_vs_double(20000);
      return 0;
    } else if (!std::strcmp(argv[i], "--peer") && i + 1 < argc) {
      return peer(argv[i + 1]);
    } else {
      std::fprintf(stderr, "usage: manyrods-accuracy [--out DIR] [--quick] | --float-vs-double | --peer DIR\n");
      return 2;
    }
  }
  const double tau = 0.02;
  Grid g;

  // ---- (i) cantilever: Richardson reference from n = 160 and 320 --------------
  std::printf("cantilever reference (n = 160 and 320, dt = stable_dt/4, Richardson in dx) ...\n");
  std::fflush(stdout);
  auto reference_at = [&](int n) {
    RodBatch<double> b = cantilever_start(n, tau);
    const double dt = stable_dt(b).elastic / 4;
    double wall, dt_used;
    std::int64_t steps;
    return run<Integrator::position_verlet, Kv::implicit>(b, dt, n, &wall, &steps, &dt_used);
  };
  const int n_fine = quick ? 40 : 160;
  const Trajectory r1 = reference_at(n_fine), r2 = reference_at(2 * n_fine);
  Trajectory cref(kFrames);
  for (int f = 0; f < kFrames; ++f)
    for (int d = 0; d < 3; ++d) cref[f][d] = (4 * r2[f][d] - r1[f][d]) / 3;
  std::printf("reference: n = %d vs %d differ by %.3e L; Richardson correction %.3e L\n", n_fine, 2 * n_fine,
              max_error(r1, r2, kCantL), max_error(r2, cref, kCantL));

  const std::vector<int> ns = quick ? std::vector<int>{10, 20} : std::vector<int>{10, 20, 40, 80, 120};
  const std::vector<double> factors = quick ? std::vector<double>{0.9, 0.1} : std::vector<double>{0.9, 0.3, 0.1};
  for (int n : ns) {
    const StableDt sd = stable_dt(build_batch<double>({cantilever(n, tau)}));
    for (double f : factors) {
      const double dt = f * sd.elastic;
      cantilever_config<Integrator::position_verlet, Kv::implicit, double>(g, n, dt, tau, cref);
      cantilever_config<Integrator::position_verlet, Kv::implicit, float>(g, n, dt, tau, cref);
      cantilever_config<Integrator::pefrl, Kv::implicit, double>(g, n, dt, tau, cref);
      cantilever_config<Integrator::pefrl, Kv::implicit, float>(g, n, dt, tau, cref);
    }
    // the explicit viscous rate at its own limit (the accuracy reference of
    // the viscous treatment), and Kelvin–Voigt off (what ignoring damping costs)
    const double dte = 0.9 * std::min(sd.elastic, sd.explicit_viscous);
    cantilever_config<Integrator::position_verlet, Kv::explicit_rate, double>(g, n, dte, tau, cref);
    cantilever_config<Integrator::position_verlet, Kv::explicit_rate, float>(g, n, dte, tau, cref);
    cantilever_config<Integrator::position_verlet, Kv::off, double>(g, n, 0.9 * sd.elastic, tau, cref);
  }

  // ---- (ii) hair: resolved explicit reference, n = 32 -------------------------
  if (!quick) {
    double dt_exp;
    const Trajectory href = hair_reference(&dt_exp);
    for (double dt : kHairSteps) {
      hair_config<double>(g, true, dt, href);
      hair_config<float>(g, true, dt, href);
    }
    hair_config<double>(g, false, 0.9 * dt_exp, href);
    hair_config<float>(g, false, 0.9 * dt_exp, href);
  }

  const std::string csv = out + "/pareto.csv";
  std::ofstream f(csv);
  if (!f) {
    std::fprintf(stderr, "manyrods-accuracy: cannot write %s\n", csv.c_str());
    return 1;
  }
  f << "case,integrator,precision,dt,elements,options,wall_s,element_steps_per_s,error\n";
  f.precision(6);
  for (const Row& r : g.rows)
    f << r.case_name << ',' << r.integrator << ',' << r.precision << ',' << r.dt << ',' << r.elements << ','
      << r.options << ',' << r.wall_s << ',' << r.rate << ',' << r.error << '\n';
  std::printf("wrote %s\n", csv.c_str());
  write_summary(g.rows, out + "/pareto.md");
  return 0;
}
