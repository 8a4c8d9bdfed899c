// host/core/model/fluid.cpp — the fluid of include/manyrods/fluid.h: its mean velocity,
// the turbulent modes made from the seed, validation, and set_fluid (the
// lumped node arrays of kernels/fluid.h).
#include "manyrods/fluid.h"

#include <cmath>
#include <numbers>
#include <string>

#include "manyrods/rng.h"
#include "kernels/fluid.h"
#include "manyrods/batch.h"
#include "manyrods/material.h"

namespace manyrods {
namespace {

[[noreturn]] void fail(const std::string& what) { throw InputError(what); }

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

bool finite3(const Vec3& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

void check_non_negative(double v, const std::string& field) {
  if (!std::isfinite(v) || v < 0) fail(field + " = " + num(v) + ": must be a finite number >= 0");
}

}  // namespace

Vec3 Fluid::mean_velocity(double t) const {
  if (times.empty()) return velocity;
  if (t <= times.front()) return velocities.front();
  if (t >= times.back()) return velocities.back();
  std::size_t i = 1;
  while (times[i] < t) ++i;
  const double a = (t - times[i - 1]) / (times[i] - times[i - 1]);
  Vec3 u;
  for (int d = 0; d < 3; ++d) u[d] = (1 - a) * velocities[i - 1][d] + a * velocities[i][d];
  return u;
}

Vec3 Fluid::mean_displacement(double t) const {
  Vec3 x{0, 0, 0};
  auto add = [&](const Vec3& u, double dt) {
    for (int d = 0; d < 3; ++d) x[d] += u[d] * dt;
  };
  if (times.empty()) {
    add(velocity, t);
    return x;
  }
  // ∫ from 0 to t of the table (held before the first and after the last
  // entry): the trapezoid of each piece between the breakpoints in [0, t]
  const double lo = std::min(0.0, t), hi = std::max(0.0, t), sign = t >= 0 ? 1.0 : -1.0;
  std::vector<double> cuts{lo};
  for (double tk : times)
    if (tk > lo && tk < hi) cuts.push_back(tk);
  cuts.push_back(hi);
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
    const Vec3 a = mean_velocity(cuts[i]), b = mean_velocity(cuts[i + 1]);
    const double dt = sign * (cuts[i + 1] - cuts[i]);
    for (int d = 0; d < 3; ++d) x[d] += 0.5 * (a[d] + b[d]) * dt;
  }
  return x;
}

std::vector<TurbulentMode> turbulent_modes(const Turbulence& t) {
  std::vector<TurbulentMode> modes;
  if (!(t.intensity > 0) || t.modes <= 0) return modes;
  Rng rng{t.seed};
  const double two_pi = 2 * std::numbers::pi;
  // per-component rms `intensity`: Σ_m |a_m|²/2 = 3 I², equal |a_m|
  const double amp = t.intensity * std::sqrt(6.0 / t.modes);
  for (int m = 0; m < t.modes; ++m) {
    // direction of k uniform on the sphere, |k| = 2π/L × [0.5, 2)
    const double z = 2 * rng.next() - 1, phi = two_pi * rng.next();
    const double rxy = std::sqrt(std::max(0.0, 1 - z * z));
    const Vec3 kh{rxy * std::cos(phi), rxy * std::sin(phi), z};
    const double kmag = two_pi / t.length_scale * (0.5 + 1.5 * rng.next());
    // amplitude direction uniform in the plane ⊥ k (divergence-free mode)
    const Vec3 e1 = std::abs(kh[2]) < 0.9 ? Vec3{-kh[1], kh[0], 0} : Vec3{0, -kh[2], kh[1]};
    const double n1 = std::hypot(e1[0], e1[1], e1[2]);
    const Vec3 u1{e1[0] / n1, e1[1] / n1, e1[2] / n1};
    const Vec3 u2{kh[1] * u1[2] - kh[2] * u1[1], kh[2] * u1[0] - kh[0] * u1[2], kh[0] * u1[1] - kh[1] * u1[0]};
    const double psi = two_pi * rng.next();
    TurbulentMode md;
    for (int d = 0; d < 3; ++d) {
      md.k[d] = kmag * kh[d];
      md.amplitude[d] = amp * (std::cos(psi) * u1[d] + std::sin(psi) * u2[d]);
    }
    md.omega = two_pi / t.time_scale * (0.5 + rng.next());
    md.phase = two_pi * rng.next();
    modes.push_back(md);
  }
  return modes;
}

Vec3 Fluid::velocity_at(const Vec3& x, double t) const {
  Vec3 u = mean_velocity(t);
  const Vec3 X = mean_displacement(t);
  for (const TurbulentMode& m : turbulent_modes(turbulence)) {
    double arg = m.omega * t + m.phase;
    for (int d = 0; d < 3; ++d) arg += m.k[d] * (x[d] - X[d]);
    arg = std::remainder(arg, 2 * std::numbers::pi);  // (as the kernels' phases)
    const double s = fluid_sin(arg);  // the kernels' sin (kernels/fluid.h)
    for (int d = 0; d < 3; ++d) u[d] += m.amplitude[d] * s;
  }
  return u;
}

void Fluid::validate() const {
  check_non_negative(density, "fluid.density");
  if (!finite3(velocity)) fail("fluid.velocity: not finite");
  if (times.size() != velocities.size())
    fail("fluid.velocities: " + std::to_string(velocities.size()) + " given, one per time (" +
         std::to_string(times.size()) + ") needed");
  for (std::size_t i = 0; i < times.size(); ++i) {
    if (!std::isfinite(times[i])) fail("fluid.times[" + std::to_string(i) + "]: not finite");
    if (i > 0 && !(times[i] > times[i - 1]))
      fail("fluid.times[" + std::to_string(i) + "] = " + num(times[i]) + ": times must increase strictly");
    if (!finite3(velocities[i])) fail("fluid.velocities[" + std::to_string(i) + "]: not finite");
  }
  const Turbulence& t = turbulence;
  check_non_negative(t.intensity, "fluid.turbulence.intensity");
  if (t.intensity > 0) {
    if (!std::isfinite(t.length_scale) || !(t.length_scale > 0))
      fail("fluid.turbulence.length_scale = " + num(t.length_scale) + ": must be a finite number > 0");
    if (!std::isfinite(t.time_scale) || !(t.time_scale > 0))
      fail("fluid.turbulence.time_scale = " + num(t.time_scale) + ": must be a finite number > 0");
    if (t.modes < 1 || t.modes > 256)
      fail("fluid.turbulence.modes = " + std::to_string(t.modes) + ": must be in [1, 256]");
  }
}

void validate_drag(const Drag& d) {
  check_non_negative(d.normal, "drag.normal");
  check_non_negative(d.tangential, "drag.tangential");
  check_non_negative(d.cd_normal, "drag.cd_normal");
  check_non_negative(d.cd_tangential, "drag.cd_tangential");
}

template <class T>
void set_fluid(RodBatch<T>& b, const Fluid& fluid) {
  fluid.validate();
  FluidData<T>& f = b.fluid;
  f = FluidData<T>{};
  f.spec = fluid;
  f.modes = turbulent_modes(fluid.turbulence);
  const double rho = fluid.density;
  for (const RodInfo& r : b.rods) {
    f.linear = f.linear || r.drag.normal > 0 || r.drag.tangential > 0;
    f.quadratic = f.quadratic || (rho > 0 && (r.drag.cd_normal > 0 || r.drag.cd_tangential > 0));
    f.buoyancy = f.buoyancy || (rho > 0 && r.drag.buoyancy);
  }
  f.on = f.linear || f.quadratic || f.buoyancy;
  if (!f.on) return;
  const std::size_t n = std::size_t(b.slots());
  auto allocate = [n](auto& a) {  // (one array, or one per component)
    if constexpr (std::is_same_v<std::decay_t<decltype(a)>, Array<T>>)
      a.resize(n, T(0));
    else
      for (Array<T>& c : a) c.resize(n, T(0));
  };
#define MANYRODS_FLUID_ALLOCATE(name, view, components, doc) allocate(f.name);
  MANYRODS_FLUID_FIELDS(MANYRODS_FLUID_ALLOCATE)
#undef MANYRODS_FLUID_ALLOCATE
  for (const RodInfo& r : b.rods) {
    const Drag& d = r.drag;
    const double diameter = 2 * r.contact_radius, area = r.section.area;
    for (int j = 0; j <= r.elements; ++j) {
      const int k = r.offset + 1 + j;
      const double left = j > 0 ? 0.5 * double(b.model.elem_rest_length[k - 1]) : 0.0;
      const double right = j < r.elements ? 0.5 * double(b.model.elem_rest_length[k]) : 0.0;
      const double l = left + right;
      // a tapered rod: the half elements' own diameters and areas (× f, × f²)
      const double fl = j > 0 ? r.scale(j - 1) : 0.0, fr = j < r.elements ? r.scale(j) : 0.0;
      const double dl = (fl * left + fr * right) * diameter, al = (fl * fl * left + fr * fr * right) * area;
      f.node_half_left[k] = T(left);
      f.node_half_right[k] = T(right);
      f.node_cn[k] = T(d.normal * l);
      f.node_ct[k] = T(d.tangential * l);
      f.node_qn[k] = T(0.5 * rho * d.cd_normal * dl);
      f.node_qt[k] = T(0.5 * rho * d.cd_tangential * std::numbers::pi * dl);
      f.node_buoyancy[k] = T(d.buoyancy ? rho * al : 0.0);
    }
  }
}

template void set_fluid<float>(RodBatch<float>&, const Fluid&);
template void set_fluid<double>(RodBatch<double>&, const Fluid&);

}  // namespace manyrods
