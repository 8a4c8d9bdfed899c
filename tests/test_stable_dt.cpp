// stable_dt (host/core/analysis/stable_dt.h) against the exact linear limit 2/ω_max of the
// eigenproblem (tests/linear.h), and a check that it really is stable.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>

#include "cases.h"
#include "linear.h"

using namespace manyrods;
using namespace manyrods::cases;
using namespace manyrods::testing;

TEST(StableDt, GershgorinBoundIsBelowAndWithinTwoOfTheLinearLimit) {
  for (int n : {10, 50, 100}) {
    auto b = build_batch<double>({seed_cantilever(n, Damping::shear_extension(0.02, 0.02))});
    const double exact = 2 / modes(linearize(b, 0)).omega.maxCoeff();
    const StableDt est = stable_dt(b);
    std::printf("n %d: estimate %.4g s, linear limit %.4g s, explicit viscous %.4g s\n", n, est.elastic,
                exact, est.explicit_viscous);
    // Gershgorin bounds ω_max² from above: the estimate never exceeds the
    // limit (up to the 1e-9 accuracy of the finite-difference eigenproblem).
    EXPECT_LE(est.elastic, exact * (1 + 1e-9));
    EXPECT_GE(est.elastic, exact / 2);
    // The explicit viscous limit 2/(τ ω_max²) is far below (docs/model.md
    // "Kelvin–Voigt in time: explicit rates or implicit backward Euler").
    EXPECT_LT(est.explicit_viscous, est.elastic / 100);
  }
}

// ---- the true stability limit by bisection ---------------------------------

namespace {

// The three rods of docs/validation.md "5a stable_dt against the true limit",
// clamped at the root.
struct StabilityCase {
  const char* name;
  RodSpec rod;
  Vec3 gravity;
};

StabilityCase stability_case(int which, Damping damping) {
  if (which == 0) {  // seed cantilever, n = 50
    return {"seed cantilever n=50", seed_cantilever(50, damping), {0, 0, 0}};
  }
  if (which == 1) {  // a cable: seed density and ν, E = 1 GPa, L = 1 m, r = 5 mm, n = 100
    RodSpec s = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, 1.0, 100);
    s.name = "cable";
    s.section = Section::circle(0.005);
    s.material = {1000, 1e9, 0.3};
    s.damping = damping;
    s.clamped_root = true;
    return {"cable n=100", s, {0, 0, 0}};
  }
  // Human hair (5b), n = 32, clamped horizontally, under gravity
  return {"hair n=32", hair(32, false, damping), {0, 0, -9.81}};
}

// Stable = bounded for kProbeSteps steps from the rest state perturbed by
// small pseudo-random velocities and angular velocities (1e-6 m/s, 1e-6
// rad/s) in every free dof, so that every mode, the highest included, is
// excited. Blow-up criterion (checked every 50 steps): a non-finite state,
// a stretch/shear strain |Q(x_{k+1} − x_k)/l̂ − e3| above 0.1, or a relative
// rotation between neighbouring elements above 1 rad. The motion itself
// stays far below both (the perturbation makes strains ~1e-9; the hair
// bending under gravity turns its elements by < 0.2 rad each), while an
// unstable mode grows by |μ| ≥ 1 + 2√ε per step at ε above the limit and,
// from ~1e-9, crosses them within kProbeSteps steps (growth ≥ e²⁰) for
// ε ≳ 6e-6: the measured limit is above the true one by at most ~1e-5
// relative. (A displacement criterion would not do: the hair falls under
// gravity by 1e-3 L within 4000 steps of 1.5 µs.)
constexpr int kProbeSteps = 4000;

bool blown_up(const RodBatch<double>& b) {
  if (!(max_element_strain(b, 0) <= 0.1)) return true;  // also NaN
  const int n = b.elements(0);
  for (int e = 0; e < n; ++e) {
    const Mat3 q = b.frame(0, e);
    if (e + 1 < n) {
      const Mat3 r = b.frame(0, e + 1);
      double trace = 0;  // tr(R Qᵀ) = Σ_ij R_ij Q_ij
      for (int i = 0; i < 9; ++i) trace += r[i] * q[i];
      if (!((trace - 1) / 2 >= std::cos(1.0))) return true;
    }
  }
  return false;
}

template <Terms kT, Viscous kV>
bool stays_bounded(const RodBatch<double>& start, double dt) {
  RodBatch<double> b = start;
  const int n = b.elements(0);
  std::uint64_t seed = 12345;
  auto rnd = [&] {  // uniform in [−1, 1)
    seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
    return double(seed >> 11) / double(1ULL << 52) - 1.0;
  };
  for (int j = 1; j <= n; ++j) b.set_velocity(0, j, {1e-6 * rnd(), 1e-6 * rnd(), 1e-6 * rnd()});
  for (int e = 0; e < n; ++e) b.set_angular_velocity(0, e, {1e-6 * rnd(), 1e-6 * rnd(), 1e-6 * rnd()});
  for (int i = 1; i <= kProbeSteps; ++i) {
    step<kT, kV>(b, dt);
    if ((i % 50 == 0 || i == kProbeSteps) && blown_up(b)) return false;
  }
  return true;
}

struct Limit {
  double lo, hi;  // stays bounded at lo, blows up at hi; hi/lo − 1 ≤ 1e-3
  bool found;     // false: still bounded at the search's upper end (lo = that end)
};

// Bracket from `guess` by factors of 2 (at most up to guess·2^max_doublings),
// then bisect (geometrically) to 1e-3.
template <Terms kT, Viscous kV>
Limit true_limit(const RodBatch<double>& b, double guess, int max_doublings) {
  double lo = guess, hi = guess;
  if (stays_bounded<kT, kV>(b, guess)) {
    int k = 0;
    do {
      lo = hi;
      hi *= 2;
      if (++k > max_doublings) return {lo, INFINITY, false};
    } while (stays_bounded<kT, kV>(b, hi));
  } else {
    do {
      hi = lo;
      lo /= 2;
    } while (!stays_bounded<kT, kV>(b, lo));
  }
  while (hi / lo - 1 > 1e-3) {
    const double mid = std::sqrt(lo * hi);
    (stays_bounded<kT, kV>(b, mid) ? lo : hi) = mid;
  }
  return {lo, hi, true};
}

}  // namespace

TEST(StableDt, EstimateAgainstTheTrueLimitByBisection) {
  // Position Verlet, undamped: the estimate (Gershgorin bound of 2/ω_max)
  // is never above the true limit and at least half of it (5a).
  // "≤": est ≤ lo, where lo is a step that stayed bounded (lo is within
  // 1e-3 + 1e-5 of the true limit, see kProbeSteps). "≥ half": est ≥ hi/2.
  constexpr Terms kUndamped{true, true, true, true, false, true, false};
  for (int which = 0; which < 3; ++which) {
    const StabilityCase c = stability_case(which, Damping::none());
    const auto b = build_batch<double>({c.rod}, c.gravity);
    const double est = stable_dt<kUndamped>(b).elastic;
    const Limit lim = true_limit<kUndamped, Viscous::implicit>(b, est, 10);
    std::printf("%-22s undamped: estimate %.5g s, true limit in [%.6g, %.6g] s, ratio %.4f\n", c.name, est,
                lim.lo, lim.hi, est / lim.lo);
    ASSERT_TRUE(lim.found);
    EXPECT_LE(est, lim.lo) << c.name;
    EXPECT_GE(est, 0.5 * lim.hi) << c.name;
  }
}

TEST(StableDt, ImplicitKelvinVoigtNeverBelowTheElasticEstimate) {
  // Position Verlet with the implicit Kelvin–Voigt update, τ = 0.1 s
  // (τS = τE: viscous matrix D = τK at the straight state). The estimate
  // stable_dt().elastic ignores the damping, so it stays a safe bound:
  // bounded at the estimate. It is NOT within 2× of the true limit, and
  // should not be: for one mode the step (drift ½h, kick h, backward-Euler
  // viscous update, drift ½h) has trace (2 + r − z²)/(1 + r) and determinant
  // 1/(1 + r), with z = hω and r = hτω², so it is stable for z² ≤ 4 + 2r,
  // i.e. h ≤ τ + √(τ² + 4/ω²) > 2τ = 0.2 s for EVERY mode — far above the
  // elastic limit 2/ω_max. What limits the step is then accuracy (and the
  // nonlinear terms). Shown: still bounded at 64 × the estimate.
  constexpr Terms kKV{true, true, true, true, true, true, false};
  for (int which = 0; which < 3; ++which) {
    const StabilityCase c = stability_case(which, Damping::shear_extension(0.1, 0.1));
    const auto b = build_batch<double>({c.rod}, c.gravity);
    const double est = stable_dt<kKV>(b).elastic;
    const bool at_est = stays_bounded<kKV, Viscous::implicit>(b, est);
    const bool at_64 = stays_bounded<kKV, Viscous::implicit>(b, 64 * est);
    std::printf("%-22s implicit KV tau 0.1: estimate %.5g s; bounded at 1x: %d, at 64x: %d\n", c.name, est,
                at_est, at_64);
    EXPECT_TRUE(at_est) << c.name;
    EXPECT_TRUE(at_64) << c.name;
  }
}

TEST(StableDt, ExplicitViscousEstimateAgainstTheTrueLimit) {
  // Viscous::explicit_rate, τ = 0.1 s: the step is limited by the viscous
  // term. For one mode the step has trace 2 − r − z², determinant 1 − r, so
  // it is stable for z² + 2r ≤ 4, i.e. h ≤ 2/(τω²) / (1 + 1/(τω)²): the
  // estimate explicit_viscous = 2/(τ·ω_G²) (ω_G ≥ ω_max, Gershgorin) is
  // below it unless the bound is tight to 1/(τω)² (≤ 2e-6 here), and
  // within 2×. (The elastic limit is 1e3–1e7 × larger and plays no part.)
  constexpr Terms kKV{true, true, true, true, true, true, false};
  for (int which = 0; which < 3; ++which) {
    const StabilityCase c = stability_case(which, Damping::shear_extension(0.1, 0.1));
    const auto b = build_batch<double>({c.rod}, c.gravity);
    const StableDt est = stable_dt<kKV>(b);
    const double e = std::min(est.elastic, est.explicit_viscous);
    const Limit lim = true_limit<kKV, Viscous::explicit_rate>(b, e, 10);
    std::printf(
        "%-22s explicit KV tau 0.1: estimate %.5g s (elastic %.4g), true limit in [%.6g, %.6g] s, ratio "
        "%.4f\n",
        c.name, est.explicit_viscous, est.elastic, lim.lo, lim.hi, e / lim.lo);
    ASSERT_TRUE(lim.found);
    EXPECT_LE(e, lim.lo) << c.name;
    EXPECT_GE(e, 0.5 * lim.hi) << c.name;
  }
}

TEST(StableDt, StiffRodsHaveNoLimitButAnAccuracyStep) {
  // Stiff rods (RodSpec::stiff_implicit) integrate every elastic term in the
  // implicit solve, bending by the midpoint-corrected form
  // (kernels/viscous_implicit.h "Stiff rods"): no stable-step limit, so
  // stable_dt's `elastic` ignores them, and `accuracy` is the step
  // dt = "auto" takes for them, ¼/ω₄. Reference (independent): the fourth
  // clamped–free Euler–Bernoulli frequency ω₄ = (β₄L)² √(EI/ρA)/L² from the
  // hair's section and material, β₄L = 10.9955 (to 5 digits: 5e-6 relative).
  constexpr Terms kUndamped{true, true, true, true, false, true, false};
  const double pi = std::acos(-1.0), r = 40e-6, L = cases::kHairL;
  const double ei = 3.9e9 * pi * std::pow(r, 4) / 4, rho_a = 1300 * pi * r * r;
  const double w4 = 10.9955 * 10.9955 * std::sqrt(ei / rho_a) / (L * L);
  for (int n : {32, 64}) {
    const StableDt sd = stable_dt<kUndamped>(build_batch<double>({hair(n, true)}));
    std::printf("stiff hair n=%d: elastic %g, accuracy %.6g s (1/4 w4 = %.6g s)\n", n, sd.elastic, sd.accuracy,
                0.25 / w4);
    EXPECT_EQ(sd.elastic, INFINITY);
    EXPECT_NEAR(sd.accuracy, 0.25 / w4, 1e-5 * 0.25 / w4);
    EXPECT_EQ(sd.automatic(), sd.accuracy);
  }
  // with another rod: its limit stays the elastic one, the hair's step the accuracy one
  const auto mixed = build_batch<double>({hair(32, true), cases::seed_cantilever(10)});
  const StableDt sd = stable_dt<kUndamped>(mixed), cant = stable_dt<kUndamped>(build_batch<double>({cases::seed_cantilever(10)}));
  EXPECT_EQ(sd.elastic, cant.elastic);
  EXPECT_NEAR(sd.accuracy, 0.25 / w4, 1e-5 * 0.25 / w4);
  EXPECT_EQ(sd.automatic(), std::min(cant.elastic, sd.accuracy));
  // Linearly stable at any step: the probe (every mode excited, no gravity)
  // stays bounded at 1/240 s and 1/60 s, 7.5 and 30 times the flexural
  // limit that bounded the step while bending was explicit (5.6e-4 s at
  // n = 32, 1.4e-4 s at n = 64).
  for (int n : {32, 64})
    for (double dt : {1.0 / 240, 1.0 / 60})
      EXPECT_TRUE((stays_bounded<kUndamped, Viscous::implicit>(build_batch<double>({hair(n, true)}, {0, 0, 0}), dt)))
          << n << " " << dt;
}

TEST(StableDt, StiffHairSwingingUnderGravityStaysBoundedAtFrameRateSteps) {
  // The hard case of the stiff scheme: a hair released horizontal under
  // gravity, whose tip whips round as it swings under, kProbeSteps steps
  // (17 s at 1/240 s), n = 32 and 64. Undamped at 1/960 and 1/240 s: with
  // c = 0.3 in the bending correction it stays bounded; at c = ¼ (the
  // time-symmetric midpoint) it went unstable at 1/240 s
  // (kernels/viscous_implicit.h "Stiff rods"). The solve linearizes at the
  // frozen half-step geometry, so each step leaves a stretch/shear strain of
  // order (h|ω|)², which the next one removes: measured, up to 1.6e-2 (n = 32)
  // and 4e-2 (n = 64) at 1/240 s, and up to 7e-2 at 1/60 s, where the
  // probe's 0.1 criterion is crossed at times. With the Kelvin–Voigt damping
  // of the example scenes (τ = 1e-3 s) the whip is damped and the strain
  // stays below 1e-3 even at 1/60 s: bounded there too.
  constexpr Terms kUndamped{true, true, true, true, false, true, false};
  for (int n : {32, 64})
    for (double dt : {1.0 / 960, 1.0 / 240})
      EXPECT_TRUE((stays_bounded<kUndamped, Viscous::implicit>(build_batch<double>({hair(n, true)}, {0, 0, -9.81}), dt)))
          << n << " " << dt;
  for (int n : {32, 64})
    EXPECT_TRUE((stays_bounded<kAllTerms, Viscous::implicit>(
        build_batch<double>({hair(n, true, Damping::shear_extension(1e-3, 1e-3))}, {0, 0, -9.81}), 1.0 / 60)))
        << n;
}
