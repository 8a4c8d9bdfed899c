// host/scene/setup/observables.cpp — the reductions of scene observables
// (include/manyrods/observables.h); the quantities are read from the batch
// by the runner (host/observe.h).
#include "manyrods/observables.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace manyrods::scene {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string time_label(double t) {
  std::ostringstream os;
  os.precision(10);
  os << t;
  return os.str();
}
}  // namespace

std::vector<std::string> observable_columns(const std::vector<Observable>& obs) {
  std::vector<std::string> cols;
  for (const Observable& ob : obs) {
    if (ob.reduce != Observable::Reduce::at || ob.times.size() == 1) {
      cols.push_back(ob.name);
      continue;
    }
    for (double t : ob.times) cols.push_back(ob.name + "@" + time_label(t));
  }
  return cols;
}

Observed start_observed(const std::vector<Observable>& obs) {
  Observed o;
  for (const Observable& ob : obs) {
    o.last.push_back(kNaN);
    if (ob.reduce == Observable::Reduce::at) {
      o.value.insert(o.value.end(), ob.times.size(), kNaN);
      continue;
    }
    const double inf = std::numeric_limits<double>::infinity();
    o.value.push_back(ob.reduce == Observable::Reduce::max || ob.reduce == Observable::Reduce::max_abs ? -inf
                      : ob.reduce == Observable::Reduce::min                                        ? inf
                                                                                                    : kNaN);
  }
  return o;
}

namespace detail {
void observe_one(const Observable& ob, Observed& o, std::size_t column, std::size_t index, double t,
                 std::int64_t step, double dt, bool first, double q) {
  using R = Observable::Reduce;
  double& v = o.value[column];
  double& last = o.last[index];
  switch (ob.reduce) {
    case R::at:
      for (std::size_t k = 0; k < ob.times.size(); ++k)
        if (step_of(ob.times[k], dt) == step) o.value[column + k] = q;
      break;
    case R::max:
      if (!(q <= v)) v = q;  // (a NaN quantity makes the maximum NaN)
      break;
    case R::min:
      if (!(q >= v)) v = q;
      break;
    case R::max_abs:
      if (!(std::abs(q) <= v)) v = std::abs(q);
      break;
    case R::final:
      v = q;
      break;
    case R::first_above:
    case R::first_below: {
      const bool above = ob.reduce == R::first_above;
      const bool there = above ? q >= ob.threshold : q <= ob.threshold;
      if (std::isnan(v) && there) {
        if (first || !std::isfinite(last) || !std::isfinite(o.time) || q == last) {
          v = t;
        } else {  // linear between the previous sample (not there yet) and this one
          const double s = (ob.threshold - last) / (q - last);
          v = o.time + std::clamp(s, 0.0, 1.0) * (t - o.time);
        }
      }
      break;
    }
  }
  last = q;
}
}  // namespace detail

std::vector<double> observed_values(const Observed& o) {
  std::vector<double> out = o.value;
  for (double& v : out)
    if (std::isinf(v)) v = kNaN;  // max or min of nothing
  return out;
}

std::vector<std::int64_t> observation_steps(const std::vector<Observable>& obs, double dt) {
  std::vector<std::int64_t> steps;
  for (const Observable& ob : obs)
    if (ob.reduce == Observable::Reduce::at)
      for (double t : ob.times)
        if (step_of(t, dt) >= 0) steps.push_back(step_of(t, dt));
  std::sort(steps.begin(), steps.end());
  steps.erase(std::unique(steps.begin(), steps.end()), steps.end());
  return steps;
}

}  // namespace manyrods::scene
