// docs/validation.md "2a Small-amplitude bending frequencies" and "2b Axial
// and torsional frequencies" — natural frequencies of the seed cantilever,
// measured two independent ways: the linearized stiffness/mass eigenproblem (tests/linear.h,
// no time stepping) and a simulated free vibration (zero crossings).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "cases.h"
#include "linear.h"

using namespace manyrods;
using namespace manyrods::cases;
using namespace manyrods::testing;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr Terms kUndamped{true, true, true, true, false, false, false};

struct Analysis {
  Linearization lin;
  Modes md;
  std::vector<double> bend_x, axial, torsion;
};

Analysis analyse(int n) {
  auto b = build_batch<double>({seed_cantilever(n)});
  Analysis a{linearize(b, 0), {}, {}, {}, {}};
  a.md = modes(a.lin);
  a.bend_x = modes_of(a.lin, a.md, 0, 0);   // x-displacement dominated
  a.axial = modes_of(a.lin, a.md, 0, 2);    // z-displacement
  a.torsion = modes_of(a.lin, a.md, 1, 2);  // rotation about d3
  return a;
}

// Simulates free vibration of mode j (amplitude 1e-6 in the M-normalized
// shape: tip displacement ≪ 1e-3 L, linear regime) and returns the angular
// frequency from the zero crossings of `signal`.
template <class Signal>
double free_vibration_omega(int n, const Analysis& a, int j, double periods, Signal signal) {
  auto b = build_batch<double>({seed_cantilever(n)});
  excite_mode(b, 0, a.lin, a.md, j, 1e-6);
  const double omega = a.md.omega[j];
  // Position Verlet is stable for ω_max h < 2; h = 0.2/ω_max. Its phase error
  // for mode ω is (ωh)²/24 relative (≤ 1e-8 here for every mode used).
  const double h = 0.2 / a.md.omega.maxCoeff();
  const int steps = int(periods * 2 * kPi / omega / h) + 1;
  const double s0 = signal(b);
  double prev = s0, first = -1, last = -1;
  int crossings = 0;
  for (int i = 1; i <= steps; ++i) {
    step<kUndamped>(b, h);
    const double cur = signal(b);
    if ((prev < 0) != (cur < 0)) {
      const double t = (i - 1 + prev / (prev - cur)) * h;  // linear interpolation
      if (crossings == 0) first = t;
      last = t;
      ++crossings;
    }
    prev = cur;
  }
  EXPECT_GE(crossings, 4);
  return kPi * (crossings - 1) / (last - first);
}

}  // namespace

TEST(Modes, BendingFrequenciesEigenproblemAndFreeVibration) {
  const Analysis a25 = analyse(25), a50 = analyse(50), a100 = analyse(100);
  const double eb[2] = {euler_bernoulli_omega(1.87510407), euler_bernoulli_omega(4.69409113)};
  EXPECT_NEAR(eb[0], 3.56629792, 1e-7);
  EXPECT_NEAR(eb[1], 22.3496075, 1e-6);
  for (int k = 0; k < 2; ++k) {
    SCOPED_TRACE(::testing::Message() << "bending mode " << k + 1 << ": " << a25.bend_x[k] << " "
                                    << a50.bend_x[k] << " " << a100.bend_x[k]);
    // Discretization: O(dx²). Order from n = 25/50/100 within ±0.2.
    const double e1 = a25.bend_x[k] - a50.bend_x[k], e2 = a50.bend_x[k] - a100.bend_x[k];
    EXPECT_NEAR(std::log2(e1 / e2), 2.0, 0.2);
    // Continuum limit (Richardson) is a Timoshenko beam: shear and rotary
    // inertia LOWER ω below Euler–Bernoulli by about ½(β r_g)²(1 + E/(κG))
    // (r_g² = I/A). Assert 0 < lowering < twice that estimate.
    const double cont = a100.bend_x[k] - e2 / 3;
    const double beta = (k == 0 ? 1.87510407 : 4.69409113) / kL;
    const double kappa = 10 * (1 + kNu) / (12 + 11 * kNu);
    const double estimate = 0.5 * beta * beta * (kI / (kA * kA)) * (1 + kE / (kappa * kG));
    const double lowering = (eb[k] - cont) / eb[k];
    EXPECT_GT(lowering, 0);
    EXPECT_LT(lowering, 2 * estimate);
    if (k == 0) {
      EXPECT_LT(lowering, 1e-3);  // 2a: below 0.1% for mode 1
    }
    // n = 50 agrees with Euler–Bernoulli within the Timoshenko lowering plus
    // the n = 50 discretization error.
    EXPECT_NEAR(a50.bend_x[k], eb[k], eb[k] * 2 * estimate + std::abs(e2) * 4 / 3 * 1.1);
  }
  // Free vibration at n = 50 agrees with the eigenproblem. Error budget:
  // Verlet phase error (ωh)²/24 < 1e-8, crossing interpolation O((ωh)²),
  // amplitude nonlinearity O(1e-12), eigenvalue round-off ε·λmax/λ ≈ 1e-8:
  // 1e-6 relative bounds them all.
  auto tip_x = [n = 50](const RodBatch<double>& b) { return b.position(0, n)[0]; };
  for (int k = 0; k < 2; ++k) {
    int j = 0;
    while (a50.md.omega[j] != a50.bend_x[k]) ++j;
    const double w = free_vibration_omega(50, a50, j, k == 0 ? 3 : 10, tip_x);
    EXPECT_NEAR(w, a50.bend_x[k], 1e-6 * a50.bend_x[k]) << "bending mode " << k + 1;
  }
}

TEST(Modes, AxialAndTorsionalFrequencies) {
  const int n = 50;
  const Analysis a = analyse(n);
  const SectionProperties p = section_properties(Section::rectangle(kA, kA), kNu);
  // J_T = 0.140577 a⁴ for the square (docs/model.md "Cross sections").
  EXPECT_NEAR(p.torsion_constant / (kA * kA * kA * kA), 0.140577, 1e-6);
  const double c_axial = std::sqrt(kE / kRho);
  const double c_torsion = std::sqrt(kG * p.torsion_constant / (kRho * p.I3));
  EXPECT_NEAR(kPi / 2 * c_axial / kL, 165.576, 1e-3);
  EXPECT_NEAR(kPi / 2 * c_torsion / kL, 94.3072, 1e-4);
  // Exact discrete spectrum: both are uniform chains fixed at s = 0 and free
  // at s = L (axial: lumped node masses, half at the tip; torsion: element
  // inertias with a half-length joint to the clamp, which is the mirror image
  // of the first element). Their modes are sin(q s) sampled on the grid with
  // ω = (2c/dx) sin(q dx/2), q = π/(2L): the continuum value times
  // sin z / z, z = π dx/(4L) — below it by z²/6 = 4.1e-5 at n = 50.
  const double dx = kL / n, z = kPi * dx / (4 * kL);
  const double axial = kPi / 2 * c_axial / kL * std::sin(z) / z;
  const double torsion = kPi / 2 * c_torsion / kL * std::sin(z) / z;
  // Eigenvalue accuracy: central-difference stiffness, round-off ~1e-9.
  EXPECT_NEAR(a.axial[0], axial, 1e-7 * axial);
  EXPECT_NEAR(a.torsion[0], torsion, 1e-7 * torsion);
  // Free vibration of those modes (same error budget as for bending).
  int ja = 0, jt = 0;
  while (a.md.omega[ja] != a.axial[0]) ++ja;
  while (a.md.omega[jt] != a.torsion[0]) ++jt;
  const double wa = free_vibration_omega(n, a, ja, 10, [n](const RodBatch<double>& b) {
    return b.position(0, n)[2] - kL;
  });
  const double wt = free_vibration_omega(n, a, jt, 10, [n](const RodBatch<double>& b) {
    const Mat3 q = b.frame(0, n - 1);
    return std::atan2(q[1], q[0]);  // rotation of d1 about e3
  });
  EXPECT_NEAR(wa, axial, 1e-6 * axial);
  EXPECT_NEAR(wt, torsion, 1e-6 * torsion);
}
