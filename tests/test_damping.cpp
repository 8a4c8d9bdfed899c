// docs/validation.md "3c Dissipation identity", "3d Modal damping ratio" and
// "5c Implicit Kelvin–Voigt step independent of τ" — Kelvin–Voigt damping:
// the dissipation identity, modal damping ratios by logarithmic decrement,
// and a stable step that does not depend on τ. Both viscous treatments are
// checked: Viscous::implicit (default) and Viscous::explicit_rate (the
// reference).
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
constexpr Terms kKV{true, true, true, true, true, false, false};  // no gravity, no loads

double omega_max(int n) {
  auto b = build_batch<double>({seed_cantilever(n)});
  return modes(linearize(b, 0)).omega.maxCoeff();
}

// Seed cantilever (τS = τE = τ, seed §5) held by a 0.05 N tip force in
// static equilibrium, then released: E(T) − E(0) + ∫₀ᵀ 2D_v dt.
template <Viscous kV>
double released_cantilever_residual(int n, double tau, double h, double T, double* energy_drop) {
  auto b = build_batch<double>({seed_cantilever(n, Damping::shear_extension(tau, tau))});
  b.set_node_force(0, n, {0.05, 0, 0});
  solve_static(b);
  b.set_node_force(0, n, {0, 0, 0});
  return manyrods::testing::dissipation_residual<kKV>(b, h, int(std::lround(T / h)),
                                   [h](RodBatch<double>& x) { step<kKV, kV>(x, h); }, energy_drop);
}

}  // namespace

TEST(Damping, DissipationIdentityExplicitRate) {
  // Energy falls at exactly 2·D_v (seed eq. 11) in the semi-discrete model.
  // The explicit-rate scheme evaluates the viscous force with the velocity
  // at the start of the kick, an O(h) error in the viscous work per unit
  // time: the residual must fall at first order when h is halved, and be a
  // small fraction of the energy dissipated.
  const int n = 20;
  const double tau = 0.02, wmax = omega_max(n);
  const double h = 0.5 * 2 / (tau * wmax * wmax);  // half the explicit viscous limit
  double drop[3];
  const double r1 = released_cantilever_residual<Viscous::explicit_rate>(n, tau, h, 0.1, &drop[0]);
  const double r2 = released_cantilever_residual<Viscous::explicit_rate>(n, tau, h / 2, 0.1, &drop[1]);
  const double r3 = released_cantilever_residual<Viscous::explicit_rate>(n, tau, h / 4, 0.1, &drop[2]);
  std::printf("explicit: h %.3g residuals %.3e %.3e %.3e of energy drop %.3e\n", h, r1, r2, r3, drop[0]);
  EXPECT_GT(drop[0], 0);
  EXPECT_NEAR(std::log2(r1 / r2), 1.0, 0.2);
  EXPECT_NEAR(std::log2(r2 / r3), 1.0, 0.2);
  EXPECT_LT(std::abs(r1) / drop[0], 1e-2);
}

TEST(Damping, DissipationIdentityImplicit) {
  // Backward Euler in the viscous velocities: also first order. At equal h
  // it is run at steps 100× longer than the explicit viscous limit.
  const int n = 20;
  const double tau = 0.02, wmax = omega_max(n);
  const double h = 0.2 * 2 / wmax;  // a fifth of the undamped elastic limit
  double drop[3];
  const double r1 = released_cantilever_residual<Viscous::implicit>(n, tau, h, 0.1, &drop[0]);
  const double r2 = released_cantilever_residual<Viscous::implicit>(n, tau, h / 2, 0.1, &drop[1]);
  const double r3 = released_cantilever_residual<Viscous::implicit>(n, tau, h / 4, 0.1, &drop[2]);
  std::printf("implicit: h %.3g residuals %.3e %.3e %.3e of energy drop %.3e\n", h, r1, r2, r3, drop[0]);
  EXPECT_GT(drop[0], 0);
  EXPECT_NEAR(std::log2(r1 / r2), 1.0, 0.2);
  EXPECT_NEAR(std::log2(r2 / r3), 1.0, 0.2);
}

namespace {

// Free vibration in mode 1 from rest; returns ζ from the logarithmic
// decrement between the first two maxima of the tip displacement.
// For a linear viscous oscillator started at rest, x(t) = A e^{−ζωt}(cos ω_d t
// + (ζω/ω_d) sin ω_d t) has its maxima exactly at t = 2πk/ω_d, so
// δ = ln(x0/x1) = 2πζ/√(1 − ζ²) holds exactly: ζ = δ/√(4π² + δ²).
template <Viscous kV>
std::vector<double> log_decrement_zeta(int n, const std::vector<double>& taus, double h,
                                       double* omega1) {
  std::vector<RodSpec> rods;
  for (double tau : taus) rods.push_back(seed_cantilever(n, Damping::shear_extension(tau, tau)));
  auto b = build_batch<double>(rods);
  auto b0 = build_batch<double>({seed_cantilever(n)});
  const Linearization lin = linearize(b0, 0);
  const Modes md = modes(lin);
  const std::vector<double> bend = modes_of(lin, md, 0, 0);
  int j = 0;
  while (md.omega[j] != bend[0]) ++j;
  *omega1 = md.omega[j];
  // eigenvector sign is arbitrary: choose the one with the tip at +x
  double sign = 1;
  for (std::size_t i = 0; i < lin.slot.size(); ++i)
    if (lin.kind[i] == 0 && lin.axis[i] == 0 && lin.slot[i] == b0.node_index(0, n))
      sign = md.shapes(i, j) < 0 ? -1 : 1;
  for (int r = 0; r < b.rod_count(); ++r) {
    // the same mode shape in every rod (amplitude: tip ≈ 1e-5 L, linear)
    detail::RodDofs d;
    for (std::size_t i = 0; i < lin.slot.size(); i += 3)
      (lin.kind[i] == 0 ? d.node_slots : d.elem_slots)
          .push_back(lin.slot[i] - b0.rods[0].offset + b.rods[r].offset);
    detail::apply_dofs(b, d, sign * 1e-6 * md.shapes.col(j));
  }
  const int R = b.rod_count();
  std::vector<double> x0(R), prev(R), pprev(R), zeta(R, -1);
  for (int r = 0; r < R; ++r) x0[r] = prev[r] = pprev[r] = b.position(r, n)[0];
  const double period = 2 * kPi / *omega1;
  const int steps = int(1.5 * period / h);
  for (int i = 1; i <= steps; ++i) {
    step<kKV, kV>(b, h);
    for (int r = 0; r < R; ++r) {
      const double x = b.position(r, n)[0];
      if (i >= 2 && i * h > 0.5 * period && zeta[r] < 0 && prev[r] >= pprev[r] && prev[r] > x) {
        // parabola through the three samples around the maximum
        const double a = 0.5 * (pprev[r] - 2 * prev[r] + x), bb = 0.5 * (x - pprev[r]);
        const double peak = prev[r] - bb * bb / (4 * a);
        const double delta = std::log(x0[r] / peak);
        zeta[r] = delta / std::sqrt(4 * kPi * kPi + delta * delta);
      }
      pprev[r] = prev[r];
      prev[r] = x;
    }
  }
  return zeta;
}

}  // namespace

TEST(Damping, ModalDampingRatioImplicit) {
  // docs/validation.md "3d Modal damping ratio". With τS = τE = τB = τ
  // (seed §5) the viscous matrix is exactly τ·K at the straight state, so
  // each linear mode decays with ζ_k = τ ω_k / 2, ω_k the discrete model's
  // undamped frequency.
  // Error budget of the measurement (relative):
  //   backward-Euler viscous step: amplitude factor (1 + hτω²)^(−½) per step
  //     instead of e^{−hτω²/2}: ζ low by hτω₁²/2 ≤ 2e-5·0.08·12.8/2 = 1e-5;
  //   Verlet phase error (ω₁h)²/24 < 1e-10; parabolic peak fit O((ω₁h)²) ~ 1e-9;
  //   amplitude nonlinearity (1e-5)² ~ 1e-10.
  // So 3e-5 relative bounds the difference.
  const std::vector<double> taus = {0.02, 0.04, 0.08};
  const int n = 20;
  double w1 = 0;
  const double h = 2e-5;
  const std::vector<double> zeta = log_decrement_zeta<Viscous::implicit>(n, taus, h, &w1);
  const double cases_zeta[3] = {0.035663, 0.071326, 0.142652};  // τ ω₁(Euler–Bernoulli)/2
  const double w_eb = euler_bernoulli_omega(1.87510407);
  for (int i = 0; i < 3; ++i) {
    const double expected = taus[i] * w1 / 2;
    std::printf("tau %.2f: zeta %.6f, tau*omega1/2 %.6f (omega1 %.6f, n = %d), EB %.6f\n", taus[i],
                zeta[i], expected, w1, n, cases_zeta[i]);
    EXPECT_NEAR(zeta[i], expected, 3e-5 * expected);
    // Against the Euler–Bernoulli values: they differ by ω₁(n=20)/ω_EB − 1,
    // the discretization and Timoshenko lowering of ω₁ (tested in test_modes).
    EXPECT_NEAR(zeta[i], cases_zeta[i], std::abs(w1 / w_eb - 1) * cases_zeta[i] + 3e-5 * expected + 1e-6);
  }
}

TEST(Damping, ModalDampingRatioExplicitRate) {
  // The explicit-rate scheme at 0.8× its viscous stability limit
  // 2/(τ ω_max²); its lagged viscous rate errs by O(hτω₁²) ≪ 1e-5 here.
  const int n = 20;
  const double tau = 0.02, wmax = omega_max(n);
  double w1 = 0;
  const std::vector<double> zeta =
      log_decrement_zeta<Viscous::explicit_rate>(n, {tau}, 0.8 * 2 / (tau * wmax * wmax), &w1);
  EXPECT_NEAR(zeta[0], tau * w1 / 2, 3e-5 * tau * w1 / 2);
}

namespace {

// Steps the seed cantilever released from a 0.05 N tip load; returns the
// largest |tip displacement| seen (blow-up shows as huge or non-finite).
template <Viscous kV>
double run_released(int n, double tau, double h, int steps, const State<double>& loaded) {
  auto b = build_batch<double>({seed_cantilever(n, Damping::shear_extension(tau, tau))});
  b.state = loaded;  // same layout: static equilibrium under the 0.05 N tip load
  double worst = 0;
  for (int i = 0; i < steps; ++i) {
    step<kKV, kV>(b, h);
    const double x = std::abs(b.position(0, n)[0]);
    if (!std::isfinite(x)) return INFINITY;
    worst = std::max(worst, x);
  }
  return worst;
}

}  // namespace

TEST(Damping, ImplicitViscousStepDoesNotDependOnTau) {
  // docs/validation.md "5c Implicit Kelvin–Voigt step independent of τ": with
  // τ up to 0.1 s the implicit scheme runs at 0.9× the UNDAMPED stable step
  // 2/ω_max (ω_max from the eigenproblem), where the
  // explicit viscous scheme, limited to 2/(τ ω_max²) — about 1/(τ ω_max)/2 ≈
  // 1000× smaller — blows up. The tip never exceeds its initial deflection
  // (energy only falls).
  for (int n : {50, 100}) {
    const double wmax = omega_max(n), h = 0.9 * 2 / wmax;
    auto b = build_batch<double>({seed_cantilever(n)});
    b.set_node_force(0, n, {0.05, 0, 0});
    solve_static(b);
    const double x0 = b.position(0, n)[0];
    for (double tau : {0.02, 0.08, 0.1}) {
      const double worst = run_released<Viscous::implicit>(n, tau, h, 3000, b.state);
      EXPECT_LE(worst, x0 * (1 + 1e-9)) << "n " << n << " tau " << tau;
    }
    EXPECT_FALSE(run_released<Viscous::explicit_rate>(n, 0.1, h, 200, b.state) <= x0 * (1 + 1e-9))
        << "the explicit viscous scheme should be unstable here";
  }
}
