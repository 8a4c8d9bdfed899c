// include/manyrods/sampling.h — sample designs and distributions for Monte
// Carlo sweeps (include/manyrods/sweep.h, docs/scenes.md "Sweeps").
//
// A design places N points in the unit cube [0, 1)^d, the same on every
// machine for a given seed (no std:: distribution, whose results differ
// between standard libraries); each varied parameter's distribution then
// maps its coordinate u to a value by its inverse CDF.
//
// Designs:
//   mc     independent uniform points (splitmix64, manyrods/rng.h), drawn
//          point by point, parameter by parameter
//   lhs    Latin hypercube (McKay, Beckman & Conover 1979): along every
//          axis each of the N strata [k/N, (k+1)/N) holds exactly one point,
//          at a uniform position inside it; strata paired by independent
//          random permutations
//   sobol  the Sobol' sequence (Sobol' 1967) with the direction numbers of
//          Joe & Kuo (2008, "new-joe-kuo-6.21201"; up to 21 parameters),
//          in Gray-code order, scrambled by a random linear matrix scramble
//          and digital shift (Matoušek 1998) drawn from the seed; every
//          point is the centre of its 2⁻³² cell, so u is never 0 or 1.
//          Without scrambling (seed ignored) it is the classic sequence
//          (0.5, 0.5, …), (0.75, 0.25, …), … shifted by 2⁻³³.
//   saltelli  the design of Sobol' sensitivity indices (Saltelli et al.
//          2010): two independent N-point samples A and B (the two halves
//          of a 2d-dimensional scrambled Sobol' point set, or Monte Carlo
//          beyond 10 parameters), then for each parameter i the matrix
//          A_B^(i), A with its column i from B: N (d + 2) points in the
//          order A, B, A_B^(1), …, A_B^(d); `samples` is N.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace manyrods::scene {

enum class DesignKind { grid, mc, lhs, sobol, saltelli };

struct Design {
  DesignKind kind = DesignKind::grid;
  int samples = 0;          // points (not for grid)
  std::uint64_t seed = 0;
  bool scramble = true;     // sobol only
};

// "grid", "mc", "lhs", "sobol" or "saltelli" (SceneError otherwise).
DesignKind parse_design(const std::string& name);
const char* design_name(DesignKind k);
// The design a sweep asked for: `kind` as parse_design, or empty for the
// default (grid without samples, mc with them); SceneError for a grid with
// samples or a sampled design without them.
Design make_design(const std::string& kind, int samples, std::uint64_t seed);

// [samples][dims] points in [0, 1) (grid: SceneError; it has no unit points).
std::vector<std::vector<double>> unit_points(const Design& d, int dims);

// Standard normal CDF Φ and its inverse Φ⁻¹ (p in (0, 1); to full double
// precision: Acklam's rational approximation refined by one Halley step on
// erfc).
double normal_cdf(double x);
double normal_quantile(double p);

}  // namespace manyrods::scene
