// docs/validation.md "2e A beam clamped at both ends" — a rod whose tip is
// clamped as well as its root (RodSpec::clamped_tip): the clamped–clamped
// bending frequencies (linearized eigenproblem and free vibration), the sag
// under a uniform load against beam theory, the dissipation identity through
// the implicit solve, and the clamp holding exactly in every integrator.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "cases.h"
#include "energy_budget.h"
#include "linear.h"

using namespace manyrods;
using namespace manyrods::cases;
using namespace manyrods::testing;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr Terms kUndamped{true, true, true, true, false, false, false};
constexpr Terms kKV{true, true, true, true, true, false, false};

// The seed beam (docs/validation.md base material), clamped at both ends.
RodSpec seed_beam(int n, Damping damping = Damping::none()) {
  RodSpec s = seed_cantilever(n, damping);
  s.name = "seed beam, clamped-clamped";
  s.clamped_tip = true;
  return s;
}

// Rectangle: Cowper's shear coefficient (host/core/model/material.cpp).
constexpr double kKappa = 10 * (1 + kNu) / (12 + 11 * kNu);

std::vector<double> bending_x(int n) {
  auto b = build_batch<double>({seed_beam(n)});
  const Linearization lin = linearize(b, 0);
  return modes_of(lin, modes(lin), 0, 0);
}

}  // namespace

TEST(ClampedEnds, BendingFrequenciesOfAClampedClampedBeam) {
  // Euler–Bernoulli clamped–clamped: cosh βL cos βL = 1, β₁L = 4.73004074,
  // β₂L = 7.85320462.
  const double beta_l[2] = {4.73004074, 7.85320462};
  const std::vector<double> a25 = bending_x(25), a50 = bending_x(50), a100 = bending_x(100);
  for (int k = 0; k < 2; ++k) {
    const double eb = euler_bernoulli_omega(beta_l[k]);
    SCOPED_TRACE(::testing::Message() << "mode " << k + 1 << ": EB " << eb << ", n = 25/50/100: " << a25[k] << " "
                                    << a50[k] << " " << a100[k]);
    // Discretization O(dx²): the observed order from n = 25/50/100 within ±0.2
    // (as for the cantilever, docs/validation.md 2a).
    const double e1 = a25[k] - a50[k], e2 = a50[k] - a100[k];
    EXPECT_NEAR(std::log2(e1 / e2), 2.0, 0.2);
    // The continuum limit (Richardson) is a Timoshenko beam: shear and rotary
    // inertia lower ω below Euler–Bernoulli by about ½(β r_g)²(1 + E/(κG)),
    // r_g² = I/A; assert 0 < lowering < twice that estimate.
    const double cont = a100[k] - e2 / 3;
    const double beta = beta_l[k] / kL;
    const double estimate = 0.5 * beta * beta * (kI / (kA * kA)) * (1 + kE / (kKappa * kG));
    const double lowering = (eb - cont) / eb;
    std::printf("clamped-clamped mode %d: EB %.6f, continuum %.6f, lowering %.3e (estimate %.3e)\n", k + 1, eb,
                cont, lowering, estimate);
    EXPECT_GT(lowering, 0);
    EXPECT_LT(lowering, 2 * estimate);
  }
  // Free vibration at n = 50 in mode 1 agrees with the eigenproblem; error
  // budget as docs/validation.md 2a (Verlet phase (ωh)²/24 < 1e-8 at
  // h = 0.2/ω_max, crossing interpolation, eigenvalue round-off): 1e-6.
  const int n = 50;
  auto b = build_batch<double>({seed_beam(n)});
  const Linearization lin = linearize(b, 0);
  const Modes md = modes(lin);
  int j = 0;
  while (md.omega[j] != a50[0]) ++j;
  excite_mode(b, 0, lin, md, j, 1e-6);
  const double h = 0.2 / md.omega.maxCoeff();
  const int steps = int(3 * 2 * kPi / md.omega[j] / h) + 1;
  auto mid_x = [&] { return b.position(0, n / 2)[0]; };
  double prev = mid_x(), first = -1, last = -1;
  int crossings = 0;
  for (int i = 1; i <= steps; ++i) {
    step<kUndamped>(b, h);
    const double cur = mid_x();
    if ((prev < 0) != (cur < 0)) {
      const double t = (i - 1 + prev / (prev - cur)) * h;
      if (crossings == 0) first = t;
      last = t;
      ++crossings;
    }
    prev = cur;
  }
  ASSERT_GE(crossings, 4);
  EXPECT_NEAR(kPi * (crossings - 1) / (last - first), a50[0], 1e-6 * a50[0]);
  // The clamp held through every step: node n and its frame did not move.
  const Vec3 tip = b.position(0, n);
  EXPECT_EQ(tip[0], 0.0);
  EXPECT_EQ(tip[1], 0.0);
  EXPECT_DOUBLE_EQ(tip[2], kL);
}

TEST(ClampedEnds, SagUnderAUniformLoadMatchesBeamTheory) {
  // Uniform load q = ρ A g across the beam (gravity along −e1, 1/100 of g so
  // that the sag stays ~1e-3 L, the linear range). Timoshenko clamped–
  // clamped: w(L/2) = q L⁴/(384 EI) + q L²/(8 κ G A) (bending + shear).
  // Membrane stiffening (the clamps hold the ends apart) is relative
  // ~(w/r_g)²/10 ≈ 1e-3 here, the bound below with the extrapolation error.
  const double g = 0.0981;
  const double q = kRho * kA * kA * g;
  const double w_theory = q * std::pow(kL, 4) / (384 * kEI) + q * kL * kL / (8 * kKappa * kG * kA * kA);
  auto sag = [&](int n) {
    auto b = build_batch<double>({seed_beam(n)}, {-g, 0, 0});
    StaticOptions opt;
    opt.load_steps = 2;
    opt.tolerance = 1e-12;
    EXPECT_TRUE(solve_static<kNoKelvinVoigt>(b, opt).converged);
    return -b.position(0, n / 2)[0];
  };
  const double w20 = sag(20), w40 = sag(40), w80 = sag(80);
  std::printf("sag: theory %.6e, n = 20/40/80: %.6e %.6e %.6e\n", w_theory, w20, w40, w80);
  // O(dx²) (lumped loads and the discrete bending operator)
  EXPECT_NEAR(std::log2((w20 - w40) / (w40 - w80)), 2.0, 0.2);
  const double cont = w80 + (w80 - w40) / 3;
  EXPECT_NEAR(cont, w_theory, 2e-3 * w_theory);
}

TEST(ClampedEnds, DissipationIdentityThroughTheImplicitSolve) {
  // A damped clamped–clamped beam released from a deflected static shape:
  // the energy falls at exactly 2·D_v (seed eq. 11). The implicit viscous
  // solve is first order in h, so the residual must fall at first order
  // (as tests/test_damping.cpp for the cantilever) — with the tip joint
  // part of the solve; a solve that left it out would not conserve this
  // budget at any h.
  const int n = 20;
  const double tau = 0.02;
  auto run = [&](double h, double* drop) {
    auto b = build_batch<double>({seed_beam(n, Damping::shear_extension(tau, tau))});
    b.set_node_force(0, n / 2, {0.5, 0, 0});
    solve_static(b);
    b.set_node_force(0, n / 2, {0, 0, 0});
    return dissipation_residual<kKV>(b, h, int(std::lround(0.05 / h)),
                                     [h](RodBatch<double>& x) { step<kKV, Viscous::implicit>(x, h); }, drop);
  };
  auto b0 = build_batch<double>({seed_beam(n)});
  const double h = 0.2 * 2 / modes(linearize(b0, 0)).omega.maxCoeff();
  double drop[3];
  const double r1 = run(h, &drop[0]), r2 = run(h / 2, &drop[1]), r3 = run(h / 4, &drop[2]);
  std::printf("clamped-clamped implicit: residuals %.3e %.3e %.3e of energy drop %.3e\n", r1, r2, r3, drop[0]);
  EXPECT_GT(drop[0], 0);
  EXPECT_NEAR(std::log2(r1 / r2), 1.0, 0.2);
  EXPECT_NEAR(std::log2(r2 / r3), 1.0, 0.2);
  EXPECT_LT(std::abs(r3) / drop[2], 0.05);
}

TEST(ClampedEnds, TheClampHoldsInEveryIntegratorAndThreadCount) {
  // A curly, damped, stiff rod and a plain one, both clamped at both ends,
  // flung by gravity: node n keeps its position and the tip ghost its frame
  // bit for bit, in Position Verlet, PEFRL, the temporally blocked step_n,
  // and with 1 or 2 threads (same hash).
  auto make = [](bool with_hair) {
    RodSpec a = hair(32, true, Damping::shear_extension(1e-3, 1e-3));
    a.clamped_tip = true;
    RodSpec c = seed_beam(24, Damping::shear_extension(0.02, 0.02));
    c.tip_frame = Mat3{1, 0, 0, 0, 1, 0, 0, 0, 1};  // (the default, given)
    c.velocities.resize(25);
    for (int j = 0; j <= 24; ++j) c.velocities[j] = {0.1 * std::sin(kPi * j / 24), 0, 0};
    std::vector<RodSpec> rods{c};
    if (with_hair) rods.insert(rods.begin(), a);
    return build_batch<double>(rods, {0, 0, -9.81});
  };
  auto tip_state = [](const RodBatch<double>& b, int r) {
    const int n = b.elements(r);
    const Vec3 x = b.position(r, n);
    std::array<double, 12> out{};
    for (int d = 0; d < 3; ++d) out[d] = x[d];
    const int g = b.rods[r].offset + n + 1;
    for (int i = 0; i < 9; ++i) out[3 + i] = b.state.elem_Q[i][g];
    return out;
  };
  auto b1 = make(true);
  const auto t0 = tip_state(b1, 0), c0 = tip_state(b1, 1);
  auto b2 = b1;
  const double h = 2e-5;
  step_n<kAllTerms>(b1, h, 200, Exec{1});
  step_n<kAllTerms>(b2, h, 200, Exec{2});
  EXPECT_EQ(state_hash(b1), state_hash(b2));
  EXPECT_EQ(tip_state(b1, 0), t0);
  EXPECT_EQ(tip_state(b1, 1), c0);
  // they moved: the hair sagged between its clamps, the beam swung
  EXPECT_GT(std::abs(b1.position(0, 16)[2]), 1e-9);
  EXPECT_GT(b1.position(1, 12)[0], 1e-4);
  auto b3 = make(false);  // PEFRL (not for stiff rods): the beam alone
  for (int i = 0; i < 50; ++i) step_pefrl<kAllTerms>(b3, 2e-5);
  EXPECT_EQ(tip_state(b3, 0), c0);
  EXPECT_GT(b3.position(0, 12)[0], 5e-5);
}

TEST(ClampedEnds, BadInputIsNamed) {
  RodSpec s = seed_cantilever(10);
  s.tip_frame = Mat3{1, 0, 0, 0, 1, 0, 0, 0, 1};
  try {
    (void)build_batch<double>({s});
    FAIL() << "a tip frame on a free tip was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tip_frame"), std::string::npos) << e.what();
  }
}
