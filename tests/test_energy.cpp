// docs/validation.md "2c Energy without damping": bounded, with the error of
// Position Verlet falling as O(dt²), over more than 10⁵ steps.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "cases.h"
#include "linear.h"

using namespace manyrods;
using namespace manyrods::cases;
using namespace manyrods::testing;

namespace {

constexpr Terms kUndamped{true, true, true, true, false, false, false};

struct Drift {
  double max_error;    // max_t |E(t) − E(0)| / E(0)
  double late_error;   // the same over the last quarter of the run
};

// The seed cantilever released from its static shape under a 0.05 N tip
// load (α ≈ 5.4: a large, nonlinear swing), optionally with a 3-D kick
// (out-of-plane velocity and twist rate), stepped for time T.
Drift energy_drift(int n, double h, double T, bool three_d) {
  auto b = build_batch<double>({seed_cantilever(n)});
  b.set_node_force(0, n, {0.05, 0, 0});
  solve_static(b);
  b.set_node_force(0, n, {0, 0, 0});
  if (three_d)
    for (int j = 1; j <= n; ++j) {
      b.set_velocity(0, j, {0, 0.3 * j / n, 0});
      b.set_angular_velocity(0, j - 1, {0, 0, 2.0 * j / n});
    }
  const double e0 = energies<kUndamped>(b).total();
  const int steps = int(std::lround(T / h));
  Drift d{0, 0};
  for (int i = 1; i <= steps; ++i) {
    step<kUndamped>(b, h);
    const double err = std::abs(energies<kUndamped>(b).total() - e0) / e0;
    d.max_error = std::max(d.max_error, err);
    if (i > 3 * steps / 4) d.late_error = std::max(d.late_error, err);
  }
  return d;
}

void check_second_order(bool three_d) {
  const int n = 20;
  auto b = build_batch<double>({seed_cantilever(n)});
  const double wmax = modes(linearize(b, 0)).omega.maxCoeff();
  // h₁ = 0.5/ω_max (a quarter of the linear stability limit 2/ω_max): all
  // modes are resolved, (ω h)² ≤ 0.25, so the O(h²) term of the modified
  // energy dominates the error. T = 1.8 s ≈ one period of mode 1; h₁/4 takes
  // more than 10⁵ steps.
  const double h = 0.5 / wmax, T = 1.8;
  const Drift d1 = energy_drift(n, h, T, three_d), d2 = energy_drift(n, h / 2, T, three_d),
              d3 = energy_drift(n, h / 4, T, three_d);
  std::printf("%s: h %.3g, max |dE|/E %.3e %.3e %.3e (steps at h/4: %ld)\n", three_d ? "3-D" : "planar",
              h, d1.max_error, d2.max_error, d3.max_error, std::lround(4 * T / h));
  ASSERT_GE(std::lround(4 * T / h), 100000);
  // Order 2 within ±0.2.
  EXPECT_NEAR(std::log2(d1.max_error / d2.max_error), 2.0, 0.2);
  EXPECT_NEAR(std::log2(d2.max_error / d3.max_error), 2.0, 0.2);
  // Bounded, no drift: the error late in the run is not larger than the
  // error over the whole run had at the start (it oscillates, symplectic).
  EXPECT_LE(d3.late_error, d3.max_error);
}

}  // namespace

TEST(Energy, PositionVerletSecondOrderPlanarSwing) { check_second_order(false); }

TEST(Energy, PositionVerletSecondOrder3DSwingWithTwist) { check_second_order(true); }
