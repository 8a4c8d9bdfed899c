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
// Stiff rods (RodSpec::stiff_implicit) integrate shear, stretch and twist
// implicitly; what stays explicit is bending on the motion those stiff terms
// allow, i.e. the flexural waves of the inextensible, unshearable rod (the
// rotation of an element follows its centerline: a rotary oscillation
// against bending alone would shear the element, which the implicit solve
// forbids). Its stiffness in the node displacements: the joint curvature
// κ_j = (t_{j+1} − t_j)/D̂_j with the unit tangents t = Δx/l̂, so
// |∂κ_j/∂x| ≤ (1/(l̂_j D̂_j), 1/(l̂_j D̂_j) + 1/(l̂_{j+1} D̂_j), 1/(l̂_{j+1} D̂_j)) on
// the three nodes of joint j, K = Σ_j B_j D̂_j aᵀa with B = max(EI₁, EI₂), and
// Gershgorin on M^{-1/2} K M^{-1/2} over the node masses (rotary inertia
// only lowers these frequencies; dropping it keeps the bound safe). For a
// uniform rod this is ω² ≤ 16 EI/(ρA l̂⁴), the zig-zag flexural mode.
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

// Gershgorin bounds (ω², τ·ω²) of the flexural waves of stiff rod r (above).
template <Terms kT, class T>
std::pair<double, double> stiff_rod_bound(const RodBatch<T>& b, int r) {
  if (!kT.bend) return {0.0, 0.0};
  const int n = b.elements(r);
  std::vector<double> rows(n + 1, 0.0), rows_tau(n + 1, 0.0), mass(n + 1, 0.0);
  for (int j = 0; j <= n; ++j) {
    const int k = b.node_index(r, j);
    mass[j] = b.model.node_inv_mass[k] == 0 ? 0.0 : double(b.model.node_mass[k]);
  }
  auto length = [&](int e) { return double(b.model.elem_rest_length[b.elem_index(r, e)]); };
  // joint j = −1 (root, at node 0: clamp frame and element 0) … n − 2, and
  // n − 1 (tip, at node n: element n − 1 and the tip's clamp frame; zero
  // stiffness unless the tip is clamped)
  for (int j = -1; j < n; ++j) {
    const int k = j < 0 ? b.root_vor_index(r) : b.vor_index(r, j);
    const double d = b.model.vor_rest_length[k];
    const double B = std::max(double(b.model.vor_stiffness[0][k]), double(b.model.vor_stiffness[1][k]));
    const double tau = kT.kelvin_voigt ? std::max(double(b.model.vor_tau[0][k]), double(b.model.vor_tau[1][k])) : 0.0;
    // nodes j, j+1, j+2 (the root joint's "element −1" and the tip joint's
    // "element n" are the fixed clamp frames)
    const double la = j < 0 ? 0.0 : 1 / (length(j) * d), lb = j + 1 < n ? 1 / (length(j + 1) * d) : 0.0;
    const double a[3] = {la, la + lb, lb};
    for (int p = 0; p < 3; ++p) {
      const int i = j + p;
      if (i < 0 || i > n || mass[i] == 0) continue;
      double s = 0;
      for (int q = 0; q < 3; ++q) {
        const int m = j + q;
        if (m >= 0 && m <= n && mass[m] != 0) s += B * d * a[p] * a[q] / std::sqrt(mass[i] * mass[m]);
      }
      rows[i] += s;
      rows_tau[i] += tau * s;
    }
  }
  double w2 = 0, tw2 = 0;
  for (int i = 0; i <= n; ++i) {
    w2 = std::max(w2, rows[i]);
    tw2 = std::max(tw2, rows_tau[i]);
  }
  return {w2, tw2};
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
    const auto [w2, tw2] =
        b.rods[r].stiff_implicit ? detail::stiff_rod_bound<kT>(b, r) : detail::explicit_rod_bound<kT>(b, r);
    wmax2 = std::max(wmax2, w2);
    tau_w2 = std::max(tau_w2, tw2);
  }
  out.omega_max = std::sqrt(wmax2);
  out.elastic = wmax2 > 0 ? 2 / out.omega_max : INFINITY;
  out.explicit_viscous = tau_w2 > 0 ? 2 / tau_w2 : INFINITY;
  return out;
}

}  // namespace manyrods
