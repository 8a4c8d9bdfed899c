// tests/cases.h — the test rods of docs/validation.md "0a Test rods: the seed
// cantilever and human hair", built once for all tests.
#pragma once

#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <vector>

#include "host/core/advanced.h"

namespace manyrods::cases {

// Seed cantilever (seed §5): L = 0.3 m, 1 cm × 1 cm square,
// ρ = 1000 kg/m³, E = 1 MPa, ν = 0.3, clamped at s = 0, along +e3 with
// d1 = e1, straight and untwisted at rest.
inline constexpr double kL = 0.3, kA = 0.01, kRho = 1000, kE = 1e6, kNu = 0.3;
inline constexpr double kI = kA * kA * kA * kA / 12;  // 8.3333e-10 m⁴
inline constexpr double kEI = kE * kI;                // 8.3333e-4 N·m²
inline constexpr double kG = kE / (2 * (1 + kNu));

inline RodSpec seed_cantilever(int elements, Damping damping = Damping::none()) {
  RodSpec s = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, kL, elements);
  s.name = "seed cantilever";
  s.section = Section::rectangle(kA, kA);
  s.material.density = kRho;
  s.material.youngs_modulus = kE;
  s.material.poisson_ratio = kNu;
  s.damping = damping;
  s.clamped_root = true;
  return s;
}

// Human hair (docs/validation.md "5b Stiff human hair at frame-rate steps"):
// L = 0.2 m, r = 40 µm, E = 3.9 GPa, ρ = 1300, ν = 0.3, clamped horizontally
// (d3 = e1, d1 = e3), so that gravity along −e3 bends and swings it;
// `stiff`: RodSpec::stiff_implicit.
inline constexpr double kHairL = 0.2;
inline RodSpec hair(int elements, bool stiff = false, Damping damping = Damping::none()) {
  RodSpec s = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, kHairL, elements);
  s.name = stiff ? "stiff hair" : "hair";
  s.section = Section::circle(40e-6);
  s.material = {1300, 3.9e9, 0.3};
  s.damping = damping;
  s.clamped_root = true;
  s.stiff_implicit = stiff;
  return s;
}

// Euler–Bernoulli clamped–free bending frequencies, ω_k = (β_k L)² √(EI/(ρ A L⁴)).
inline double euler_bernoulli_omega(double beta_l) {
  return beta_l * beta_l * std::sqrt(kEI / (kRho * kA * kA * kL * kL * kL * kL));
}

// |a − b| and the largest of it over two equally long lists of points.
inline double distance(const Vec3& a, const Vec3& b) { return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }
inline double max_distance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double d = distance(a[i], b[i]);
    if (!(d <= worst)) worst = d;  // NaN propagates
  }
  return worst;
}

// Largest |σ| = |Q e/l̂ − V0| over the elements of rod `rod` (shear and
// stretch strain), from the library's element_strain kernel.
inline double max_element_strain(const RodBatch<double>& b, int rod) {
  const ModelView<double> m = b.model_view();
  const ConstStateView<double> s = b.state_view();
  double worst = 0;
  for (int e = 0; e < b.elements(rod); ++e) {
    const vec3<double> sigma = element_strain(b.elem_index(rod, e), m, s).sigma;
    const double n = std::sqrt(dot(sigma, sigma));
    if (!(n <= worst)) worst = n;  // NaN propagates
  }
  return worst;
}

// Self-convergence in time: run(h) gives node positions at `frames` equal
// frames over T; the step is h_max rounded down so that every frame is a
// whole number of steps at h, h/2, h/4 and h/32, and the errors of the
// first three against h/32 (whose own error shifts a measured second order
// by < 0.01) are returned.
template <class Run>
std::array<double, 3> time_errors(double h_max, double T, int frames, Run run) {
  const double h0 = T / frames / std::ceil(T / frames / h_max);
  const std::vector<Vec3> ref = run(h0 / 32);
  std::array<double, 3> err{};
  for (int i = 0; i < 3; ++i) err[i] = max_distance(run(h0 / (1 << i)), ref);
  return err;
}
// The orders between consecutive errors of time_errors, printed with `what`.
inline std::array<double, 2> time_orders(const std::array<double, 3>& err, const char* what) {
  std::array<double, 2> o{};
  for (int i = 0; i + 1 < 3; ++i) {
    o[i] = std::log2(err[i] / err[i + 1]);
    std::printf("%s: error %.3e m at h/%d, %.3e m at h/%d: order %.2f\n", what, err[i], 1 << i, err[i + 1], 2 << i,
                o[i]);
  }
  return o;
}

// The golden batches (tests/test_golden.cpp, tests/test_isa.cpp): a damped
// seed cantilever of 20 and one of 7 elements; for Position Verlet also a
// damped stiff hair beside them and a cantilever on a shaking, nodding root.
inline std::vector<RodSpec> golden_rods(bool verlet) {
  const Damping kv = Damping::shear_extension(0.02, 0.02);
  std::vector<RodSpec> rods{seed_cantilever(20, kv), seed_cantilever(7, kv)};
  if (!verlet) return rods;
  RodSpec h = hair(16, true, Damping::shear_extension(1e-4, 1e-4));
  for (Vec3& x : h.nodes) x[1] += 0.5;  // beside the cantilevers
  rods.push_back(h);
  RodSpec driven = seed_cantilever(12, kv);
  auto motion = std::make_shared<OscillatingMotion>();
  motion->translation_amplitude = {0.01, 0, 0};
  motion->axis = {0, 1, 0};
  motion->rotation_amplitude = 0.2;
  motion->frequency = 2;
  motion->ramp_time = 0.05;
  driven.root_motion = motion;
  rods.push_back(driven);
  return rods;
}

}  // namespace manyrods::cases
