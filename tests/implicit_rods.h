// tests/implicit_rods.h — random rods for the implicit-solve tests
// (test_implicit_lanes, test_implicit_partitioned) and the dense system of a
// rod's solve with its round-off scale (the bound is derived in
// tests/test_implicit_lanes.cpp's header).
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "check.h"
#include "host/core/advanced.h"

namespace manyrods::testing {

template <class T>
constexpr double unit_roundoff() {
  return sizeof(T) == 4 ? 0x1p-24 : 0x1p-53;
}

// A rod along a random walk: element i turns from element i−1 by up to
// `max_turn` rad (bend) and twists by up to `max_turn` about its axis;
// random node velocities (≤ 0.1 m/s) and angular velocities (≤ 2 rad/s).
inline RodSpec random_rod(std::mt19937& rng, int n, bool clamped, double tau_s, bool stiff, double max_turn) {
  std::uniform_real_distribution<double> u(-1, 1), pos(0.8, 1.2);
  const double L = 0.3;
  std::vector<Vec3> nodes(n + 1);
  Eigen::Vector3d x(u(rng), u(rng), u(rng)), d(1, 0.2 * u(rng), 0.2 * u(rng));
  d.normalize();
  std::vector<Mat3> frames(n);
  Eigen::Vector3d d1 = d.unitOrthogonal();
  for (int i = 0; i <= n; ++i) {
    nodes[i] = {x.x(), x.y(), x.z()};
    if (i == n) break;
    if (i > 0) {  // turn d (and carry d1 along), then twist d1 about d
      Eigen::Vector3d axis = d.cross(Eigen::Vector3d(u(rng), u(rng), u(rng))).normalized();
      const Eigen::AngleAxisd bend(max_turn * std::abs(u(rng)), axis);
      d = (bend * d).normalized();
      d1 = bend * d1;
      d1 = (d1 - d1.dot(d) * d).normalized();
      d1 = Eigen::AngleAxisd(max_turn * u(rng), d) * d1;
    }
    const Eigen::Vector3d d2 = d.cross(d1);
    frames[i] = {d1.x(), d1.y(), d1.z(), d2.x(), d2.y(), d2.z(), d.x(), d.y(), d.z()};
    x += (L / n) * pos(rng) * d;
  }
  RodSpec s = RodSpec::polyline(nodes, frames);
  s.name = "random";
  s.section = Section::rectangle(0.01 * pos(rng), 0.01 * pos(rng));
  s.material = {1000 * pos(rng), 1e6 * std::pow(10.0, u(rng)), 0.3};
  // τE ≥ 0.87 τS keeps the bulk retardation time non-negative at ν = 0.3
  s.damping = tau_s > 0 ? Damping::shear_extension(tau_s, tau_s * (1.5 + 0.5 * u(rng))) : Damping::none();
  s.clamped_root = clamped;
  s.stiff_implicit = stiff;
  s.velocities.resize(n + 1);
  s.angular_velocities.resize(n);
  for (auto& v : s.velocities) v = {0.1 * u(rng), 0.1 * u(rng), 0.1 * u(rng)};
  for (auto& w : s.angular_velocities) w = {2 * u(rng), 2 * u(rng), 2 * u(rng)};
  return s;
}

// The system A u = b of rod `rod` exactly as viscous_implicit_rod builds it
// (same maps; in T, then to double; fixed unknowns: identity rows), with
// A − M = hD (fixed rows and columns zeroed) and u⁻. `prescribed`: the fixed
// unknowns keep their values p = u⁻ (b = p on their rows) and the free rows'
// coupling to them moves to b, b = M u⁻ − hD_fp p, done here in double from
// the dense blocks (an independent lifting); Avisc then holds those
// couplings too (for the round-off scale).
struct RodSystem {
  Eigen::SparseMatrix<double> A, Avisc;
  Eigen::VectorXd rhs, uminus;
};

template <Terms kT, class T>
RodSystem rod_system(const RodBatch<T>& b, int rod, T h, T stiff_h, bool prescribed = false) {
  using namespace viscous_detail;
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> s = b.state_view();
  const int first = b.rods[rod].offset + 1, cells = b.rods[rod].elements + 1, N = 6 * cells;
  std::vector<Eigen::Triplet<double>> a, av, lift;
  RodSystem sys;
  sys.rhs.resize(N);
  sys.uminus.resize(N);
  std::vector<bool> fixed(N, false);
  for (int c = 0; c < cells; ++c) {
    const int k = first + c;
    const T minv[6] = {m.node_inv_mass[k],       m.node_inv_mass[k],       m.node_inv_mass[k],
                       m.elem_inv_inertia[0][k], m.elem_inv_inertia[1][k], m.elem_inv_inertia[2][k]};
    for (int i = 0; i < 6; ++i) fixed[6 * c + i] = minv[i] == T(0);
  }
  struct Part {
    int at;
    mat3<T> map;
  };
  auto add = [&](const Part* parts, int count, vec3<T> w) {
    const double ww[3] = {double(w.x), double(w.y), double(w.z)};
    for (int p = 0; p < count; ++p)
      for (int q = 0; q < count; ++q)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) {
            double acc = 0;
            for (int l = 0; l < 3; ++l)
              acc += double(parts[p].map.m[3 * l + i]) * ww[l] * double(parts[q].map.m[3 * l + j]);
            const int r = parts[p].at + i, col = parts[q].at + j;
            if (prescribed && !fixed[r] && fixed[col]) {
              lift.emplace_back(r, col, double(h) * acc);
              av.emplace_back(r, col, double(h) * acc);
            }
            if (fixed[r] || fixed[col]) continue;
            a.emplace_back(r, col, double(h) * acc);
            av.emplace_back(r, col, double(h) * acc);
          }
  };
  for (int c = 0; c < cells; ++c) {
    const int k = first + c;
    vec3<T> w;
    mat3<T> b1, b2, b3, c1, c2;
    element_maps<kT>(k, stiff_h, m, s, w, b1, b2, b3);
    if (c + 1 < cells) {  // the tip ghost element has no stiffness
      const Part e[3] = {{6 * c, b1}, {6 * c + 3, b2}, {6 * c + 6, b3}};
      add(e, 3, w);
      voronoi_maps<kT>(k + 1, stiff_h, m, s, w, c1, c2);
      const Part v[2] = {{6 * c + 3, c1}, {6 * c + 9, c2}};
      add(v, 2, w);
    }
    if (c == 0) {
      voronoi_maps<kT>(k, stiff_h, m, s, w, c1, c2);
      const Part v[1] = {{3, c2}};
      add(v, 1, w);
    }
    const double mass[6] = {double(m.node_mass[k]),       double(m.node_mass[k]),
                            double(m.node_mass[k]),       double(m.elem_inertia[0][k]),
                            double(m.elem_inertia[1][k]), double(m.elem_inertia[2][k])};
    const double u[6] = {double(s.node_v[0][k]), double(s.node_v[1][k]), double(s.node_v[2][k]),
                         double(s.elem_w[0][k]), double(s.elem_w[1][k]), double(s.elem_w[2][k])};
    for (int i = 0; i < 6; ++i) {
      const int r = 6 * c + i;
      sys.uminus(r) = u[i];
      a.emplace_back(r, r, fixed[r] ? 1.0 : mass[i]);
      sys.rhs(r) = fixed[r] ? (prescribed ? u[i] : 0.0) : mass[i] * u[i];
    }
  }
  for (const Eigen::Triplet<double>& t : lift) sys.rhs(t.row()) -= t.value() * sys.uminus(t.col());
  sys.A.resize(N, N);
  sys.A.setFromTriplets(a.begin(), a.end());
  sys.Avisc.resize(N, N);
  sys.Avisc.setFromTriplets(av.begin(), av.end());
  return sys;
}

// The round-off scale s = |A⁻¹|(d dᵀ|u| + |b| + |A − M||u⁻|) per unknown (6
// per cell: v, ω) of rod `rod`'s system (dense: short rods only).
template <Terms kT, class T>
Eigen::VectorXd solve_scale(const RodBatch<T>& b, int rod, T h, T stiff_h, bool prescribed = false) {
  const RodSystem sys = rod_system<kT>(b, rod, h, stiff_h, prescribed);
  const Eigen::MatrixXd A(sys.A), Avisc(sys.Avisc);
  const Eigen::MatrixXd Ainv = A.inverse();
  const Eigen::VectorXd x = Ainv * sys.rhs;
  const Eigen::VectorXd d = A.diagonal().cwiseSqrt();
  const double dx = d.dot(x.cwiseAbs());
  return Ainv.cwiseAbs() * (dx * d + sys.rhs.cwiseAbs() + Avisc.cwiseAbs() * sys.uminus.cwiseAbs());
}

// The velocities of rod `rod` in `got` (cells c: node v, element ω) as one
// vector.
template <class T>
Eigen::VectorXd rod_velocities(const RodBatch<T>& got, int rod) {
  const int first = got.rods[rod].offset + 1, cells = got.rods[rod].elements + 1;
  Eigen::VectorXd u(6 * cells);
  for (int c = 0; c < cells; ++c)
    for (int d = 0; d < 3; ++d) {
      u(6 * c + d) = double(got.state.node_v[d][first + c]);
      u(6 * c + 3 + d) = double(got.state.elem_w[d][first + c]);
    }
  return u;
}

// A backward-stable solve's residual (Higham, Accuracy and Stability of
// Numerical Algorithms, Thm 10.4, with |R̂ᵀ||R̂| ≤ d dᵀ by Cauchy–Schwarz
// where the factor has fill, zero elsewhere): û solves (A + ΔA) û = b with
// |ΔA| ≤ k·u·d dᵀ on the unknowns within `reach` cells of each other, so
//   |A û − b|_i ≤ k·u·(d_i Σ_{|cell(j) − cell(i)| ≤ reach} d_j |û_j| + |b_i|);
// the residual is computed in double (one more rounding, within k's slack).
template <class T>
void check_residual(Checker& ck, const RodSystem& sys, const Eigen::VectorXd& u, int reach,
                    const std::string& tag) {
  const Eigen::VectorXd r = sys.A * u - sys.rhs;
  const Eigen::VectorXd d = Eigen::VectorXd(sys.A.diagonal()).cwiseSqrt();
  const int cells = int(u.size()) / 6;
  std::vector<double> prefix(cells + 1, 0.0);  // Σ d_j |û_j| over cells < c
  for (int c = 0; c < cells; ++c) {
    double acc = 0;
    for (int i = 0; i < 6; ++i) acc += d(6 * c + i) * std::abs(u(6 * c + i));
    prefix[c + 1] = prefix[c] + acc;
  }
  for (int c = 0; c < cells; ++c) {
    const double near = prefix[std::min(cells, c + reach + 1)] - prefix[std::max(0, c - reach)];
    for (int i = 0; i < 6; ++i) {
      const int j = 6 * c + i;
      ck.num(r(j), 0.0, d(j) * near + std::abs(sys.rhs(j)), tag + " residual of cell " + std::to_string(c));
    }
  }
}

// Compares the velocities of rod `rod` (cells c: node v, element ω) in `got`
// and `want` against k·u·scale.
template <class T>
void compare_rod(Checker& ck, const RodBatch<T>& got, const RodBatch<T>& want, int rod,
                 const Eigen::VectorXd& scale, const std::string& tag) {
  const int first = got.rods[rod].offset + 1, cells = got.rods[rod].elements + 1;
  for (int c = 0; c < cells; ++c) {
    const int k = first + c;
    for (int d = 0; d < 3; ++d) {
      ck.num(got.state.node_v[d][k], want.state.node_v[d][k], scale(6 * c + d),
             tag + " " + where("v of node", rod, c) + " dim " + std::to_string(d));
      ck.num(got.state.elem_w[d][k], want.state.elem_w[d][k], scale(6 * c + 3 + d),
             tag + " " + where("omega of cell", rod, c) + " dim " + std::to_string(d));
    }
  }
}


}  // namespace manyrods::testing
