// host/core/analysis/stable_dt.h — an estimate of the largest stable time step.
//
// Position Verlet is stable for the linearized undamped system when
// h · ω_max < 2. ω_max² is the largest eigenvalue of M^{-1/2} K M^{-1/2},
// where K is the elastic stiffness linearized at the current state:
//   element k:  K_e = l̂ Bᵀ C_F B,  B = [−Q/l̂ (x_k), [V]× (φ_k), Q/l̂ (x_{k+1})]
//   joint k:    K_v = D̂ Cᵀ C_M C,  C = [−I (φ_{k−1}), I (φ_k)] / D̂
// (V = Q e / l̂; φ the rotation increments, Q ← exp(−[φ]×)Q; stress-stiffening
// terms are dropped, exact at a stress-free state). Gershgorin's theorem
// bounds ω_max² by the largest absolute row sum of M^{-1/2} K M^{-1/2}, so
// the estimate 2/√(bound) never exceeds the linear limit; for uniform chains
// the bound is tight (the zig-zag mode), so it is not far below either.
//
// With the explicit viscous treatment the Kelvin–Voigt term adds the limit
// h ≲ 2/(τ ω_max²) (docs/model.md "Time stepping"), reported separately; the implicit
// treatment has no τ limit.
//
// Stiff rods (RodSpec::stiff_implicit) integrate every elastic term in the
// implicit solve (kernels/viscous_implicit.h "Stiff rods"): no linear limit.
// Their step is an accuracy choice: `accuracy` = ¼/ω₄, ω₄ = (β₄L)²·√(EI/ρA)/L²
// the fourth clamped–free bending frequency of the rod's mean section
// (β₄L = 10.9955; EI the larger bending stiffness), i.e. 25 steps a period of
// the fourth mode. The modes a swing excites lie mostly below it, and the
// scheme resolves them at second order: a damped human hair released
// horizontal is 1.3e-2 L off the resolved run over 1 s at 2.1e-3 s (0.9 of
// this step, as dt = "auto" takes it), 4.8e-2 L at 4.2e-3 s
// (bench/RESULTS.md "Stiff rods: bending in the solve").
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "manyrods/batch.h"
#include "manyrods/stable_dt.h"

namespace manyrods {

namespace detail {

// The accuracy step of stiff rod r (above); inf without bending.
template <Terms kT, class T>
double stiff_rod_accuracy(const RodBatch<T>& b, int r) {
  if (!kT.bend) return INFINITY;
  const int n = b.elements(r);
  double length = 0, mass = 0, ei = 0;
  for (int e = 0; e < n; ++e) length += double(b.model.elem_rest_length[b.elem_index(r, e)]);
  for (int j = 0; j <= n; ++j) mass += double(b.model.node_mass[b.node_index(r, j)]);
  for (int j = 0; j + 1 < n; ++j) {
    const int k = b.vor_index(r, j);
    ei += std::max(double(b.model.vor_stiffness[0][k]), double(b.model.vor_stiffness[1][k]));
  }
  if (n < 2 || !(length > 0) || !(mass > 0) || !(ei > 0)) return INFINITY;
  const double beta4 = 10.9955, w4 = beta4 * beta4 * std::sqrt(ei / (n - 1) / (mass / length)) / (length * length);
  return 0.25 / w4;
}

// Gershgorin bounds (ω², τ·ω²) of rod r with explicit shear, stretch and
// twist: element and joint stiffness blocks (above) over the lumped masses
// and rotary inertias.
template <Terms kT, class T>
std::pair<double, double> explicit_rod_bound(const RodBatch<T>& b, int r) {
  const int n = b.elements(r);
  // dofs: node j → 3j..3j+2 (j = 0..n), element e → 3(n+1) + 3e
  const int nd = 3 * (n + 1) + 3 * n;
  std::vector<double> rows(nd, 0.0), mass(nd, 0.0), rows_tau(nd, 0.0);
  for (int j = 0; j <= n; ++j) {
    const int k = b.node_index(r, j);
    for (int a = 0; a < 3; ++a)
      mass[3 * j + a] = b.model.node_inv_mass[k] == 0 ? 0.0 : double(b.model.node_mass[k]);
  }
  for (int e = 0; e < n; ++e) {
    const int k = b.elem_index(r, e);
    for (int a = 0; a < 3; ++a)
      mass[3 * (n + 1) + 3 * e + a] = double(b.model.elem_inertia[a][k]);
  }
  auto accumulate = [&](const Eigen::MatrixXd& K, const std::vector<int>& dof, double tau) {
    for (int i = 0; i < K.rows(); ++i) {
      if (mass[dof[i]] == 0) continue;
      double s = 0;
      for (int j = 0; j < K.cols(); ++j)
        if (mass[dof[j]] != 0) s += std::abs(K(i, j)) / std::sqrt(mass[dof[i]] * mass[dof[j]]);
      rows[dof[i]] += s;
      rows_tau[dof[i]] += tau * s;
    }
  };
  for (int e = 0; e < n; ++e) {
    const int k = b.elem_index(r, e);
    Eigen::Matrix3d q;
    for (int i = 0; i < 9; ++i) q(i / 3, i % 3) = double(b.state.elem_Q[i][k]);
    const double l = b.model.elem_rest_length[k];
    Eigen::Vector3d ed;
    for (int a = 0; a < 3; ++a) ed[a] = double(b.state.node_x[a][k + 1] - b.state.node_x[a][k]);
    const Eigen::Vector3d v = q * ed / l;
    Eigen::Matrix3d sk;
    sk << 0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0;
    Eigen::Matrix<double, 3, 9> B;
    B << -q / l, sk, q / l;
    const Eigen::Vector3d c(kT.shear ? double(b.model.elem_stiffness[0][k]) : 0.0,
                            kT.shear ? double(b.model.elem_stiffness[1][k]) : 0.0,
                            kT.stretch ? double(b.model.elem_stiffness[2][k]) : 0.0);
    const Eigen::MatrixXd K = l * B.transpose() * c.asDiagonal() * B;
    std::vector<int> dof;
    for (int a = 0; a < 3; ++a) dof.push_back(3 * e + a);
    for (int a = 0; a < 3; ++a) dof.push_back(3 * (n + 1) + 3 * e + a);
    for (int a = 0; a < 3; ++a) dof.push_back(3 * (e + 1) + a);
    double tau = 0;
    for (int a = 0; a < 3; ++a) tau = std::max(tau, double(b.model.elem_tau[a][k]));
    accumulate(K, dof, kT.kelvin_voigt ? tau : 0.0);
  }
  // joints: the root joint (clamp: only element 0), the interior ones and
  // the tip joint (clamp: only element n − 1; zero stiffness for a free tip)
  for (int j = -1; j < n; ++j) {
    const int k = j < 0 ? b.root_vor_index(r) : b.vor_index(r, j);
    const double d = b.model.vor_rest_length[k];
    const Eigen::Vector3d c(kT.bend ? double(b.model.vor_stiffness[0][k]) : 0.0,
                            kT.bend ? double(b.model.vor_stiffness[1][k]) : 0.0,
                            kT.twist ? double(b.model.vor_stiffness[2][k]) : 0.0);
    double tau = 0;
    for (int a = 0; a < 3; ++a) tau = std::max(tau, double(b.model.vor_tau[a][k]));
    if (j < 0 || j + 1 == n) {
      const int e = j < 0 ? 0 : n - 1;
      const Eigen::MatrixXd K = Eigen::Matrix3d(c.asDiagonal()) / d;
      accumulate(K, {3 * (n + 1) + 3 * e, 3 * (n + 1) + 3 * e + 1, 3 * (n + 1) + 3 * e + 2},
                 kT.kelvin_voigt ? tau : 0.0);
      continue;
    }
    Eigen::Matrix<double, 3, 6> C;
    C << -Eigen::Matrix3d::Identity() / d, Eigen::Matrix3d::Identity() / d;
    const Eigen::MatrixXd K = d * C.transpose() * c.asDiagonal() * C;
    std::vector<int> dof;
    for (int a = 0; a < 3; ++a) dof.push_back(3 * (n + 1) + 3 * j + a);
    for (int a = 0; a < 3; ++a) dof.push_back(3 * (n + 1) + 3 * (j + 1) + a);
    accumulate(K, dof, kT.kelvin_voigt ? tau : 0.0);
  }
  double w2 = 0, tw2 = 0;
  for (int i = 0; i < nd; ++i) {
    w2 = std::max(w2, rows[i]);
    tw2 = std::max(tw2, rows_tau[i]);
  }
  return {w2, tw2};
}

}  // namespace detail

template <Terms kT, class T>
StableDt stable_dt(const RodBatch<T>& b) {
  StableDt out;
  double wmax2 = 0, tau_w2 = 0;
  for (int r = 0; r < b.rod_count(); ++r) {
    if (b.rods[r].stiff_implicit) {
      out.accuracy = std::min(out.accuracy, detail::stiff_rod_accuracy<kT>(b, r));
      continue;
    }
    const auto [w2, tw2] = detail::explicit_rod_bound<kT>(b, r);
    wmax2 = std::max(wmax2, w2);
    tau_w2 = std::max(tau_w2, tw2);
  }
  out.omega_max = std::sqrt(wmax2);
  out.elastic = wmax2 > 0 ? 2 / out.omega_max : INFINITY;
  out.explicit_viscous = tau_w2 > 0 ? 2 / tau_w2 : INFINITY;
  return out;
}

}  // namespace manyrods
