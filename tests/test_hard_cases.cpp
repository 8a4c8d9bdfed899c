// Hard cases (docs/validation.md "5d Hard cases"): rods that break careless
// steppers, each stepped 10⁵ steps of Position Verlet with the implicit
// Kelvin–Voigt update at 0.9 × stable_dt(b).elastic (recomputed for the
// case, so the estimate is tested on them too), with gravity: the state stays finite (advance()
// would throw NonFiniteError) and bounded, and the mechanical energy
// (kinetic + elastic + gravity) does not increase.
//
//   1. relative rotations near π between neighbouring elements, in twist
//      (frames turned by 3.0 rad about d3 from one element to the next) and
//      in bending (a zig-zag polyline folded by 3.0 rad at every node);
//   2. a stiffness ratio of 1e4 within one rod (the model's stiffness arrays
//      scaled after build_batch);
//   3. element lengths differing 100× (alternating long and short);
//   4. τ = 0.1 s with the implicit viscous update (large swing);
//   5. curly hair: a helical rest shape turning ≈ 1 rad per element, with
//      the hair material (docs/validation.md "0a Test rods: the seed cantilever
//      and human hair").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "cases.h"
#include "host/core/advanced.h"

using namespace manyrods;
using namespace manyrods::cases;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kSteps = 100000;
constexpr int kSample = 500;  // energy and bounds every kSample steps

Mat3 rows(const Vec3& d1, const Vec3& d2, const Vec3& d3) {
  return {d1[0], d1[1], d1[2], d2[0], d2[1], d2[2], d3[0], d3[1], d3[2]};
}

// Seed material (ρ = 1000, E = 1 MPa, ν = 0.3, 1 cm square) on a given
// centreline and frames; clamped root.
RodSpec seed_on(std::vector<Vec3> nodes, std::vector<Mat3> frames, double tau, const char* name) {
  RodSpec s = RodSpec::polyline(std::move(nodes), std::move(frames));
  s.name = name;
  s.section = Section::rectangle(kA, kA);
  s.material = {kRho, kE, kNu};
  s.damping = Damping::shear_extension(tau, tau);
  s.clamped_root = true;
  return s;
}

struct Outcome {
  double dt = 0;
  double e0 = 0, e_end = 0;
  // max over samples of E(t_k) − E(t_{k−1}) − tol_k, J: ≤ 0 when the energy
  // never rose by more than the round-off of its evaluation, tol_k =
  // 4·(number of terms)·ε·(K + E_elastic + |E_gravity|) — energies() sums
  // ≈ 3n terms in double, and each term carries the round-off of the state
  // it is computed from (relative ε).
  double max_excess_rise = -INFINITY;
  double max_rise = -INFINITY;  // max over samples of E(t_k) − E(t_{k−1}), J
  double dissipated = 0;        // E(0) − min_k E(t_k), J
  double max_strain = 0;        // max |σ − V0| over samples
  double max_reach = 0;         // max distance of a node from the root / rod length
  double max_turn = 0;          // max angle between neighbouring frames, rad
};

// Angle of the rotation Q_b Q_aᵀ (rows = directors), rad.
double frame_angle(const Mat3& qb, const Mat3& qa) {
  double trace = 0;  // tr(Q_b Q_aᵀ) = Σ_ij (Q_b)_ij (Q_a)_ij
  for (int i = 0; i < 9; ++i) trace += qb[i] * qa[i];
  return std::acos(std::clamp((trace - 1) / 2, -1.0, 1.0));
}

// Largest rest angle between neighbouring frames of rod 0, rad.
double rest_turn(const RodBatch<double>& b) {
  double t = 0;
  for (int j = 0; j + 1 < b.elements(0); ++j) t = std::max(t, frame_angle(b.frame(0, j + 1), b.frame(0, j)));
  return t;
}

// Steps the batch (one rod) kSteps steps at 0.9 × stable_dt (or the given
// fraction) and records energy and bounds every kSample steps. Throws
// NonFiniteError (from advance) if the state goes non-finite.
Outcome run_hard(RodBatch<double>& b, double fraction = 0.9) {
  Outcome o;
  o.dt = fraction * stable_dt(b).elastic;
  const int n = b.elements(0);
  double length = 0;
  for (int e = 0; e < n; ++e) length += b.model.elem_rest_length[b.elem_index(0, e)];
  const Vec3 root = b.position(0, 0);
  o.e0 = energies(b).total();
  double prev = o.e0, emin = o.e0;
  for (int done = 0; done < kSteps; done += kSample) {
    advance(b, o.dt, kSample);
    const Energies en = energies(b);
    const double e = en.total();
    const double tol = 4 * (3 * n + 3) * 2.2e-16 * (en.kinetic + en.elastic + std::abs(en.potential));
    o.max_rise = std::max(o.max_rise, e - prev);
    o.max_excess_rise = std::max(o.max_excess_rise, e - prev - tol);
    emin = std::min(emin, e);
    prev = e;
    for (int j = 0; j <= n; ++j) {
      const Vec3 p = b.position(0, j);
      o.max_reach =
          std::max(o.max_reach, std::hypot(p[0] - root[0], p[1] - root[1], p[2] - root[2]) / length);
    }
    o.max_strain = std::max(o.max_strain, max_element_strain(b, 0));
    for (int k = 0; k + 1 < n; ++k)
      o.max_turn = std::max(o.max_turn, frame_angle(b.frame(0, k + 1), b.frame(0, k)));
  }
  o.e_end = prev;
  o.dissipated = o.e0 - emin;
  return o;
}

// What every case asserts.
void check(const char* name, const Outcome& o) {
  std::printf(
      "%-22s dt %.4g s: E %.6e -> %.6e J (dissipated %.3e J), max rise %.3e J, max |sigma| %.3e, "
      "reach %.4f L, max turn %.3f rad\n",
      name, o.dt, o.e0, o.e_end, o.dissipated, o.max_rise, o.max_strain, o.max_reach, o.max_turn);
  // Energy: never rises beyond the round-off of its evaluation, and falls.
  EXPECT_LE(o.max_excess_rise, 0) << name;
  EXPECT_LT(o.e_end, o.e0) << name;
  // Bounded: strains stay small (the loads here give |σ| ≲ 2e-2; a blown-up
  // step gives O(1)), and no node is farther from the clamp than the rod's
  // length plus that stretch.
  EXPECT_LT(o.max_strain, 0.1) << name;
  EXPECT_LT(o.max_reach, 1.1) << name;
}

}  // namespace

TEST(HardCases, NearPiTwistBetweenNeighbours) {
  const int n = 20;
  std::vector<Vec3> nodes;
  std::vector<Mat3> frames;
  // Horizontal (gravity bends it); frames turned by 3.0 rad = π − 0.14 about
  // d3 from each element to the next.
  const double l = kL / n, turn = 3.0;
  for (int j = 0; j <= n; ++j) nodes.push_back({l * j, 0, 0});
  for (int e = 0; e < n; ++e) {
    const double a = turn * e;
    frames.push_back(rows({0, std::cos(a), std::sin(a)}, {0, -std::sin(a), std::cos(a)}, {1, 0, 0}));
  }
  auto b = build_batch<double>({seed_on(nodes, frames, 0.02, "near-pi twist")}, {0, 0, -9.81});
  EXPECT_NEAR(rest_turn(b), turn, 1e-9);
  const Outcome o = run_hard(b);
  check("near-pi twist", o);
}

TEST(HardCases, NearPiBendBetweenNeighbours) {
  const int n = 20;
  std::vector<Vec3> nodes = {{0, 0, 0}};
  const double l = kL / n, half = 1.5;  // segments at ±1.5 rad from the axis: folds of 3.0 rad
  for (int e = 0; e < n; ++e) {
    const double s = (e % 2 == 0 ? 1 : -1) * std::sin(half);
    const Vec3& p = nodes.back();
    nodes.push_back({p[0] + l * std::cos(half), p[1], p[2] + l * s});
  }
  auto frames = RodSpec::parallel_transport_frames(nodes, {0, 1, 0});
  auto b = build_batch<double>({seed_on(nodes, frames, 0.02, "near-pi bend")}, {0, 0, -9.81});
  EXPECT_NEAR(rest_turn(b), 2 * half, 1e-9);
  const Outcome o = run_hard(b);
  check("near-pi bend", o);
}

TEST(HardCases, StiffnessRatio1e4WithinARod) {
  // Built as the seed cantilever; then the outer half (elements 10–19 and
  // the joints between them) is made 1e4× stiffer by scaling the model's
  // stiffness arrays (viscous resultants scale with them: V = C·τ). The
  // joint between elements 9 and 10 keeps the soft value.
  const int n = 20;
  auto b = build_batch<double>({seed_cantilever(n, Damping::shear_extension(0.02, 0.02))}, {-9.81, 0, 0});
  for (int e = n / 2; e < n; ++e)
    for (int a = 0; a < 3; ++a) b.model.elem_stiffness[a][b.elem_index(0, e)] *= 1e4;
  for (int j = n / 2; j + 1 < n; ++j)
    for (int a = 0; a < 3; ++a) b.model.vor_stiffness[a][b.vor_index(0, j)] *= 1e4;
  const Outcome o = run_hard(b);
  check("stiffness ratio 1e4", o);
}

TEST(HardCases, ElementLengthsDiffering100x) {
  const int n = 20;
  std::vector<Vec3> nodes = {{0, 0, 0}};
  const double long_l = 0.03, short_l = long_l / 100;
  for (int e = 0; e < n; ++e) nodes.push_back({nodes.back()[0] + (e % 2 == 0 ? long_l : short_l), 0, 0});
  auto frames = RodSpec::parallel_transport_frames(nodes, {0, 0, 1});
  auto b = build_batch<double>({seed_on(nodes, frames, 0.02, "100x lengths")}, {0, 0, -9.81});
  const Outcome o = run_hard(b);
  check("element lengths 100x", o);
}

TEST(HardCases, Tau01ImplicitLargeSwing) {
  // The seed cantilever (n = 50, τS = τE = 0.1 s) released from its shape
  // under a 0.05 N tip load, standing upright under gravity: its weight
  // per length ρAg = 0.98 N/m is above the self-weight buckling load
  // 7.84 EI/L³ = 0.24 N/m, so it swings over and falls to one side.
  const int n = 50;
  auto b = build_batch<double>({seed_cantilever(n, Damping::shear_extension(0.1, 0.1))}, {0, 0, 0});
  b.set_node_force(0, n, {0.05, 0, 0});
  solve_static(b);
  b.set_node_force(0, n, {0, 0, 0});
  b.set_gravity({0, 0, -9.81});
  const Outcome o = run_hard(b);
  check("tau 0.1 implicit", o);
}

TEST(HardCases, CurlyHair) {
  // Hair (the material of cases::hair) on a helix of radius 6.25 mm and
  // pitch 4 mm per turn; element length 6.25 mm: the helix angle advances by ≈ 1 rad
  // per element, and so does the tangent (measured below).
  const int n = 32;
  const double L = 0.2, l = L / n, R = 6.25e-3, pitch = 4e-3;
  const double c = std::sqrt(4 * kPi * kPi * R * R + pitch * pitch);  // arc length per turn
  std::vector<Vec3> nodes;
  for (int j = 0; j <= n; ++j) {
    const double t = 2 * kPi * (l * j) / c;  // helix angle
    nodes.push_back({R * std::cos(t), R * std::sin(t), -pitch * t / (2 * kPi)});
  }
  auto frames = RodSpec::parallel_transport_frames(nodes, {0, 0, 1});
  RodSpec s = RodSpec::polyline(nodes, frames);
  s.name = "curly hair";
  s.section = Section::circle(40e-6);
  s.material = {1300, 3.9e9, 0.3};
  s.damping = Damping::shear_extension(0.02, 0.02);
  s.clamped_root = true;
  auto b = build_batch<double>({s}, {9.81, 0, 0});
  const double turn = rest_turn(b);
  std::printf("curly hair: rest rotation between neighbours %.3f rad\n", turn);
  EXPECT_GT(turn, 0.9);
  const Outcome o = run_hard(b);
  check("curly hair", o);
}
