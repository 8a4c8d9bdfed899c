// docs/validation.md "3b Closed-form strain rates" — the closed-form strain
// rates σ̇, κ̇ (kernels/strains.h) against central differences in time of σ,
// κ along a smooth motion.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <utility>

#include "host/core/advanced.h"

using namespace manyrods;

namespace {

// A curly rod: helix of `turn` rad per element, frames rotated off the
// tangent by random angles (shear ≠ 0). Relative rotations between
// neighbours reach about `turn` rad.
RodSpec curly_rod(int n, double turn, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3> nodes(n + 1);
  const double r = 0.01, pitch = 0.004;
  for (int j = 0; j <= n; ++j) nodes[j] = {r * std::cos(turn * j), r * std::sin(turn * j), pitch * j};
  std::vector<Mat3> frames = RodSpec::parallel_transport_frames(nodes, {0, 0, 1});
  for (Mat3& f : frames) {
    Eigen::Matrix3d q;
    for (int i = 0; i < 9; ++i) q(i / 3, i % 3) = f[i];
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    q = q * Eigen::AngleAxisd(0.3 * u(rng), axis).toRotationMatrix();
    for (int i = 0; i < 9; ++i) f[i] = q(i / 3, i % 3);
  }
  RodSpec s = RodSpec::polyline(nodes, frames);
  s.section = Section::circle(0.002);
  s.material.density = 1000;
  s.material.youngs_modulus = 1e6;
  s.material.poisson_ratio = 0.3;
  return s;
}

struct Motion {
  std::vector<Eigen::Vector3d> x0, v0, a;  // per slot
  std::vector<Eigen::Matrix3d> q0;
  std::vector<Eigen::Vector3d> w;          // constant, material components
};

// State at time t: x = x0 + t v0 + ½ t² a, Q = exp(−t[ω]×) Q0 (so that
// Q̇ = −[ω]× Q with constant material ω); velocities at t = 0 are (v0, ω).
void set_state(RodBatch<double>& b, const Motion& m, double t) {
  for (int k = 0; k < b.slots(); ++k) {
    const Eigen::Vector3d x = m.x0[k] + t * m.v0[k] + 0.5 * t * t * m.a[k];
    const Eigen::Vector3d v = m.v0[k] + t * m.a[k];
    for (int d = 0; d < 3; ++d) {
      b.state.node_x[d][k] = x[d];
      b.state.node_v[d][k] = v[d];
      b.state.elem_w[d][k] = m.w[k][d];
    }
    const double th = m.w[k].norm() * t;
    Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
    if (th != 0) r = Eigen::AngleAxisd(-th, m.w[k].normalized()).toRotationMatrix();
    const Eigen::Matrix3d q = r * m.q0[k];
    for (int i = 0; i < 9; ++i) b.state.elem_Q[i][k] = q(i / 3, i % 3);
  }
}

struct Rates {
  std::vector<Eigen::Vector3d> sigma, kappa;
};

Rates strains(const RodBatch<double>& b) {
  Rates r;
  const ModelView<double> m = b.model_view();
  const ConstStateView<double> s = b.state_view();
  for (int k = 0; k < b.slots(); ++k) {
    const auto es = element_strain(k, m, s).sigma;
    const auto ks = voronoi_strain(k, m, s).kappa;
    r.sigma.emplace_back(es.x, es.y, es.z);
    r.kappa.emplace_back(ks.x, ks.y, ks.z);
  }
  return r;
}

Rates closed_form_rates(const RodBatch<double>& b) {
  Rates r;
  const ModelView<double> m = b.model_view();
  const ConstStateView<double> s = b.state_view();
  for (int k = 0; k < b.slots(); ++k) {
    const auto es = element_strain(k, m, s);
    const auto sr = element_strain_rate(k, m, s, es);
    const auto vs = voronoi_strain(k, m, s);
    const auto kr = voronoi_strain_rate(k, m, s, vs);
    r.sigma.emplace_back(sr.x, sr.y, sr.z);
    r.kappa.emplace_back(kr.x, kr.y, kr.z);
  }
  return r;
}

// max over real elements / joints of |central difference − closed form|,
// relative to the max |closed form|.
std::pair<double, double> fd_error(RodBatch<double>& b, const Motion& mo, double h) {
  set_state(b, mo, h);
  const Rates p = strains(b);
  set_state(b, mo, -h);
  const Rates q = strains(b);
  set_state(b, mo, 0);
  const Rates c = closed_form_rates(b);
  double es = 0, ek = 0, ms = 0, mk = 0;
  for (int r = 0; r < b.rod_count(); ++r) {
    const int n = b.elements(r);
    for (int e = 0; e < n; ++e) {
      const int k = b.elem_index(r, e);
      es = std::max(es, ((p.sigma[k] - q.sigma[k]) / (2 * h) - c.sigma[k]).norm());
      ms = std::max(ms, c.sigma[k].norm());
    }
    for (int j = 0; j + 1 < n; ++j) {
      const int k = b.vor_index(r, j);
      ek = std::max(ek, ((p.kappa[k] - q.kappa[k]) / (2 * h) - c.kappa[k]).norm());
      mk = std::max(mk, c.kappa[k].norm());
    }
  }
  return {es / ms, ek / mk};
}

}  // namespace

TEST(StrainRates, ClosedFormMatchesCentralDifferencesAtSecondOrder) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  // Three rods: gentle (0.2 rad per element), curly (1 rad), and one with a
  // relative rotation near π (3.0 rad) between neighbours.
  std::vector<RodSpec> rods = {curly_rod(12, 0.2, rng), curly_rod(9, 1.0, rng), curly_rod(6, 3.0, rng)};
  auto b = build_batch<double>(rods);
  Motion mo;
  const int S = b.slots();
  mo.x0.resize(S);
  mo.v0.resize(S);
  mo.a.resize(S);
  mo.q0.resize(S);
  mo.w.resize(S);
  for (int k = 0; k < S; ++k) {
    for (int d = 0; d < 3; ++d) mo.x0[k][d] = b.state.node_x[d][k];
    for (int i = 0; i < 9; ++i) mo.q0[k](i / 3, i % 3) = b.state.elem_Q[i][k];
    mo.v0[k] = 0.05 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    mo.a[k] = 0.5 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    mo.w[k] = 3.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));
  }
  // Central differences err by h²/6 · (third time derivative): the ratio of
  // errors for h and h/2 is 4 (order 2) while h is small enough that round-off
  // (ε·|σ|/h ≈ 1e-16/1e-4 = 1e-12 relative) stays far below the O(h²) term
  // (≈ (h|ω|)²/6 ≈ 1e-7 at h = 1e-4, |ω| ≈ 3).
  const double h = 1e-4;
  const auto e1 = fd_error(b, mo, h), e2 = fd_error(b, mo, h / 2);
  std::printf("relative error sigma %.3e %.3e, kappa %.3e %.3e\n", e1.first, e2.first, e1.second, e2.second);
  EXPECT_NEAR(std::log2(e1.first / e2.first), 2.0, 0.1);
  EXPECT_NEAR(std::log2(e1.second / e2.second), 2.0, 0.1);
  // Magnitude: (h|ω|)² / 6 with |ω| ≤ 3√3 and the acceleration terms: < 1e-6.
  EXPECT_LT(e1.first, 1e-6);
  EXPECT_LT(e1.second, 1e-6);
}

TEST(StrainRates, PlainAngularVelocityDifferenceIsWrongOnCurlyRods) {
  // The naive rate (ω_b − ω_a)/D̂ is not the rate of the discrete curvature
  // when neighbouring frames differ by a large rotation: under a rigid
  // rotation of a curly rod (κ̇ = 0 exactly) it is far from zero, while the
  // closed form vanishes to round-off. (3a: the hard case.)
  std::mt19937 rng(11);
  auto b = build_batch<double>({curly_rod(9, 1.0, rng)});
  const Eigen::Vector3d Omega(0.3, -2.0, 1.1);  // lab angular velocity, rigid
  for (int e = 0; e < 9; ++e) {
    const int k = b.elem_index(0, e);
    Eigen::Matrix3d q;
    for (int i = 0; i < 9; ++i) q(i / 3, i % 3) = b.state.elem_Q[i][k];
    const Eigen::Vector3d w = q * Omega;  // material components
    for (int d = 0; d < 3; ++d) b.state.elem_w[d][k] = w[d];
  }
  for (int j = 0; j <= 9; ++j) {
    const int k = b.node_index(0, j);
    Eigen::Vector3d x(b.state.node_x[0][k], b.state.node_x[1][k], b.state.node_x[2][k]);
    const Eigen::Vector3d v = Omega.cross(x);
    for (int d = 0; d < 3; ++d) b.state.node_v[d][k] = v[d];
  }
  const ModelView<double> m = b.model_view();
  const ConstStateView<double> s = std::as_const(b).state_view();
  double naive = 0, exact = 0, scale = Omega.norm() / b.model.vor_rest_length[b.vor_index(0, 0)];
  for (int j = 0; j < 8; ++j) {
    const int k = b.vor_index(0, j);
    const auto vs = voronoi_strain(k, m, s);
    const auto kr = voronoi_strain_rate(k, m, s, vs);
    exact = std::max(exact, std::sqrt(dot(kr, kr)));
    const vec3<double> d = (1.0 / m.vor_rest_length[k]) * (load3(s.elem_w, k) - load3(s.elem_w, k - 1));
    naive = std::max(naive, std::sqrt(dot(d, d)));
  }
  EXPECT_LT(exact, 1e-12 * scale);  // round-off of |ω|/D̂ quantities
  EXPECT_GT(naive, 0.1 * scale);    // wrong by O(θ|Ω|/D̂), θ ≈ 1 rad
}
