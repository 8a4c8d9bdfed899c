// host/core/step/fluid_stage.h — the fluid's part of a kick (kernels/fluid.h) on the
// nodes of a segment: fluid_save before the kick, fluid_stage after it (Ū
// and the turbulent modes' phases for the kick's time, then one launch of
// the kernel specialized for the parts the batch uses). A batch without a
// fluid never calls them (one branch per step).
#pragma once

#include <cmath>
#include <numbers>
#include <vector>

#include "host/core/model/view_of.h"
#include "host/core/step/launch.h"
#include "kernels/fluid.h"
#include "kernels/views.h"
#include "manyrods/batch.h"

namespace manyrods {

namespace detail {
template <FluidTerms kF, class T>
void fluid_launch(RodBatch<T>& b, T h, const FluidView<T>& f, const Exec& ex, const Segment& r) {
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  launch(r.begin, r.end, ex, [&](int k) MANYRODS_KERNEL_LAMBDA { fluid_node<kF>(k, h, f, m, s); });
}
// The kernels' view of the fluid arrays (MANYRODS_FLUID_FIELDS).
template <class T>
FluidView<T> fluid_arrays(FluidData<T>& fd) {
  FluidView<T> f{};
#define MANYRODS_FLUID_VIEW(name, view, n, doc) view_of(f.view, fd.name);
  MANYRODS_FLUID_FIELDS(MANYRODS_FLUID_VIEW)
#undef MANYRODS_FLUID_VIEW
  return f;
}
}  // namespace detail

// Before the kick: the velocities saved (the fluid stage recovers the
// kick's increment from them).
// reads: state.node_v  writes: batch.fluid.node_v_saved
template <class T>
void fluid_save_stage(RodBatch<T>& b, const Exec& ex, const Segment& r) {
  const FluidView<T> f = detail::fluid_arrays(b.fluid);
  const StateView<T> s = b.state_view();
  launch(r.begin, r.end, ex, [&](int k) MANYRODS_KERNEL_LAMBDA { fluid_save(k, f, s); });
}

// After the kick of length h at time t (the kick's) on segment r: the kick
// redone as the exact flow with drag (kernels/fluid.h). `gravity`: the step
// has gravity (buoyancy acts only with it).
// reads: state, model, batch.fluid  writes: state.node_v
template <class T>
void fluid_stage(RodBatch<T>& b, T h, double t, bool gravity, const Exec& ex, const Segment& r) {
  FluidData<T>& fd = b.fluid;
  const Vec3 mean = fd.spec.mean_velocity(t), X = fd.spec.mean_displacement(t);
  // each mode's phase at t, c_m = −k·X(t) + ω t + φ (reduced mod 2π in double)
  T modes[7 * 256];  // (Turbulence::modes ≤ 256, Fluid::validate)
  const int count = int(fd.modes.size());
  for (int i = 0; i < count; ++i) {
    const TurbulentMode& md = fd.modes[i];
    double c = md.omega * t + md.phase - (md.k[0] * X[0] + md.k[1] * X[1] + md.k[2] * X[2]);
    c = std::remainder(c, 2 * std::numbers::pi);
    for (int d = 0; d < 3; ++d) {
      modes[7 * i + d] = T(md.k[d]);
      modes[7 * i + 3 + d] = T(md.amplitude[d]);
    }
    modes[7 * i + 6] = T(c);
  }
  const bool with_gravity = gravity && fd.buoyancy;
  const vec3<T> g = with_gravity ? b.model_view().gravity : vec3<T>{T(0), T(0), T(0)};
  FluidView<T> f = detail::fluid_arrays(fd);
  f.mean = vec3<T>{T(mean[0]), T(mean[1]), T(mean[2])};
  f.gravity = g;
  if (count > 0) {  // the turbulent wind at the nodes, mode by mode
    const StateView<T> s = b.state_view();
    launch(r.begin, r.end, ex, [&](int k) MANYRODS_KERNEL_LAMBDA { fluid_mean(k, f); });
    for (int i = 0; i < count; ++i) {
      const T* p = modes + 7 * i;
      launch(r.begin, r.end, ex, [&](int k) MANYRODS_KERNEL_LAMBDA { fluid_mode(k, p, f, s); });
    }
  }
  const unsigned which = unsigned(fd.linear) | unsigned(fd.quadratic) << 1 | unsigned(with_gravity) << 2 |
                         unsigned(count > 0) << 3;
  // the 16 combinations of FluidTerms, each compiled once
  auto go = [&]<unsigned w>() {
    constexpr FluidTerms kF{bool(w & 1), bool(w & 2), bool(w & 4), bool(w & 8)};
    detail::fluid_launch<kF>(b, h, f, ex, r);
  };
  switch (which) {
#define MANYRODS_FLUID_CASE(w) \
  case w: go.template operator()<w>(); break;
    MANYRODS_FLUID_CASE(0) MANYRODS_FLUID_CASE(1) MANYRODS_FLUID_CASE(2) MANYRODS_FLUID_CASE(3)
    MANYRODS_FLUID_CASE(4) MANYRODS_FLUID_CASE(5) MANYRODS_FLUID_CASE(6) MANYRODS_FLUID_CASE(7)
    MANYRODS_FLUID_CASE(8) MANYRODS_FLUID_CASE(9) MANYRODS_FLUID_CASE(10) MANYRODS_FLUID_CASE(11)
    MANYRODS_FLUID_CASE(12) MANYRODS_FLUID_CASE(13) MANYRODS_FLUID_CASE(14) MANYRODS_FLUID_CASE(15)
#undef MANYRODS_FLUID_CASE
  }
}

}  // namespace manyrods
