// Rods in a fluid (include/manyrods/fluid.h, kernels/fluid.h; docs/validation.md
// "7k Drag, buoyancy and wind"): terminal velocities with linear and
// quadratic drag and with buoyancy, at steps far beyond the drag's own time
// scale; a cantilever in a slow cross-flow against q·L⁴/(8EI); the wind the
// rods feel is the documented field; the turbulent part's statistics;
// Position Verlet's order with drag; bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "cases.h"

using namespace manyrods;

namespace {

constexpr double kPi = std::numbers::pi;

// A free round rod (r = 1 cm, ρ = 1000, E = 1e6), 1 m along `direction`.
RodSpec free_rod(const Vec3& direction, int n = 10) {
  const Vec3 normal = direction[2] != 0 ? Vec3{1, 0, 0} : Vec3{0, 0, 1};
  RodSpec s = RodSpec::straight({0, 0, 0}, direction, normal, 1.0, n);
  s.name = "rod";
  s.section = Section::circle(0.01);
  s.material = {1000, 1e6, 0.3};
  return s;
}

// Its velocity (node 0) after `t` seconds of falling under gravity −e3, at
// half the elastic stable step (2.3e-4 s).
double fall(RodSpec s, const Fluid& f, double t) {
  RodBatch<double> b = build_batch<double>({s}, {0, 0, -9.81});
  set_fluid(b, f);
  const double dt = 0.5 * stable_dt(b).elastic;
  EXPECT_GT(dt, 2e-4);
  EXPECT_TRUE(b.any_fluid());
  advance<kNoKelvinVoigt>(b, dt, std::int64_t(std::lround(t / dt)));
  for (int j = 0; j <= s.elements(); ++j)
    EXPECT_NEAR(b.velocity(0, j)[2], b.velocity(0, 0)[2], 1e-9 * std::abs(b.velocity(0, 0)[2]))
        << "a straight rod falls rigidly";
  return b.velocity(0, 0)[2];
}

}  // namespace

TEST(Fluid, LinearDragGivesTheTerminalVelocityAtAnyStep) {
  // Broadside: v = m g/(c⊥ L); along its axis: m g/(c∥ L). c⊥ = 1e4 N·s/m²
  // gives a drag time m/(c⊥L) = 3e-5 s, 8 × below the step: an explicit
  // drag force would blow up at h > 2·3e-5 s; the exact per-node flow gives
  // the terminal velocity as its fixed point.
  const double rhoA = 1000 * kPi * 1e-4, g = 9.81;
  RodSpec s = free_rod({1, 0, 0});
  s.drag.normal = 1e4;
  s.drag.tangential = 5e3;
  const double v = fall(s, Fluid{}, 0.2);
  EXPECT_NEAR(v, -rhoA * g / 1e4, 1e-9 * rhoA * g / 1e4);  // (to round-off over 870 steps)
  RodSpec axial = free_rod({0, 0, 1});
  axial.drag = s.drag;
  EXPECT_NEAR(fall(axial, Fluid{}, 0.2), -rhoA * g / 5e3, 1e-9 * rhoA * g / 5e3);
  // buoyancy: the displaced mass ρ_f A pushes up; (ρ − ρ_f) A g / c⊥
  Fluid water;
  water.density = 400;
  EXPECT_NEAR(fall(s, water, 0.2), -(1000 - 400) * kPi * 1e-4 * g / 1e4, 1e-9 * rhoA * g / 1e4);
}

TEST(Fluid, FloatBatchesReachTheSameTerminalVelocity) {
  // the fluid stage in float (its own e^{−z} to 1.2e-7): the fixed point to
  // float's round-off
  RodSpec s = free_rod({1, 0, 0});
  s.drag.normal = 1e4;
  s.drag.cd_normal = 1.2;
  Fluid air;
  air.density = 1.2;
  RodBatch<float> b = build_batch<float>({s}, {0, 0, -9.81});
  set_fluid(b, air);
  const float dt = 0.5f * float(stable_dt(b).elastic);
  advance<kNoKelvinVoigt>(b, dt, std::int64_t(0.2 / dt));
  // c⊥v + ½ρC d v² = (ρ − ρ_f) A g per length
  const double w = (1000 - 1.2) * kPi * 1e-4 * 9.81, q = 0.5 * 1.2 * 1.2 * 0.02;
  const double v = (-1e4 + std::sqrt(1e8 + 4 * q * w)) / (2 * q);
  for (int j = 0; j <= s.elements(); ++j) EXPECT_NEAR(-b.velocity(0, j)[2], v, 1e-5 * v) << "node " << j;
}

TEST(Fluid, QuadraticDragGivesTheTerminalVelocity) {
  // Broadside, v = sqrt(2 m g/(ρ_f C⊥ d L)), buoyancy off (so that the
  // law is the issue's). Reached after ~10 drag times (2v/g ≈ 0.1 s).
  RodSpec s = free_rod({1, 0, 0});
  s.drag.cd_normal = 1.2;
  s.drag.buoyancy = false;
  Fluid air;
  air.density = 1.2;
  const double rhoA = 1000 * kPi * 1e-4;
  const double v = std::sqrt(2 * rhoA * 9.81 / (1.2 * 1.2 * 0.02));
  const double got = fall(s, air, 12 * 2 * v / 9.81);
  std::printf("quadratic drag: terminal velocity %.6f m/s against %.6f m/s\n", -got, v);
  EXPECT_NEAR(-got, v, 1e-6 * v);
}

namespace {

// A cantilever (clamped root, along e3, no gravity) in a uniform flow U e1
// with linear drag c⊥, relaxed under the drag itself (≈ critically damped):
// its tip deflection.
double cross_flow(int n, double* expected) {
  RodSpec s = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, 1.0, n);
  s.section = Section::circle(0.01);
  s.material = {1000, 1e7, 0.3};
  s.clamped_root = true;
  s.drag.normal = 1.1;
  RodBatch<double> b = build_batch<double>({s}, {0, 0, 0});
  const RodInfo& i = b.rods[0];
  const double EI = i.elastic.E * i.section.I1, kGA = i.section.shear_factor1 * i.elastic.G * i.section.area;
  const double q = 8 * EI * 1e-3;  // a tip deflection of 1e-3 L
  Fluid f;
  f.velocity = {q / 1.1, 0, 0};
  set_fluid(b, f);
  *expected = q / (8 * EI) + q / (2 * kGA);
  const double dt = 0.5 * stable_dt(b).elastic;
  advance<kNoKelvinVoigtNoGravity>(b, dt, std::int64_t(14.0 / dt));
  return b.position(0, n)[0];
}

}  // namespace

TEST(Fluid, CantileverInASlowCrossFlowDeflectsByqL4Over8EI) {
  // The lumped load converges at O(dx²); Richardson's extrapolation of
  // n = 16 and 32 removes that term, leaving the O((w/L)²) = 1e-6 of the
  // small-deflection theory and the unrelaxed part (e^{−ωt} ≈ 1e-8).
  double expected = 0;
  const double w16 = cross_flow(16, &expected), w32 = cross_flow(32, &expected);
  const double rich = (4 * w32 - w16) / 3;
  std::printf("cantilever in cross-flow: tip %.7e (n = 16), %.7e (32), extrapolated %.7e, theory %.7e m\n", w16,
              w32, rich, expected);
  EXPECT_LT(std::abs(w32 - expected), std::abs(w16 - expected));
  EXPECT_NEAR(rich, expected, 2e-5 * expected);
}

TEST(Fluid, RodsFeelTheDocumentedWindField) {
  // With a drag so large that e^{−λh} underflows (and a/λ ≈ 1e-12 m/s), a
  // node's velocity after a step is the fluid's velocity at the kick (its
  // position after the first half drift, t + h/2): Fluid::velocity_at, the
  // field documented.
  RodSpec s = free_rod({1, 0, 0}, 8);
  s.drag.normal = s.drag.tangential = 1e12;
  Fluid f;
  f.times = {0, 1};
  f.velocities = {{1, 0, 0}, {3, 2, 0}};
  f.turbulence.intensity = 0.5;
  f.turbulence.length_scale = 0.3;
  f.turbulence.time_scale = 0.7;
  f.turbulence.modes = 24;
  f.turbulence.seed = 7;
  RodBatch<double> b = build_batch<double>({s}, {0, 0, 0});
  set_fluid(b, f);
  const double h = 1e-4;
  for (int i = 0; i < 200; ++i) step<kNoKelvinVoigtNoGravity>(b, h);
  const double t = b.state.time;
  // the last kick's positions: the end positions less the last half drift
  for (int j = 0; j <= 8; ++j) {
    const Vec3 x = b.position(0, j), v = b.velocity(0, j);
    const Vec3 xk{x[0] - 0.5 * h * v[0], x[1] - 0.5 * h * v[1], x[2] - 0.5 * h * v[2]};
    const Vec3 u = f.velocity_at(xk, t - 0.5 * h);
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(v[d], u[d], 1e-9) << "node " << j << " component " << d;
  }
  const Vec3 m = f.mean_velocity(0.25);
  EXPECT_DOUBLE_EQ(m[0], 1.5);
  EXPECT_DOUBLE_EQ(m[1], 0.5);
  EXPECT_DOUBLE_EQ(f.mean_velocity(-1)[0], 1.0);
  EXPECT_DOUBLE_EQ(f.mean_velocity(5)[1], 2.0);
  // the turbulent pattern is carried by X(t) = ∫Ū dt: 2 m by t = 1 s along
  // x (1 → 3 m/s), 1 m along y; then 3 and 2 m/s held
  const Vec3 X1 = f.mean_displacement(1), X3 = f.mean_displacement(3);
  EXPECT_NEAR(X1[0], 2.0, 1e-15);
  EXPECT_NEAR(X1[1], 1.0, 1e-15);
  EXPECT_NEAR(X3[0], 8.0, 1e-14);
  EXPECT_NEAR(X3[1], 5.0, 1e-14);
  EXPECT_NEAR(f.mean_displacement(0.5)[0], 0.5 * (1 + 2) * 0.5, 1e-15);
}

TEST(Fluid, TurbulenceHasItsIntensityIsDivergenceFreeAndSeeded) {
  Fluid f;
  f.turbulence.intensity = 0.8;
  f.turbulence.length_scale = 0.5;
  f.turbulence.time_scale = 2;
  f.turbulence.modes = 32;
  f.turbulence.seed = 3;
  // Σ_m |a_m|²/2 = 3 I² exactly; sampled at 40,000 points the mean of |U′|²
  // has a relative sampling error of ≈ sqrt(2/N_eff): 1.5 % at 4σ here
  double sum = 0;
  std::uint64_t z = 12345;
  auto uni = [&] {
    z = z * 6364136223846793005ull + 1442695040888963407ull;
    return double(z >> 11) * 0x1.0p-53;
  };
  const int N = 40000;
  double div = 0, scale = 0;
  for (int i = 0; i < N; ++i) {
    const Vec3 x{10 * uni(), 10 * uni(), 10 * uni()};
    const double t = 100 * uni();
    const Vec3 u = f.velocity_at(x, t);
    sum += u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
    if (i < 200) {  // central differences of ∂u_d/∂x_d
      const double e = 1e-5;
      double d = 0;
      for (int a = 0; a < 3; ++a) {
        Vec3 p = x, m = x;
        p[a] += e;
        m[a] -= e;
        d += (f.velocity_at(p, t)[a] - f.velocity_at(m, t)[a]) / (2 * e);
      }
      div = std::max(div, std::abs(d));
      scale = std::max(scale, 0.8 * 2 * kPi / 0.5 * 2);
    }
  }
  const double ms = sum / N;
  std::printf("turbulence: mean |U'|^2 = %.4f against 3 I^2 = %.4f; max |div U| %.2e (scale %.1f 1/s)\n", ms,
              3 * 0.64, div, scale);
  EXPECT_NEAR(ms, 3 * 0.64, 0.015 * 3 * 0.64);
  EXPECT_LT(div, 1e-6 * scale);
  const std::vector<TurbulentMode> a = turbulent_modes(f.turbulence), b = turbulent_modes(f.turbulence);
  ASSERT_EQ(a.size(), 32u);
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].phase, b[i].phase);
  Fluid g = f;
  g.turbulence.seed = 4;
  EXPECT_NE(turbulent_modes(g.turbulence)[0].phase, a[0].phase);
}

namespace {

// A cantilever swinging under gravity with linear drag in a uniform wind:
// node positions at 8 frames over 0.2 s.
std::vector<Vec3> windy(double h, double T, int frames) {
  RodSpec s = cases::seed_cantilever(16);
  s.nodes = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, cases::kL, 16).nodes;
  s.frames = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, cases::kL, 16).frames;
  s.drag.normal = 0.05;
  s.drag.tangential = 0.02;
  RodBatch<double> b = build_batch<double>({s}, {0, 0, -9.81});
  Fluid f;
  f.velocity = {0, 0.5, 0.2};
  set_fluid(b, f);
  std::vector<Vec3> out;
  const int per = int(std::lround(T / frames / h));
  for (int i = 0; i < frames; ++i) {
    step_n<kNoKelvinVoigt>(b, h, per);
    for (int j = 0; j <= 16; j += 4) out.push_back(b.position(0, j));
  }
  return out;
}

}  // namespace

TEST(Fluid, LinearDragKeepsPositionVerletSecondOrder) {
  const double h = 0.5 * stable_dt(build_batch<double>({cases::seed_cantilever(16)})).elastic;
  const auto err = cases::time_errors(h, 0.2, 8, [](double dt) { return windy(dt, 0.2, 8); });
  for (double o : cases::time_orders(err, "cantilever in wind with drag")) EXPECT_NEAR(o, 2.0, 0.15);
}

TEST(Fluid, BadFluidsAndCoefficientsAreNamed) {
  auto expect_error = [](const Fluid& f, const std::string& what) {
    RodBatch<double> b = build_batch<double>({cases::seed_cantilever(4)});
    try {
      set_fluid(b, f);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  Fluid f;
  f.density = -1;
  expect_error(f, "fluid.density = -1: must be a finite number >= 0");
  f = Fluid{};
  f.times = {0, 1};
  f.velocities = {{0, 0, 0}};
  expect_error(f, "fluid.velocities: 1 given, one per time (2) needed");
  f.velocities = {{0, 0, 0}, {1, 0, 0}};
  f.times = {1, 1};
  expect_error(f, "fluid.times[1] = 1: times must increase strictly");
  f = Fluid{};
  f.turbulence.intensity = 1;
  f.turbulence.modes = 0;
  expect_error(f, "fluid.turbulence.modes = 0: must be in [1, 256]");
  f.turbulence.modes = 8;
  f.turbulence.length_scale = 0;
  expect_error(f, "fluid.turbulence.length_scale = 0: must be a finite number > 0");
  // PEFRL's backward kicks would amplify the drag: refused
  RodSpec s = cases::seed_cantilever(4);
  s.drag.normal = 1;
  RodBatch<double> b = build_batch<double>({s});
  set_fluid(b, Fluid{});
  EXPECT_THROW(step_pefrl(b, 1e-5), std::invalid_argument);
}
