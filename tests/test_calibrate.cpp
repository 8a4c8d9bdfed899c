// tests/test_calibrate.cpp — the CMA-ES (host/scene/study/cmaes.h) and the
// calibration (include/manyrods/calibrate.h): --fit specs, measurements,
// recovery of known parameters, the Laplace uncertainty, an undetermined
// parameter flagged.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "host/scene/study/cmaes.h"
#include "manyrods/calibrate.h"
#include "manyrods/rng.h"
#include "manyrods/sampling.h"
#include "manyrods/scene.h"
#include "manyrods/sweep.h"

using namespace manyrods;
using namespace manyrods::scene;

namespace {

// CMA-ES on f from x0 with step s0 until its step is below tol; returns
// the best point and counts the generations.
template <class F>
std::vector<double> minimise(F&& f, int n, double s0, std::uint64_t seed, int& generations, int lambda = 0) {
  CmaEs es(n, std::vector<double>(std::size_t(n), 0.0), s0, lambda, seed);
  std::vector<double> best;
  double fb = HUGE_VAL;
  for (generations = 0; generations < 2000 && es.step() * es.max_axis() > 1e-12; ++generations) {
    const std::vector<std::vector<double>> x = es.ask();
    std::vector<double> v;
    for (const auto& p : x) {
      v.push_back(f(p));
      if (v.back() < fb) fb = v.back(), best = p;
    }
    es.tell(x, v);
  }
  return best;
}

}  // namespace

TEST(CmaEs, FindsTheMinimumOfAnIllConditionedQuadraticAndOfRosenbrocksFunction) {
  // Independent references: the minima are known in closed form. An
  // ellipsoid with axes 1 … 1e3 (condition 1e6) shifted to x* = (1, …, 1),
  // and Rosenbrock's valley (minimum at (1, …, 1)) in 4 dimensions; CMA-ES
  // learns the covariance, so both are reached to the step tolerance
  // (1e-12: x within 1e-9 is asserted, well above the round-off of f).
  auto ellipsoid = [](const std::vector<double>& x) {
    double f = 0;
    for (std::size_t i = 0; i < x.size(); ++i) f += std::pow(1e3, 2.0 * double(i) / double(x.size() - 1)) * (x[i] - 1) * (x[i] - 1);
    return f;
  };
  auto rosenbrock = [](const std::vector<double>& x) {
    double f = 0;
    for (std::size_t i = 0; i + 1 < x.size(); ++i)
      f += 100 * (x[i + 1] - x[i] * x[i]) * (x[i + 1] - x[i] * x[i]) + (1 - x[i]) * (1 - x[i]);
    return f;
  };
  int g1 = 0, g2 = 0;
  const std::vector<double> a = minimise(ellipsoid, 5, 0.5, 1, g1), b = minimise(rosenbrock, 4, 0.5, 2, g2);
  std::printf("ellipsoid (5 dims, condition 1e6): %d generations; Rosenbrock (4 dims): %d generations\n", g1, g2);
  for (double v : a) EXPECT_NEAR(v, 1.0, 1e-9);
  for (double v : b) EXPECT_NEAR(v, 1.0, 1e-7);  // (f ∝ |x − x*|² with a smallest curvature ~ 0.4: f's round-off 1e-16 allows 1e-8)
}

TEST(CmaEs, TheSameSeedGivesTheSameSearch) {
  // Regression of determinism: the random numbers come from the seed alone.
  auto sphere = [](const std::vector<double>& x) { return x[0] * x[0] + (x[1] - 0.3) * (x[1] - 0.3); };
  int g1 = 0, g2 = 0, g3 = 0;
  const std::vector<double> a = minimise(sphere, 2, 0.5, 7, g1), b = minimise(sphere, 2, 0.5, 7, g2),
                            c = minimise(sphere, 2, 0.5, 8, g3);
  EXPECT_EQ(a, b);
  EXPECT_EQ(g1, g2);
  EXPECT_NE(a, c);
}

TEST(CmaEs, ReflectionFoldsABoxSearchBackIntoTheUnitInterval) {
  EXPECT_DOUBLE_EQ(reflect_unit(0.25), 0.25);
  EXPECT_DOUBLE_EQ(reflect_unit(-0.25), 0.25);
  EXPECT_DOUBLE_EQ(reflect_unit(1.25), 0.75);
  EXPECT_DOUBLE_EQ(reflect_unit(2.25), 0.25);
  EXPECT_DOUBLE_EQ(reflect_unit(-1.5), 0.5);
}

TEST(Calibrate, FitSpecsParseAndBadOnesAreNamed) {
  const FitParameter a = parse_fit("rods.0.material.youngs_modulus=log:1e5:1e7");
  EXPECT_EQ(a.key, "rods.0.material.youngs_modulus");
  EXPECT_TRUE(a.log());
  EXPECT_DOUBLE_EQ(a.theta_lo(), std::log(1e5));
  EXPECT_NEAR(a.value(a.theta(2e6)), 2e6, 1e-6);
  const FitParameter b = parse_fit("rods.0.damping.tau_extension=0.01:0.1");
  EXPECT_FALSE(b.log());
  EXPECT_DOUBLE_EQ(b.theta_hi(), 0.1);
  const FitParameter c = parse_fit("rods.0.material.youngs_modulus=lognormal:1e6:0.3");
  EXPECT_TRUE(c.prior());
  EXPECT_NEAR(c.theta_hi(), std::log(1e6) + 1.2, 1e-12);
  auto message = [](const std::string& arg) {
    try {
      parse_fit(arg);
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_NE(message("rods.0.material.youngs_modulus").find("KEY=SPEC"), std::string::npos);
  EXPECT_NE(message("rods.0.material.youngs_modulus=log:0:1e7").find("lo > 0"), std::string::npos);
  EXPECT_NE(message("rods.0.material.youngs_modulus=3:1").find("empty"), std::string::npos);
  EXPECT_NE(message("rods.0.material.youngs_modulus=normal:1e6:0").find("no mass"), std::string::npos);
  EXPECT_NE(message("rods.0.material.youngs_modulus=a:b").find("'a' is not a finite number"), std::string::npos);
}

namespace {

// A small seed-like cantilever (n elements, 0.3 m) released from a tip
// force, damped, at a fixed step.
std::string beam(double E, double tau, int n = 10, double duration = 1.0, double tau_shear = 0.02) {
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "[simulation]\ndt = %s\nduration = %.17g\noutput_interval = 0.02\n"
                "[[rods]]\nname = \"beam\"\nelements = %d\nlength = 0.3\n"
                "initial_tip_force = [0.005, 0.0, 0.0]\n"
                "section = { shape = \"rectangle\", width = 0.01, height = 0.01 }\n"
                "material = { density = 1000.0, youngs_modulus = %.17g, poisson_ratio = 0.3 }\n"
                "damping = { tau_shear = %.17g, tau_extension = %.17g }\n",
                n == 10 ? "1e-4" : "2e-4", duration, n, E, tau_shear, tau);
  return buf;
}

// The tip's track of the beam (E, τ; n elements, over `duration`) every
// 0.02 s, from a run of it.
Measurements tip_track(double E, double tau, int n = 10, double duration = 1.0, double tau_shear = 0.02) {
  const std::string text = beam(E, tau, n, duration, tau_shear);
  Sweep sw = make_sweep(text, "beam.toml", {"rods.0.material.youngs_modulus"}, {{E}});
  Measurements m;
  m.path = "synthetic";
  Track t;
  t.name = "0:-1";
  t.rod = 0, t.node = n;
  for (int i = 1; i <= int(std::lround(duration / 0.02)); ++i) m.time.push_back(0.02 * i);
  Observable o;
  o.quantity = Observable::Quantity::position;
  o.node = n;
  o.reduce = Observable::Reduce::at;
  o.times = m.time;
  for (int a = 0; a < 3; ++a) {
    o.name = std::string("tip_") + "xyz"[a];
    o.component = a;
    sw.scene.observables.push_back(o);
  }
  RunOptions ro;
  ro.output = testing::TempDir() + "calibrate_truth.h5";
  ro.frames = RunOptions::Frames::none;
  const std::vector<double> v = observed_values(run_sweep(sw, ro).run.probes[0].observed);
  t.x.resize(m.time.size());
  for (std::size_t i = 0; i < m.time.size(); ++i)
    for (int a = 0; a < 3; ++a) t.x[i][std::size_t(a)] = v[std::size_t(a) * m.time.size() + i];
  m.tracks.push_back(t);
  return m;
}

}  // namespace

TEST(Calibrate, RecoversTheModulusAndRetardationTimeOfACantileverFromItsTipTrack) {
  // Self-consistency with an independent check of the optimum: measurements
  // from a run of the beam at E = 1e6 Pa, τE = 0.02 s (noiseless, the tip's
  // x, y, z every 0.02 s over 1 s); the fit searches E on [1e5, 1e7] and τE
  // on [0.002, 0.2] (both in log) from the middle of the box and must
  // recover both to 1e-4 relative (the noiseless target; the
  // residual's round-off, ~1e-15 m against tip motions of 1e-2 m, allows far
  // less). The parameter that does not act on a planar bending swing at this
  // noise (τS, shear and twist damping: σ = 0.1 mm given) is reported as not
  // determined by the data.
  const Measurements data = tip_track(1e6, 0.02);
  const std::string text = beam(3e5, 0.05);  // (the scene's own values are not the answer)
  CalibrateOptions opt;
  opt.seed = 3;
  opt.max_generations = 300;
  opt.tolerance = 1e-6;  // (1e-4 relative in E is 2e-5 of its log range)
  const Calibration c = calibrate(text, "beam.toml",
                                  {parse_fit("rods.0.material.youngs_modulus=log:1e5:1e7"),
                                   parse_fit("rods.0.damping.tau_extension=log:0.002:0.2")},
                                  data, opt);
  std::printf("fit: E = %.9g (rel %.2e), tauE = %.9g (rel %.2e), %d generations, %d runs, misfit %.3g\n", c.best[0],
              c.best[0] / 1e6 - 1, c.best[1], c.best[1] / 0.02 - 1, c.generations, c.evaluations, c.misfit);
  EXPECT_TRUE(c.converged);
  EXPECT_NEAR(c.best[0] / 1e6, 1.0, 1e-4);
  EXPECT_NEAR(c.best[1] / 0.02, 1.0, 1e-4);
  EXPECT_TRUE(c.determined[0] && c.determined[1]);

  CalibrateOptions noisy = opt;
  noisy.sigma = 1e-4;
  noisy.max_generations = 30;
  const Calibration u = calibrate(beam(3e5, 0.02), "beam.toml",
                                  {parse_fit("rods.0.material.youngs_modulus=log:1e5:1e7"),
                                   parse_fit("rods.0.damping.tau_shear=log:0.002:0.2")},
                                  data, noisy);
  for (const std::string& l : calibration_lines(u)) std::printf("  %s\n", l.c_str());
  EXPECT_TRUE(u.determined[0]);
  EXPECT_FALSE(u.determined[1]);
  EXPECT_NEAR(u.best[0] / 1e6, 1.0, 2 * u.sigma[0] / 1e6 + 1e-4);
}

TEST(Calibrate, TheReportedUncertaintyCoversTheTruthInNoisyTrials) {
  // A statistical test of the Laplace estimate (independent reference: the
  // known parameters). 20 trials: the tip track of a 6-element cantilever
  // (E = 1e6 Pa, τE = 0.02 s; 25 samples over 0.5 s) plus Gaussian noise of
  // σ = 0.5 mm (a fortieth of the swing; the seeds 1…20 through
  // manyrods/rng.h, so the test is the same on every machine), fitted with
  // that σ given. Where the estimate is right, each parameter lies within
  // its reported 2σ with probability 0.954; the test asks for ≥ 18 of 20
  // per parameter, which an exact estimate fails with probability 6 %
  // (Binomial(20, 0.046) ≥ 3) for a random set of seeds — these seeds are
  // fixed, so a failure here is a change of the result, to be understood.
  const double E = 1e6, tau = 0.02, sigma = 5e-4;
  // (τS = 0.005 s: τE's lower bound 2(1+ν)/3 τS = 0.0043 s lies far below
  // the truth, so the fits of τE are not cut off by it)
  const Measurements clean = tip_track(E, tau, 6, 0.5, 0.005);
  const std::string text = beam(3e5, 0.05, 6, 0.5, 0.005);
  int inside[2] = {0, 0};
  for (int trial = 1; trial <= 20; ++trial) {
    Measurements m = clean;
    Rng rng{std::uint64_t(1000 + trial)};
    for (auto& x : m.tracks[0].x)
      for (double& v : x) v += sigma * normal_quantile(rng.next() + 0x1.0p-54);
    m.tracks[0].sigma = sigma;
    CalibrateOptions opt;
    opt.seed = std::uint64_t(trial);
    opt.tolerance = 1e-4;  // (of the log ranges: a twentieth of E's σ, a hundredth of τE's)
    const Calibration c = calibrate(text, "beam.toml",
                                    {parse_fit("rods.0.material.youngs_modulus=log:1e5:1e7"),
                                     parse_fit("rods.0.damping.tau_extension=log:0.005:0.2")},
                                    m, opt);
    const double zE = (c.best[0] - E) / c.sigma[0], zt = (c.best[1] - tau) / c.sigma[1];
    std::printf("trial %2d: E = %.6g ± %.3g (z %+.2f), tauE = %.5g ± %.2g (z %+.2f), chi2/N = %.3f\n", trial, c.best[0],
                c.sigma[0], zE, c.best[1], c.sigma[1], zt, c.data_misfit / double(c.samples));
    inside[0] += std::abs(zE) <= 2;
    inside[1] += std::abs(zt) <= 2;
  }
  std::printf("within 2 sigma: E %d of 20, tauE %d of 20\n", inside[0], inside[1]);
  EXPECT_GE(inside[0], 18);
  EXPECT_GE(inside[1], 18);
}
