// tests/ref_batch.h — moving one rod between the reference (tests/reference.h)
// and the slots of a RodBatch, and random rods for the tests.
//
// load_rod writes every real entry of rod r (model, state, loads) from a
// ref::Rod, so a test can give each element its own stiffness, viscosity,
// mass and inertia (build_batch makes them uniform per rod). extract_rod reads
// them back. Neither does physics.
#pragma once

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "host/core/advanced.h"
#include "reference.h"

namespace manyrods::testing {

using ref::M3;
using ref::V3;

// Placeholder specs with the right element counts and clamps; load_rod then
// overwrites everything the physics reads.
inline std::vector<RodSpec> placeholder_specs(const std::vector<ref::Rod>& rods) {
  std::vector<RodSpec> specs;
  for (const ref::Rod& r : rods) {
    RodSpec s = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, 0.3, r.elements());
    s.section = Section::circle(0.005);
    s.material = {1000, 1e6, 0.3};
    s.clamped_root = r.clamped;
    specs.push_back(s);
  }
  return specs;
}

template <class T>
void load_rod(const ref::Rod& rod, RodBatch<T>& b, int r) {
  const int n = rod.elements();
  if (b.elements(r) != n || b.rods[r].clamped_root != rod.clamped)
    throw std::logic_error("load_rod: batch rod does not match");
  auto put3 = [](std::array<Array<T>, 3>& a, int k, const V3& v) {
    for (int d = 0; d < 3; ++d) a[d][k] = T(v[d]);
  };
  auto put_frame = [&](int k, const M3& q) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) b.state.elem_Q[3 * i + j][k] = T(q(i, j));
  };
  Model<T>& m = b.model;
  for (int j = 0; j <= n; ++j) {
    const int k = b.node_index(r, j);
    m.node_mass[k] = T(rod.mass[j]);
    m.node_inv_mass[k] = (j == 0 && rod.clamped) ? T(0) : T(1 / rod.mass[j]);
    put3(b.state.node_x, k, rod.x[j]);
    put3(b.state.node_v, k, rod.v[j]);
    put3(b.loads.node_force, k, rod.f_ext[j]);
  }
  put3(b.state.node_x, b.node_index(r, -1), rod.x[0]);  // root ghost node: finite, still
  for (int e = 0; e < n; ++e) {
    const int k = b.elem_index(r, e);
    m.elem_rest_length[k] = T(rod.l0[e]);
    put3(m.elem_stiffness, k, rod.CF[e]);
    put3(m.elem_rest_strain, k, rod.V0[e]);
    put3(m.elem_tau, k, rod.tauF[e]);
    put3(m.elem_inertia, k, rod.J[e]);
    put3(m.elem_inv_inertia, k, rod.J[e].cwiseInverse());
    put_frame(k, rod.Q[e]);
    put3(b.state.elem_w, k, rod.w[e]);
    put3(b.loads.elem_couple, k, rod.c_ext[e]);
  }
  // ghost elements: the clamp frame at the root, a copy of the last frame at the tip
  put_frame(b.elem_index(r, -1), rod.clamped ? rod.Q_clamp : rod.Q[0]);
  put3(b.state.elem_w, b.elem_index(r, -1), V3::Zero());
  put_frame(b.elem_index(r, n), rod.Q[n - 1]);
  put3(b.state.elem_w, b.elem_index(r, n), V3::Zero());
  for (int j = 0; j + 1 < n; ++j) {
    const int k = b.vor_index(r, j);
    m.vor_rest_length[k] = T(rod.D[j]);
    put3(m.vor_stiffness, k, rod.CM[j]);
    put3(m.vor_rest_curvature, k, rod.U0[j]);
    put3(m.vor_tau, k, rod.tauM[j]);
  }
  const int kr = b.root_vor_index(r);
  if (rod.clamped) {
    m.vor_rest_length[kr] = T(rod.D_root);
    put3(m.vor_stiffness, kr, rod.CM_root);
    put3(m.vor_rest_curvature, kr, rod.U0_root);
    put3(m.vor_tau, kr, rod.tauM_root);
  }
  b.model.gravity = {T(rod.g[0]), T(rod.g[1]), T(rod.g[2])};
}

template <class T>
ref::Rod extract_rod(const RodBatch<T>& b, int r) {
  const int n = b.elements(r);
  ref::Rod rod;
  auto get3 = [](const std::array<Array<T>, 3>& a, int k) {
    return V3(double(a[0][k]), double(a[1][k]), double(a[2][k]));
  };
  auto get_frame = [&](int k) {
    M3 q;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) q(i, j) = double(b.state.elem_Q[3 * i + j][k]);
    return q;
  };
  const Model<T>& m = b.model;
  for (int j = 0; j <= n; ++j) {
    const int k = b.node_index(r, j);
    rod.mass.push_back(double(m.node_mass[k]));
    rod.x.push_back(get3(b.state.node_x, k));
    rod.v.push_back(get3(b.state.node_v, k));
    rod.f_ext.push_back(get3(b.loads.node_force, k));
  }
  for (int e = 0; e < n; ++e) {
    const int k = b.elem_index(r, e);
    rod.l0.push_back(double(m.elem_rest_length[k]));
    rod.CF.push_back(get3(m.elem_stiffness, k));
    rod.V0.push_back(get3(m.elem_rest_strain, k));
    rod.tauF.push_back(get3(m.elem_tau, k));
    rod.J.push_back(get3(m.elem_inertia, k));
    rod.Q.push_back(get_frame(k));
    rod.w.push_back(get3(b.state.elem_w, k));
    rod.c_ext.push_back(get3(b.loads.elem_couple, k));
  }
  for (int j = 0; j + 1 < n; ++j) {
    const int k = b.vor_index(r, j);
    rod.D.push_back(double(m.vor_rest_length[k]));
    rod.CM.push_back(get3(m.vor_stiffness, k));
    rod.U0.push_back(get3(m.vor_rest_curvature, k));
    rod.tauM.push_back(get3(m.vor_tau, k));
  }
  rod.clamped = b.rods[r].clamped_root;
  if (rod.clamped) {
    const int kr = b.root_vor_index(r);
    rod.Q_clamp = get_frame(b.elem_index(r, -1));
    rod.D_root = double(m.vor_rest_length[kr]);
    rod.CM_root = get3(m.vor_stiffness, kr);
    rod.U0_root = get3(m.vor_rest_curvature, kr);
    rod.tauM_root = get3(m.vor_tau, kr);
  }
  rod.g = V3(double(m.gravity[0]), double(m.gravity[1]), double(m.gravity[2]));
  return rod;
}

template <class T>
RodBatch<T> make_batch(const std::vector<ref::Rod>& rods) {
  RodBatch<T> b = build_batch<T>(placeholder_specs(rods));
  for (int r = 0; r < static_cast<int>(rods.size()); ++r) load_rod(rods[r], b, r);
  return b;
}

// ---- random rods ---------------------------------------------------------

struct Random {
  std::mt19937_64 gen;
  explicit Random(std::uint64_t seed) : gen(seed) {}
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(gen); }
  V3 box(double a) { return V3(uniform(-a, a), uniform(-a, a), uniform(-a, a)); }
  V3 box(const V3& a) { return box(1.0).cwiseProduct(a); }
  V3 unit() {
    V3 u;
    do u = box(1.0);
    while (u.norm() < 0.1 || u.norm() > 1);
    return u.normalized();
  }
  V3 unit_perpendicular(const V3& t) {
    V3 u;
    do {
      u = unit();
      u -= t * t.dot(u);
    } while (u.norm() < 0.1);
    return u.normalized();
  }
  M3 rotation(double angle) { return Eigen::AngleAxisd(angle, unit()).toRotationMatrix(); }
  V3 range(const V3& lo, const V3& hi) {
    return V3(uniform(lo[0], hi[0]), uniform(lo[1], hi[1]), uniform(lo[2], hi[2]));
  }
};

inline M3 frame_from_rows(const V3& d1, const V3& d2, const V3& d3) {
  M3 q;
  q.row(0) = d1;
  q.row(1) = d2;
  q.row(2) = d3;
  return q;
}

// A random curved rod (about 0.3 m long, seed-cantilever-like magnitudes):
// tangents turn by 0.1–0.6 rad per element, frames are tilted 0.02–0.1 rad
// away from the tangents (shear ≠ 0) and twisted by up to ±0.4 rad per
// element, lengths differ from rest by ±5 % (stretch ≠ 0). Every element and
// Voronoi point draws its own stiffness, retardation times, mass and inertia.
// Rest curvature = current curvature + a random offset; rest strain = e3 + a
// random offset. Random velocities, angular velocities, point forces, couples.
inline ref::Rod random_rod(Random& rnd, int n, bool clamped, const V3& g) {
  ref::Rod r;
  r.clamped = clamped;
  r.g = g;
  V3 t = rnd.unit();
  V3 d1 = rnd.unit_perpendicular(t);
  r.x.push_back(rnd.box(0.5));
  for (int e = 0; e < n; ++e) {
    const double l0 = 0.3 / n * rnd.uniform(0.8, 1.2);
    r.l0.push_back(l0);
    r.x.push_back(r.x.back() + l0 * rnd.uniform(0.95, 1.05) * t);
    const M3 tilt = Eigen::AngleAxisd(rnd.uniform(0.02, 0.1), rnd.unit_perpendicular(t)).toRotationMatrix();
    const V3 q3 = tilt * t, q1 = tilt * d1;
    r.Q.push_back(frame_from_rows(q1, q3.cross(q1), q3));
    // next tangent, d1 transported with it, then twisted about it
    const M3 turn = Eigen::AngleAxisd(rnd.uniform(0.1, 0.6), rnd.unit_perpendicular(t)).toRotationMatrix();
    t = (turn * t).normalized();
    d1 = Eigen::AngleAxisd(rnd.uniform(-0.4, 0.4), t) * (turn * d1);
    d1 = (d1 - t * t.dot(d1)).normalized();
  }
  for (int e = 0; e < n; ++e) {
    r.V0.push_back(V3(0, 0, 1) + rnd.box(0.05));
    r.CF.push_back(rnd.range({20, 20, 80}, {40, 40, 120}));
    r.tauF.push_back(rnd.range({0.005, 0.005, 0.005}, {0.02, 0.02, 0.02}));
    r.J.push_back(rnd.range({2e-8, 2e-8, 4e-8}, {3e-8, 3e-8, 6e-8}));
    r.w.push_back(rnd.box(10.0));
    r.c_ext.push_back(rnd.box(1e-3));
  }
  for (int j = 0; j <= n; ++j) {
    r.mass.push_back(rnd.uniform(2e-3, 4e-3));
    r.v.push_back(rnd.box(1.0));
    r.f_ext.push_back(rnd.box(0.05));
  }
  for (int j = 0; j + 1 < n; ++j) {
    const double D = 0.5 * (r.l0[j] + r.l0[j + 1]);
    r.D.push_back(D);
    r.U0.push_back(-ref::rotation_log(r.Q[j + 1] * r.Q[j].transpose()) / D + rnd.box(0.2 / D));
    r.CM.push_back(rnd.range({6e-4, 6e-4, 4e-4}, {1e-3, 1e-3, 6e-4}));
    r.tauM.push_back(rnd.range({0.005, 0.005, 0.005}, {0.02, 0.02, 0.02}));
  }
  if (clamped) {
    r.Q_clamp = r.Q[0] * rnd.rotation(0.2);
    r.D_root = 0.5 * r.l0[0];
    r.U0_root = -ref::rotation_log(r.Q[0] * r.Q_clamp.transpose()) / r.D_root + rnd.box(0.2 / r.D_root);
    r.CM_root = rnd.range({6e-4, 6e-4, 4e-4}, {1e-3, 1e-3, 6e-4});
    r.tauM_root = rnd.range({0.005, 0.005, 0.005}, {0.02, 0.02, 0.02});
    r.v[0].setZero();  // the clamped node does not move
  }
  return r;
}

}  // namespace manyrods::testing
