// include/manyrods/fluid.h — the rods in a fluid: drag relative to the
// fluid's velocity (linear, resistive-force theory; quadratic, Morison form),
// buoyancy, and wind (a uniform velocity with a time table and a seeded,
// deterministic turbulent part). docs/model.md "Drag, buoyancy and wind" has
// the model and its integration.
//
//   RodSpec::drag              the coefficients of one rod
//   set_fluid(batch, fluid)    the fluid the batch's rods are in (validated:
//                              InputError naming the field); off by default
//
// Force per unit length on the centreline, with w = v − U(x, t) the velocity
// relative to the fluid, t̂ the tangent, w∥ = (w·t̂)t̂ and w⊥ = w − w∥:
//   f = −c⊥ w⊥ − c∥ w∥                                   (linear)
//       − ½ ρ_f C⊥ d |w⊥| w⊥ − ½ ρ_f C∥ π d |w∥| w∥       (quadratic)
//       − ρ_f A g                                        (buoyancy)
// with d the rod's diameter (twice the section's contact radius). Lumped on
// the nodes, the drag turns the kick into a per-node linear flow at fixed
// positions, v̇ = a − λ(v − U), which the step integrates exactly over the
// kick (an exponential integrator, kernels/fluid.h; the quadratic
// coefficients frozen at its start): it damps without limit on the step,
// whatever the coefficients, the terminal velocity is its exact fixed point,
// and Position Verlet stays second order with linear drag.
#pragma once

#include <cstdint>
#include <vector>

#include "manyrods/drive.h"

namespace manyrods {

// A rod's drag coefficients (all ≥ 0; zero: no such drag).
struct Drag {
  double normal = 0;      // c⊥, N·s/m² (force per length per relative speed, across the rod)
  double tangential = 0;  // c∥, N·s/m² (along it; slender-body theory gives c∥ ≈ c⊥/2)
  double cd_normal = 0;   // C⊥, 1: Morison drag coefficient across (≈ 1.2 for a cylinder)
  double cd_tangential = 0;  // C∥, 1: skin friction along (≈ 0.01)
  bool buoyancy = true;   // the displaced fluid (ρ_f A per length) pushes against gravity
  bool any() const { return normal > 0 || tangential > 0 || cd_normal > 0 || cd_tangential > 0; }
};

// A deterministic turbulent part: a sum of `modes` random Fourier modes,
//   U′(x, t) = Σ_m a_m sin(k_m · (x − X(t)) + ω_m t + φ_m),  a_m ⊥ k_m,
// advected by the mean flow, X(t) = ∫₀ᵗ Ū dt (frozen turbulence, Taylor), and
// decorrelating over `time_scale`; |k_m| = 2π/length_scale × [0.5, 2),
// ω_m = 2π/time_scale × [0.5, 1.5), directions uniform; the amplitudes give
// each component an rms of `intensity`. Divergence-free (each mode is). The
// modes come from `seed` through splitmix64: the same field on every
// machine and for any thread count.
struct Turbulence {
  double intensity = 0;     // m/s, rms of each component; 0: none
  double length_scale = 1;  // m
  double time_scale = 1;    // s
  int modes = 16;
  std::uint64_t seed = 1;
};

struct Fluid {
  double density = 0;  // kg/m³: quadratic drag and buoyancy (0: neither)
  // Mean velocity Ū(t): `velocity` when `times` is empty, else the table
  // (times strictly increasing, one velocity each), linear between entries
  // and held before the first and after the last.
  Vec3 velocity{0, 0, 0};  // m/s
  std::vector<double> times;
  std::vector<Vec3> velocities;
  Turbulence turbulence;

  Vec3 mean_velocity(double t) const;
  // X(t) = ∫₀ᵗ Ū dt (exact for the piecewise-linear table), m: how far the
  // mean flow has carried the turbulent pattern.
  Vec3 mean_displacement(double t) const;
  // Mean plus turbulent part at a point (the field the kernels evaluate).
  Vec3 velocity_at(const Vec3& x, double t) const;
  // Throws InputError naming the first bad field.
  void validate() const;
};

// Throws InputError naming the first negative or non-finite coefficient
// (build_batch calls it for every rod).
void validate_drag(const Drag& d);

// One turbulent mode (host/core/model/fluid.cpp makes them from the seed).
struct TurbulentMode {
  Vec3 k, amplitude;
  double omega, phase;
};
std::vector<TurbulentMode> turbulent_modes(const Turbulence& t);

}  // namespace manyrods
