// include/manyrods/observables.h — observables a scene declares
// ([[observables]] tables, docs/scenes.md "Observables"): scalars that a
// run measures at its sample points and reduces to one number each, per
// sweep variation (extra summary columns, with their statistics and Sobol'
// indices) or for a plain run (/observables in its file).
//
// An observable is a quantity and a reduction:
//
//   quantity       of                                  keys
//   position       a node's position, m                rod, node, component x|y|z|norm
//   displacement   a node's position minus its place   rod, node, component (default norm)
//                  in the scene file (before any static pre-load), m
//   strain         the largest strain (scene.h max_strain) over the rod, or all rods
//   energy         kinetic|elastic|potential|total, J, or dissipated (∫ 2·D_v dt,
//                  all rods only); over the rod, or all rods
//   contacts       elements in contact (gap < 0)       rod or all
//   penetration    the deepest overlap, m              rod or all
//
//   reduction      value
//   at = t | [t…]  the quantity at the step nearest each time (one column per
//                  time, "name@t"; NaN for a time the run does not reach)
//   reduce = max|min|max_abs|final
//                  over the sample points
//   first_above = q, first_below = q
//                  the first time the quantity is ≥ q (≤ q), linear between
//                  the sample points that bracket it (NaN: never); the start
//                  time when it starts there
//
// "rod" is the rod's index in the scene (in a sweep: within each variation)
// or "all" (the default for strain, energy, contacts, penetration); "node"
// a node index, negative from the end (default −1, the tip).
//
// Resolution. The runner samples every 64th step, at every frame, at the
// last step and at every `at` time (include/manyrods/runner.h), so max, min
// and first-crossing times are those of the sample points: for an
// oscillation of angular frequency ω sampled every h seconds a maximum is
// low by at most A(1 − cos(ωh/2)) ≈ A ω²h²/8, and a crossing time is off by
// at most h (less where the quantity is smooth: the interpolation is linear).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace manyrods::scene {

struct Observable {
  enum class Quantity { position, displacement, strain, energy, contacts, penetration };
  enum class Reduce { at, max, min, max_abs, final, first_above, first_below };
  // energy components
  static constexpr int kinetic = 0, elastic = 1, potential = 2, total = 3, dissipated = 4;
  static constexpr int norm = 3;  // component of a position or displacement (0, 1, 2: x, y, z)

  std::string name;
  Quantity quantity = Quantity::position;
  int rod = 0;    // −1: all rods (of the variation)
  int node = -1;  // negative: from the end
  int component = norm;
  Reduce reduce = Reduce::final;
  std::vector<double> times;  // at
  double threshold = 0;       // first_above, first_below
};

// The summary columns of the observables, in order: one per observable, or
// one per time of an `at` observable ("name@t" when it has more than one).
std::vector<std::string> observable_columns(const std::vector<Observable>& obs);

// What a run keeps of each variation's observables between sample points
// (and in its checkpoint): `value`, one per column, and `last`, one per
// observable, the quantity at the previous sample point, whose time is
// `time` (for crossings).
struct Observed {
  std::vector<double> value, last;
  double time = std::numeric_limits<double>::quiet_NaN();
};

// The start: values NaN (or ∓∞ for max/min, turned into NaN by
// observed_values when nothing was sampled).
Observed start_observed(const std::vector<Observable>& obs);
// One sample point at time t (step `step`, `first` for the run's first
// sample) with quantity(i) the i-th observable's quantity now; dt: the step,
// which maps an `at` time to its step, llround(t/dt).
template <class Quantity>
void observe(const std::vector<Observable>& obs, Observed& o, double t, std::int64_t step, double dt, bool first,
             Quantity&& quantity);
// The columns' final values.
std::vector<double> observed_values(const Observed& o);

// The step of time t at step dt, llround(t/dt) (−1 beyond any run).
inline std::int64_t step_of(double t, double dt) {
  const double s = t / dt;
  return s < 9e18 ? std::llround(s) : -1;
}

// The steps at which `at` observables need a sample, sorted.
std::vector<std::int64_t> observation_steps(const std::vector<Observable>& obs, double dt);

// ---- implementation of observe ------------------------------------------------
namespace detail {
void observe_one(const Observable& ob, Observed& o, std::size_t column, std::size_t index, double t,
                 std::int64_t step, double dt, bool first, double q);
}  // namespace detail

template <class Quantity>
void observe(const std::vector<Observable>& obs, Observed& o, double t, std::int64_t step, double dt, bool first,
             Quantity&& quantity) {
  std::size_t column = 0;
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const Observable& ob = obs[i];
    bool needed = ob.reduce != Observable::Reduce::at;
    for (double at : ob.times) needed = needed || step_of(at, dt) == step;
    if (needed) detail::observe_one(ob, o, column, i, t, step, dt, first, quantity(i));
    column += ob.reduce == Observable::Reduce::at ? ob.times.size() : 1;
  }
  o.time = t;
}

}  // namespace manyrods::scene
