// tools/demo.cpp — the seed's §5 experiment (Linn, Lang & Tuganov 2013):
// a clamped 30 cm cantilever, 1 cm × 1 cm, E = 1 MPa, ν = 0.3, ρ = 1000,
// Kelvin–Voigt with τS = τE = τB = 0.02 s, pulled sideways by a 0.05 N tip
// force into static equilibrium, released, and simulated for 30 s without
// gravity. Prints key = value lines (SI units) and writes the tip trajectory.
//
// usage: manyrods-demo [--csv PATH] [--elements N] [--duration S] [--tau S]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "manyrods/manyrods.h"
#include "manyrods/statics.h"

using namespace manyrods;

namespace {

struct Peak {
  double t, x;
};

[[noreturn]] void usage(const char* msg) {
  std::fprintf(stderr, "manyrods-demo: %s\nusage: manyrods-demo [--csv PATH] [--elements N] [--duration S] [--tau S]\n", msg);
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  std::string csv = "tip_trajectory.csv";
  int n = 50;
  double duration = 30, tau = 0.02;
  for (int i = 1; i < argc; ++i) {
    auto value = [&](const char* name) {
      if (i + 1 >= argc) usage((std::string(name) + " needs a value").c_str());
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--csv")) csv = value("--csv");
    else if (!std::strcmp(argv[i], "--elements")) n = std::atoi(value("--elements"));
    else if (!std::strcmp(argv[i], "--duration")) duration = std::atof(value("--duration"));
    else if (!std::strcmp(argv[i], "--tau")) tau = std::atof(value("--tau"));
    else usage((std::string("unknown argument ") + argv[i]).c_str());
  }
  if (!(duration > 0) || !(tau >= 0)) usage("--duration must be > 0 and --tau >= 0");

  const double L = 0.3, a = 0.01, E = 1e6, rho = 1000, nu = 0.3, F = 0.05;
  RodSpec rod = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, L, n);
  rod.name = "seed cantilever";
  rod.section = Section::rectangle(a, a);
  rod.material = {rho, E, nu};
  rod.damping = Damping::shear_extension(tau, tau);  // τS = τE (= τB), seed §5
  rod.clamped_root = true;
  RodBatch<double> b;
  try {
    b = build_batch<double>({rod});
  } catch (const InputError& e) {
    std::fprintf(stderr, "manyrods-demo: %s\n", e.what());
    return 2;
  }

  // 1. Static equilibrium under the tip force (Newton, host/core/analysis/statics.h).
  b.set_node_force(0, n, {F, 0, 0});
  const StaticResult st = solve_static(b);
  if (!st.converged) {
    std::fprintf(stderr, "manyrods-demo: static equilibrium did not converge\n");
    return 1;
  }
  const double x0 = b.position(0, n)[0];
  std::printf("static_tip_deflection_m = %.9g\n", x0);

  // 2. Release and simulate. Implicit Kelvin–Voigt: the step is limited by
  // the elastic waves only (0.9 × stable_dt), not by τ.
  b.set_node_force(0, n, {0, 0, 0});
  const double dt = 0.9 * stable_dt(b).elastic;
  const long steps = std::lround(duration / dt);
  std::ofstream out(csv);
  if (!out) {
    std::fprintf(stderr, "manyrods-demo: cannot write %s\n", csv.c_str());
    return 1;
  }
  out << "time_s,tip_x_m,tip_y_m,tip_z_m\n";
  out.precision(10);
  auto write_tip = [&](double t) {
    const Vec3 p = b.position(0, n);
    out << t << ',' << p[0] << ',' << p[1] << ',' << p[2] << '\n';
  };
  write_tip(0);
  std::vector<Peak> peaks{{0, x0}};
  double pprev = x0, prev = x0, sim_seconds = 0;
  for (long i = 1; i <= steps; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    step(b, dt);
    sim_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double x = b.position(0, n)[0];
    if (!std::isfinite(x)) {
      const NonFinite nf = find_non_finite(b);
      std::fprintf(stderr, "manyrods-demo: non-finite state at step %ld (t = %g s), rod %d %s %d\n", i, i * dt,
                   nf.rod, nf.field.c_str(), nf.index);
      return 1;
    }
    if (i >= 2 && prev >= pprev && prev > x && prev > 0) {  // a maximum at step i − 1
      const double c2 = 0.5 * (pprev - 2 * prev + x), c1 = 0.5 * (x - pprev);
      const double off = -c1 / (2 * c2);  // parabola vertex, in steps
      peaks.push_back({(i - 1 + off) * dt, prev - c1 * c1 / (4 * c2)});
    }
    pprev = prev;
    prev = x;
    if (i % 10 == 0) write_tip(i * dt);
  }
  out.close();

  // 3. Period and damping ratio from the maxima once the amplitude is below
  // 25% of the initial deflection (linear regime), down to 1% of it.
  std::size_t first = 0;
  while (first < peaks.size() && peaks[first].x >= 0.25 * x0) ++first;
  std::size_t last = first;
  while (last + 1 < peaks.size() && peaks[last + 1].x > 0.01 * x0) ++last;
  if (first >= peaks.size() || last <= first) {
    std::fprintf(stderr, "manyrods-demo: too few oscillations below 25%% amplitude; run longer\n");
    return 1;
  }
  const double cycles = double(last - first);
  const double period = (peaks[last].t - peaks[first].t) / cycles;
  const double delta = std::log(peaks[first].x / peaks[last].x) / cycles;  // logarithmic decrement
  const double zeta = delta / std::sqrt(4 * std::numbers::pi * std::numbers::pi + delta * delta);
  std::printf("period_s = %.9g\n", period);
  std::printf("damping_ratio = %.9g\n", zeta);
  std::printf("element_steps_per_s = %.4g\n", double(steps) * n / sim_seconds);

  // Context: the linear theory (Euler–Bernoulli ω₁; docs/validation.md "3d
  // Modal damping ratio") and the seed's empirical rule (docs/validation.md
  // "8a Damping ratio of the seed cantilever").
  const double omega1 = 1.87510407 * 1.87510407 * std::sqrt(E * a * a * a * a / 12 / (rho * a * a * L * L * L * L));
  const double zeta_lin = tau * omega1 / 2;
  std::printf("linear_theory_damping_ratio = %.9g\n", zeta_lin);
  std::printf("linear_theory_period_s = %.9g\n", 2 * std::numbers::pi / (omega1 * std::sqrt(1 - zeta_lin * zeta_lin)));
  std::printf("seed_empirical_damping_ratio = %.9g\n", tau / (std::numbers::pi * 2 * std::numbers::pi / omega1));
  std::printf("cycles_measured = %g\n", cycles);
  std::printf("dt_s = %.6g\n", dt);
  std::printf("steps = %ld\n", steps);
  std::printf("tip_trajectory_csv = %s\n", csv.c_str());
  return 0;
}
