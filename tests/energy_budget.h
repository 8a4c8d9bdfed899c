// tests/energy_budget.h — the discrete form of the seed's dissipation
// identity (eq. 11), shared by the damping and integrator tests.
#pragma once

#include <cmath>

#include "host/core/advanced.h"

namespace manyrods::testing {

// Runs `one_step(b)` (a step of length h) `steps` times and returns
// E(T) − E(0) + ∫₀ᵀ 2D_v dt, the integral by the trapezoid rule over the
// step samples (O(h²)); *energy_drop = E(0) − E(T).
template <Terms kT, class Step>
double dissipation_residual(RodBatch<double>& b, double h, int steps, Step&& one_step, double* energy_drop) {
  const Energies e0 = energies<kT>(b);
  double integral = 0, d_prev = e0.dissipation;
  for (int i = 0; i < steps; ++i) {
    one_step(b);
    const double d = energies<kT>(b).dissipation;
    integral += 0.5 * h * (d_prev + d);
    d_prev = d;
  }
  const Energies e1 = energies<kT>(b);
  *energy_drop = e0.total() - e1.total();
  return e1.total() - e0.total() + integral;
}

}  // namespace manyrods::testing
