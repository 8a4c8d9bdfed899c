// host/core/analysis/preload.h — gravity preload: the rest shape that makes
// the rods as built their own static equilibrium (include/manyrods/statics.h
// preload_rest_shape; docs/model.md "Gravity preload").
//
// Equations. At rest the residual of statics.h, r(x, Q; p) — the node
// forces and element couples on the free unknowns — is affine in the rest
// strains p = (V0 of each element, U0 of each joint): the internal force is
// C_F(σ − V0) and the moment C_M(κ − U0) (each over its dilatation), and
// everything else at fixed x, Q is constant. The preload keeps x, Q as built
// and changes p by Δp so that
//
//     r(x, Q; p + Δp) + C λ = 0,   λ ≥ 0,
//
// where C λ are the normal forces of the colliders on the touches within
// one contact radius of their surface (frictionless; each touch's force
// shared by its element's nodes as (1 − s, s), as static_colliders.h collider_push
// places it). J = ∂r/∂p is exact from one-sided differences (r is affine)
// and sparse (a rest strain reaches the cells beside its own), grouped as
// statics.h does: 18 residuals per rod.
//
// A rod with a free tip is statically determinate: J is square and Δp is
// the unique inverse (the internal force and moment summed from the tip).
// With more holds (both ends, interior nodes) J has more columns than rows
// and Δp is the one of least complementary energy
//
//     ½ Σ_elements l̂ ΔV0ᵀ C_F ΔV0 + ½ Σ_joints D̂ ΔU0ᵀ C_M ΔU0,
//
// which is what Menabrea's theorem picks for the redundant reactions of a
// linear structure built in this shape: the preload stress of a clamped–
// clamped beam is the beam theory's (tests/test_preload.cpp). The contact
// forces cost nothing: where a collider can carry the load it does.
//
// Solve: the saddle-point system of min ½|q|² s.t. A q + C λ = b with
// q = W^½ Δp (W = the energy's weights), rows scaled to unit norm, by
// sparse LU; touches whose λ comes out negative are dropped and it is
// solved again. The result is checked: the residual at the new rest shape
// must vanish to round-off, else the rod has no rest shape in which it
// stands as built (a free rod in gravity, a node that no strain reaches).
#pragma once

#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "host/core/analysis/statics.h"

namespace manyrods {

namespace detail {

// One rest parameter: a component of an element's V0 or a joint's U0.
struct RestParam {
  int slot = 0;
  int comp = 0;
  bool joint = false;
  double weight = 0;  // l̂ C_F or D̂ C_M: its complementary energy's weight
  double& value(RodBatch<double>& b) const {
    return joint ? b.model.vor_rest_curvature[comp][slot] : b.model.elem_rest_strain[comp][slot];
  }
};

// |g| of the batch (m/s²).
inline double gravity_magnitude(const RodBatch<double>& b) {
  return std::sqrt(b.model.gravity[0] * b.model.gravity[0] + b.model.gravity[1] * b.model.gravity[1] +
                   b.model.gravity[2] * b.model.gravity[2]);
}

// A touch of a collider that may carry load: a unit force along n at the
// element's nodes k and k + 1, shared as (1 − s, s).
struct PreloadTouch {
  int node = 0;  // slot of the element's first node
  double s = 0;
  Eigen::Vector3d n;
  int collider = 0;  // which collider
};

// The gradient ∂n/∂x of collider col's outward normal at the point x of a
// rod of radius r (the Hessian of the gap: the curvature of the surface
// the rod's axis stays on): (I − n nᵀ)/ρ about a sphere's centre at
// distance ρ, the same less the axis direction about a capsule's, zero on
// a plane. Central differences of collider_touches' normal at x (as a
// zero-length element), steps of 10⁻³ r (at least 10⁻⁹ m), symmetrized.
inline Eigen::Matrix3d collider_normal_gradient(const ColliderFrame<double>& col, const vec3<double>& x, double r) {
  const double h = std::max(1e-3 * r, 1e-9);
  auto normal = [&](vec3<double> p) {
    Touch<double> t[3];
    collider_touches(col, p, p, r, t);
    return Eigen::Vector3d(t[0].n.x, t[0].n.y, t[0].n.z);
  };
  Eigen::Matrix3d G;
  for (int a = 0; a < 3; ++a) {
    const vec3<double> e{a == 0 ? h : 0.0, a == 1 ? h : 0.0, a == 2 ? h : 0.0};
    G.col(a) = (normal(x + e) - normal(x - e)) / (2 * h);
  }
  return 0.5 * (G + G.transpose());
}

struct PreloadOutcome {
  bool ok = true;
  int contacts = 0;  // touches carrying load
  int worst_node = -1;
  double residual_force = 0, residual_couple = 0;
  bool unstable = false;  // the equilibrium found is an unstable one (preload_stability)
  double growth_rate = 0;  // 1/s: the fastest growth of a perturbation from it, when unstable (NaN: not measured)
};

// The residual's banded Jacobian of rod r (unknowns d) at its state, with
// shear and stretch softened to C'_F = min(C_F, 100 C_M/l̂²) and V0 moved
// so that the internal force stays (preload_stability, below); the
// stiffness and rest strains restored however it returns (the rod's own
// slots only: rods are preloaded in parallel on disjoint blocks). On the
// way: the rod's length, its smallest bending stiffness, its largest mass
// per length.
struct RodScales {
  double length = 0, soft_bend = std::numeric_limits<double>::infinity(), heavy = 0;
};
template <Terms kT>
void softened_jacobian(RodBatch<double>& b, int r, const RodDofs& d, std::array<Array<double>, 3>& f,
                       std::array<Array<double>, 3>& c, BandedJacobian& J, RodScales& sc) {
  const RodInfo& rod = b.rods[std::size_t(r)];
  const int n = rod.elements, o = rod.offset;
  struct Restore {
    RodBatch<double>& b;
    int o, n;
    std::vector<double> c, v;
    ~Restore() {
      for (int e = 0; e < n; ++e)
        for (int a = 0; a < 3; ++a) {
          b.model.elem_stiffness[a][o + 1 + e] = c[std::size_t(3 * e + a)];
          b.model.elem_rest_strain[a][o + 1 + e] = v[std::size_t(3 * e + a)];
        }
    }
  } restore{b, o, n, std::vector<double>(std::size_t(3 * n)), std::vector<double>(std::size_t(3 * n))};
  for (int e = 0; e < n; ++e)
    for (int a = 0; a < 3; ++a) {
      restore.c[std::size_t(3 * e + a)] = b.model.elem_stiffness[a][o + 1 + e];
      restore.v[std::size_t(3 * e + a)] = b.model.elem_rest_strain[a][o + 1 + e];
    }
  for (int e = 0; e < n; ++e) {
    const int k = o + 1 + e;
    const double l = b.model.elem_rest_length[k];
    sc.length += l;
    double cm = 0;
    for (int a = 0; a < 3; ++a) cm = std::max({cm, b.model.vor_stiffness[a][k], b.model.vor_stiffness[a][k + 1]});
    for (int a = 0; a < 2; ++a) {
      const double bend = b.model.vor_stiffness[a][k];
      if (bend > 0 && (e > 0 || b.model.vor_rest_length[k] > 0)) sc.soft_bend = std::min(sc.soft_bend, bend);
    }
    sc.heavy = std::max(sc.heavy, b.model.node_mass[k] / l);
    const vec3<double> x0{b.state.node_x[0][k], b.state.node_x[1][k], b.state.node_x[2][k]};
    const vec3<double> x1{b.state.node_x[0][k + 1], b.state.node_x[1][k + 1], b.state.node_x[2][k + 1]};
    mat3<double> Q;
    for (int i = 0; i < 9; ++i) Q.m[i] = b.state.elem_Q[i][k];
    const vec3<double> V = (1 / l) * mul(Q, x1 - x0);
    for (int a = 0; a < 3; ++a) {
      double& C = b.model.elem_stiffness[a][k];
      double& V0 = b.model.elem_rest_strain[a][k];
      const double soft = 100 * cm / (l * l);
      if (!(soft > 0 && soft < C)) continue;
      const double Va = a == 0 ? V.x : a == 1 ? V.y : V.z;
      V0 = Va - (C / soft) * (Va - V0);
      C = soft;
    }
  }
  J.plan(d, o);
  const Segment seg = rod_blocks(rod);
  banded_jacobian<kT>(b, d, f, c, sc.length, 1e-6, J, ResidualAt{&seg, 1.0, nullptr, r});
}

// Stability of the equilibrium the preload found (docs/model.md "Gravity
// preload", Stability). The rod as built, at rest under the loads, is in
// equilibrium; it is a stable one when the stiffness K = −∂r/∂q (q: the
// free positions and frame turns, r: the residual of statics.h) is positive
// definite on the motions the colliders' pushing touches allow. Small
// motions from it obey M q̈ = −K q, so an eigenvalue ω² < 0 of
// K φ = ω² M φ is a motion that grows as e^{γt}, γ = √(−ω²).
//
// K comes from the residual's central differences (banded_jacobian), its
// symmetric part (K is symmetric at an equilibrium under conservative
// loads; the antisymmetric part is the differences' error). Two things keep
// the differences' error off the soft modes that decide stability:
// - Shear and stretch are softened for the differences to C'_F =
//   min(C_F, 100 C_M/l̂²) with V0 moved so that the internal force stays
//   what it is, C'_F (V − V0') = C_F (V − V0). The geometric stiffness of
//   that force (what buckles a column under its weight) is kept; the
//   constraint part shrinks to 100 times the element's bending stiffness,
//   which still pins the soft modes to their inextensible limit within
//   about 1 % (K grows with the penalty, so softening can only lower ω²:
//   the check errs towards "unstable"). The round-off of the differences
//   scales with C'_F: for a human hair 10⁵ times less.
// - A touch that pushes (λ > 0) holds its normal motion: leaving the
//   surface costs the work λ δ at first order, so the second-order check is
//   on the motions that keep the touch: K + k_c c cᵀ for each touch
//   (c: its normal at the element's nodes, weights 1 − s, s), k_c the
//   largest diagonal entry of K's positions (as stiff as the softened
//   stretch, far above the soft modes; larger only loses digits). Along the
//   surface the touch's force turns with the normal: the Lagrangian's
//   Hessian adds −λ w_a w_b ∂n/∂x (collider_normal_gradient) to the node
//   blocks a, b of the element — zero on a plane, destabilizing on a
//   convex collider (a weight resting on top of a sphere of radius ρ:
//   ω² = −g/ρ).
// Sylvester's law of inertia counts the eigenvalues below −τ as the
// negative pivots of the banded LDLᵀ of K + τ M (no pivoting; the band of
// statics.h). τ = 10⁻² ω_ref², ω_ref² = (|g| + F/m)/L, the rod's pendulum
// rate under its loads (L its length, m its mass, F the sum of the dead
// loads on it); for a rod with no loads C_M/(ρ A L⁴) (its smallest bending
// stiffness and largest mass per length), and with neither 10⁻⁸ of the
// largest K_ii/M_i. Instabilities slower than a tenth of the rod's own
// pendulum rate are not reported, and neither is the differences' error
// on a motion of zero stiffness (measured: −1.4e-5 ω_ref² for a pinned
// hanging hair turning about the vertical, −5e-6 ω_ref² for a stiff rod,
// E = 1e11 Pa, pinned on a floor). Where
// the pivots say unstable, a dense symmetric eigensolve (rods of up to
// kDenseDiagnosis unknowns) confirms it and gives γ. node_unknown: a free
// node's first unknown by slot − o, n + 3 long (preload_rod's node_row).
template <Terms kT>
void preload_stability(RodBatch<double>& b, int r, const RodDofs& d, const std::vector<ColliderFrame<double>>& colliders,
                       const std::vector<PreloadTouch>& touches, const Eigen::VectorXd& lambda,
                       const std::vector<int>& node_unknown,
                       std::array<Array<double>, 3>& f, std::array<Array<double>, 3>& c, PreloadOutcome& out) {
  const RodInfo& rod = b.rods[std::size_t(r)];
  const int n = rod.elements, o = rod.offset, m = d.size(), nn = 3 * int(d.node_slots.size());
  if (m == 0) return;
  BandedJacobian J;
  RodScales scales;
  softened_jacobian<kT>(b, r, d, f, c, J, scales);
  const double length = scales.length;

  // K = −sym(J) in the band, the touches' penalty, the mass
  constexpr int w = BandedJacobian::w;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(m, w + 1);  // K(i, i − j) for j ≤ i: the lower band
  auto at = [&](int i, int j) -> double& { return i >= j ? K(i, i - j) : K(j, j - i); };
  for (int i = 0; i < m; ++i)
    for (int j = std::max(0, i - w); j <= i; ++j) at(i, j) = -0.5 * (J.B(i, j - i + w) + J.B(j, i - j + w));
  Eigen::VectorXd M(m);
  double stiffest = 0;
  for (int u = 0; u < m; ++u) {
    const int p = J.pos[std::size_t(u)];
    M[p] = u < nn ? b.model.node_mass[d.node_slots[std::size_t(u / 3)]]
                  : b.model.elem_inertia[(u - nn) % 3][d.elem_slots[std::size_t((u - nn) / 3)]];
    if (u < nn) stiffest = std::max(stiffest, std::abs(at(p, p)));
  }
  for (std::size_t t = 0; t < touches.size(); ++t) {
    const double lam = lambda[Eigen::Index(t)];
    if (!(lam > 0)) continue;
    const PreloadTouch& tt = touches[t];
    int idx[6], cnt = 0;
    double cv[6], wv[6];
    vec3<double> x{0, 0, 0};
    for (int side = 0; side < 2; ++side) {
      const double weight = side ? tt.s : 1 - tt.s;
      const int k = tt.node + side;
      if (weight == 0) continue;
      x = x + weight * vec3<double>{b.state.node_x[0][k], b.state.node_x[1][k], b.state.node_x[2][k]};
      const int u = node_unknown[std::size_t(k - o)];
      if (u < 0) continue;
      for (int a = 0; a < 3; ++a) idx[cnt] = J.pos[std::size_t(u + a)], wv[cnt] = weight, cv[cnt++] = weight * tt.n[a];
    }
    const Eigen::Matrix3d G = collider_normal_gradient(colliders[std::size_t(tt.collider)], x,
                                                       b.rods[std::size_t(r)].element_radius(std::min(tt.node - o - 1, n - 1)));
    for (int i = 0; i < cnt; ++i)
      for (int j = 0; j < cnt; ++j)
        if (idx[i] >= idx[j])
          at(idx[i], idx[j]) += stiffest * cv[i] * cv[j] - lam * wv[i] * wv[j] * G(i % 3, j % 3);
  }
  const double g = gravity_magnitude(b);
  double mass = 0, load = 0;  // the rod's mass and dead loads
  for (int k = o + 1; k <= o + n + 1; ++k) {
    mass += b.model.node_mass[k];
    load += std::sqrt(b.loads.node_force[0][k] * b.loads.node_force[0][k] +
                      b.loads.node_force[1][k] * b.loads.node_force[1][k] +
                      b.loads.node_force[2][k] * b.loads.node_force[2][k]);
  }
  double omega_ref2 = (g + (mass > 0 ? load / mass : 0.0)) / length;
  if (!(omega_ref2 > 0) && std::isfinite(scales.soft_bend) && scales.heavy > 0)
    omega_ref2 = scales.soft_bend / (scales.heavy * std::pow(length, 4));
  if (!(omega_ref2 > 0))  // (neither loads nor bending stiffness: the largest K_ii/M_i)
    for (int i = 0; i < m; ++i) omega_ref2 = std::max(omega_ref2, 1e-8 * K(i, 0) / M[i]);
  const double tau = 1e-2 * omega_ref2;

  // LDLᵀ of K + τM in the band: a pivot ≤ 0 is an eigenvalue of
  // M^-½ K M^-½ below −τ
  Eigen::MatrixXd L = K;  // L(i, i − j): the factor below the diagonal, D on it
  for (int i = 0; i < m; ++i) L(i, 0) += tau * M[i];
  bool negative = false;
  for (int i = 0; i < m && !negative; ++i) {
    for (int j = std::max(0, i - w); j < i; ++j) {
      double v = L(i, i - j);
      for (int k = std::max(0, i - w); k < j; ++k) v -= L(i, i - k) * L(j, j - k) * L(k, 0);
      L(i, i - j) = v / L(j, 0);
    }
    double dii = L(i, 0);
    for (int k = std::max(0, i - w); k < i; ++k) dii -= L(i, i - k) * L(i, i - k) * L(k, 0);
    L(i, 0) = dii;
    negative = !(dii > 0);
  }
  if (!negative) return;
  if (m > kDenseDiagnosis) {  // too large to confirm: the pivots say so
    out.unstable = true;
    out.growth_rate = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  Eigen::MatrixXd A(m, m);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) A(i, j) = std::abs(i - j) <= w ? at(std::max(i, j), std::min(i, j)) / std::sqrt(M[i] * M[j]) : 0.0;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(A, Eigen::EigenvaluesOnly);
  const double lowest = es.eigenvalues()[0];
  if (lowest < -tau) {
    out.unstable = true;
    out.growth_rate = std::sqrt(-lowest);
  }
}

template <Terms kT>
PreloadOutcome preload_rod(RodBatch<double>& b, int r, const std::vector<ColliderFrame<double>>& colliders,
                           std::array<Array<double>, 3>& f, std::array<Array<double>, 3>& c) {
  PreloadOutcome out;
  const RodInfo& rod = b.rods[std::size_t(r)];
  const int n = rod.elements, o = rod.offset;
  const RodDofs d = rod_dofs(b, r);
  const int m = d.size(), nn = 3 * int(d.node_slots.size());
  if (m == 0) return out;  // every unknown held: nothing to balance

  std::vector<RestParam> params;
  for (int k = o; k <= o + n + 1; ++k)
    for (int a = 0; a < 3; ++a) {
      if (k > o && k <= o + n && b.model.elem_stiffness[a][k] != 0)
        params.push_back({k, a, false, b.model.elem_rest_length[k] * b.model.elem_stiffness[a][k]});
      if (b.model.vor_stiffness[a][k] != 0)
        params.push_back({k, a, true, b.model.vor_rest_length[k] * b.model.vor_stiffness[a][k]});
    }
  const int np = int(params.size());
  const Segment seg = rod_blocks(rod);
  const ResidualAt at{&seg, 1.0, nullptr, r};
  const Eigen::VectorXd r0 = static_residual<kT>(b, d, f, c, at);

  // the rows (residual entries) of each slot: a node's force, an element's couple
  std::vector<std::vector<int>> rows_of(static_cast<std::size_t>(n + 2));
  for (int i = 0; i < m; ++i) {
    const int slot = i < nn ? d.node_slots[std::size_t(i / 3)] : d.elem_slots[std::size_t((i - nn) / 3)];
    rows_of[std::size_t(slot - o)].push_back(i);
  }
  // ∂r/∂p: V0 of element k reaches the forces on nodes k, k + 1 and the
  // couple on element k; U0 of joint k the couples on elements k − 1, k:
  // the cells k − 1 … k + 1, so parameters 3 slots apart share a residual.
  std::vector<Eigen::Triplet<double>> jt;
  for (int g = 0; g < 18; ++g) {
    const bool joint = g >= 9;
    const int comp = (g % 9) / 3, phase = g % 3;
    std::vector<int> group;
    for (int p = 0; p < np; ++p) {
      const RestParam& q = params[std::size_t(p)];
      if (q.joint == joint && q.comp == comp && (q.slot - o) % 3 == phase) group.push_back(p);
    }
    if (group.empty()) continue;
    std::vector<double> h(group.size());
    std::vector<double> old(group.size());
    for (std::size_t i = 0; i < group.size(); ++i) {
      const RestParam& q = params[std::size_t(group[i])];
      h[i] = joint ? 1e-3 / b.model.vor_rest_length[q.slot] : 1e-3;
      old[i] = q.value(b);
      q.value(b) = old[i] + h[i];
    }
    const Eigen::VectorXd r1 = static_residual<kT>(b, d, f, c, at);
    for (std::size_t i = 0; i < group.size(); ++i) {
      const RestParam& q = params[std::size_t(group[i])];
      q.value(b) = old[i];
      for (int cell = std::max(0, q.slot - o - 1); cell <= std::min(n + 1, q.slot - o + 1); ++cell)
        for (const int row : rows_of[std::size_t(cell)]) {
          const double v = (r1[row] - r0[row]) / h[i];
          if (v != 0) jt.emplace_back(row, group[i], v);
        }
    }
  }

  // the touches near a collider (gap within one contact radius)
  std::vector<PreloadTouch> touches;
  const ConstStateView<double> sv = std::as_const(b).state_view();
  for (int e = 0; e < n; ++e) {
    const int k = o + 1 + e;
    if (b.model.node_inv_mass[k] == 0 && b.model.node_inv_mass[k + 1] == 0) continue;
    const vec3<double> x0 = load3(sv.node_x, k), x1 = load3(sv.node_x, k + 1);
    for (const ColliderFrame<double>& col : colliders) {
      Touch<double> t[3];
      const int count = collider_touches(col, x0, x1, rod.element_radius(e), t);
      for (int i = 0; i < count; ++i) {
        if (!(t[i].gap <= rod.element_radius(e))) continue;
        // a touch at an end of the element is a node's: the element beside
        // it finds it too (a plane's); one column per node and normal, else
        // the two would make the system singular
        PreloadTouch pt{k, t[i].s, {t[i].n.x, t[i].n.y, t[i].n.z}, int(&col - colliders.data())};
        if (pt.s == 1) pt.node = k + 1, pt.s = 0;
        const bool seen = pt.s == 0 && std::any_of(touches.begin(), touches.end(), [&](const PreloadTouch& u) {
                            return u.node == pt.node && u.s == 0 && (u.n - pt.n).norm() < 1e-12;
                          });
        if (!seen) touches.push_back(pt);
      }
    }
  }
  // a free node's first row, by slot − o (a touch at the tip node names the slot after it, with weight 0)
  std::vector<int> node_row(static_cast<std::size_t>(n + 3), -1);
  for (int i = 0; i < nn; i += 3) node_row[std::size_t(d.node_slots[std::size_t(i / 3)] - o)] = i;

  // scaled: q = W^½ Δp, rows of [J W^-½ | C] to unit norm, C's columns too
  Eigen::SparseMatrix<double> J(m, np);
  J.setFromTriplets(jt.begin(), jt.end());
  Eigen::VectorXd wq(np);
  for (int p = 0; p < np; ++p) wq[p] = 1 / std::sqrt(params[std::size_t(p)].weight);
  const Eigen::SparseMatrix<double> A0 = J * wq.asDiagonal();
  const int nt = int(touches.size());
  Eigen::MatrixXd Cd = Eigen::MatrixXd::Zero(m, nt);  // (m × touches: a few per rod)
  for (int t = 0; t < nt; ++t)
    for (int side = 0; side < 2; ++side) {
      const int row = node_row[std::size_t(touches[std::size_t(t)].node + side - o)];
      if (row >= 0) Cd.block(row, t, 3, 1) += (side ? touches[std::size_t(t)].s : 1 - touches[std::size_t(t)].s) * touches[std::size_t(t)].n;
    }
  std::vector<char> active(static_cast<std::size_t>(nt), 1);
  for (int t = 0; t < nt; ++t) active[std::size_t(t)] = Cd.col(t).norm() > 0;  // (a touch on held nodes only)
  Eigen::VectorXd rs = Eigen::VectorXd::Zero(m);
  for (int k = 0; k < A0.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(A0, k); it; ++it) rs[it.row()] += it.value() * it.value();
  for (int i = 0; i < m; ++i) {
    rs[i] += Cd.row(i).squaredNorm();
    rs[i] = rs[i] > 0 ? 1 / std::sqrt(rs[i]) : 1.0;
  }
  const Eigen::SparseMatrix<double> A = rs.asDiagonal() * A0;
  const Eigen::MatrixXd C = rs.asDiagonal() * Cd;
  Eigen::VectorXd cs(nt);
  for (int t = 0; t < nt; ++t) cs[t] = C.col(t).norm() > 0 ? 1 / C.col(t).norm() : 1.0;
  const Eigen::VectorXd rhs = -(rs.asDiagonal() * r0);

  // KKT of min ½|q|² s.t. A q + C λ = b: [I 0 Aᵀ; 0 0 Cᵀ; A C 0] [q; λ; −y] = [0; 0; b],
  // over the active touches (λ ≥ 0: a touch that would pull is dropped)
  Eigen::VectorXd q, lambda = Eigen::VectorXd::Zero(nt);
  bool solved = false;
  for (int pass = 0; pass <= nt; ++pass) {
    std::vector<int> live;
    for (int t = 0; t < nt; ++t)
      if (active[std::size_t(t)]) live.push_back(t);
    const int na = int(live.size()), size = np + na + m;
    std::vector<Eigen::Triplet<double>> kt;
    for (int p = 0; p < np; ++p) kt.emplace_back(p, p, 1.0);
    for (int k = 0; k < A.outerSize(); ++k)
      for (Eigen::SparseMatrix<double>::InnerIterator it(A, k); it; ++it) {
        kt.emplace_back(np + na + int(it.row()), int(it.col()), it.value());
        kt.emplace_back(int(it.col()), np + na + int(it.row()), it.value());
      }
    for (int i = 0; i < na; ++i)
      for (int row = 0; row < m; ++row) {
        const double v = C(row, live[std::size_t(i)]) * cs[live[std::size_t(i)]];
        if (v == 0) continue;
        kt.emplace_back(np + na + row, np + i, v);
        kt.emplace_back(np + i, np + na + row, v);
      }
    Eigen::VectorXd bk = Eigen::VectorXd::Zero(size);
    bk.tail(m) = rhs;
    // A rod that its holds leave free to turn as a whole (a pinned root and
    // a free tip) has equations that no rest strain reaches — the moment of
    // its loads about the pin — so A loses rank and the saddle-point matrix
    // is singular. Then it is solved again with −δI on the multipliers'
    // block (δ = 1e-12 against A's unit rows): the least-squares Δp, which
    // balances the rod where its loads allow it (a pendulum hanging on its
    // vertical) and leaves the force the check below reports where they do
    // not (a pendulum off it).
    Eigen::VectorXd z;
    for (const double delta : {0.0, 1e-12}) {
      if (delta > 0)
        for (int row = 0; row < m; ++row) kt.emplace_back(np + na + row, np + na + row, -delta);
      Eigen::SparseMatrix<double> K(size, size);
      K.setFromTriplets(kt.begin(), kt.end());
      Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
      lu.compute(K);
      if (lu.info() == Eigen::Success) {
        z = lu.solve(bk);
        if (lu.info() == Eigen::Success && z.allFinite()) break;
      }
      z.resize(0);
    }
    if (z.size() == 0) break;
    q = z.head(np);
    lambda.setZero();
    double largest = 0;
    for (int i = 0; i < na; ++i) largest = std::max(largest, std::abs(z[np + i]));
    bool dropped = false;
    for (int i = 0; i < na; ++i) {
      const int t = live[std::size_t(i)];
      lambda[t] = z[np + i] * cs[t];
      if (z[np + i] < -1e-12 * largest) active[std::size_t(t)] = 0, dropped = true, lambda[t] = 0;
    }
    if (!dropped) {
      solved = true;
      break;
    }
  }

  // apply, then check the balance: r + C λ = 0 to round-off
  std::vector<double> before(static_cast<std::size_t>(np));
  for (int p = 0; p < np; ++p) before[std::size_t(p)] = params[std::size_t(p)].value(b);
  if (solved)
    for (int p = 0; p < np; ++p) params[std::size_t(p)].value(b) += wq[p] * q[p];
  const Eigen::VectorXd r1 = static_residual<kT>(b, d, f, c, at) + Cd * lambda;
  // What balances: the largest load or internal force on a node before
  // (a couple's: that times the rod's longest element), to 1e-8; and the
  // round-off of the internal forces, C_F (σ − V0) with σ ≈ e3: a thousand
  // ε C_F (a couple's: that times the longest element, and ε C_M |U0|/D̂).
  const double g = gravity_magnitude(b);
  double scale[2] = {0, 0}, longest = 0, stiffest[2] = {0, 0};
  for (int i = 0; i < m / 3; ++i) scale[i < nn / 3 ? 0 : 1] = std::max(scale[i < nn / 3 ? 0 : 1], r0.segment(3 * i, 3).norm());
  for (int k = o; k < o + n + 2; ++k) {
    const Eigen::Vector3d ext(b.loads.node_force[0][k], b.loads.node_force[1][k], b.loads.node_force[2][k]);
    scale[0] = std::max(scale[0], ext.norm() + b.model.node_mass[k] * g);
    if (k > o && k <= o + n) longest = std::max(longest, b.model.elem_rest_length[k]);
    for (int a = 0; a < 3; ++a) {
      stiffest[0] = std::max(stiffest[0], b.model.elem_stiffness[a][k]);
      const double u = b.model.vor_rest_length[k] > 0 ? std::abs(b.model.vor_rest_curvature[a][k]) + 1 / b.model.vor_rest_length[k] : 0;
      stiffest[1] = std::max(stiffest[1], b.model.vor_stiffness[a][k] * u);
    }
  }
  constexpr double kRoundOff = 1e3 * std::numeric_limits<double>::epsilon();
  const double tol_force = 1e-8 * scale[0] + kRoundOff * stiffest[0];
  const double tol_couple = 1e-8 * std::max(scale[1], scale[0] * longest) + kRoundOff * (stiffest[0] * longest + stiffest[1]);
  RodOutcome size;
  residual_size(d, r1, o + 1, size);
  out.residual_force = size.residual_force;
  out.residual_couple = size.residual_couple;
  out.worst_node = size.worst_node;
  for (int t = 0; t < nt; ++t) out.contacts += lambda[t] > 0;
  out.ok = solved && r1.allFinite() && out.residual_force <= tol_force && out.residual_couple <= tol_couple;
  if (!out.ok)
    for (int p = 0; p < np; ++p) params[std::size_t(p)].value(b) = before[std::size_t(p)];
  else
    preload_stability<kT>(b, r, d, colliders, touches, lambda, node_row, f, c, out);
  return out;
}

}  // namespace detail

// preload_rest_shape (include/manyrods/statics.h).
template <Terms kT>
PreloadResult preload_rest_shape(RodBatch<double>& b, int threads) {
  constexpr Terms kStatic = detail::kStaticTerms<kT>;
  PreloadResult res;
  bool any = false;
  for (const RodInfo& r : b.rods) any = any || r.preload;
  if (!any) return res;
  // the shape as built, at rest; the colliders where they are
  std::array<Array<double>, 3> f, c;
  const auto node_v = b.state.node_v;  // (the residual is at rest; the state's velocities are kept)
  const auto elem_w = b.state.elem_w;
  detail::at_rest(b, f, c);
  const std::vector<ColliderFrame<double>> colliders = detail::static_colliders(b, b.state.time);
  std::vector<detail::PreloadOutcome> outcome(std::size_t(b.rod_count()));
  detail::each_rod_in_waves(
      b, threads, [&](int r) { return b.rods[std::size_t(r)].preload; },
      [&](int r) { outcome[std::size_t(r)] = detail::preload_rod<kStatic>(b, r, colliders, f, c); });
  b.state.node_v = node_v;
  b.state.elem_w = elem_w;
  for (int r = 0; r < b.rod_count(); ++r) {
    if (!b.rods[std::size_t(r)].preload) continue;
    const detail::PreloadOutcome& o = outcome[std::size_t(r)];
    ++res.rods;
    res.contacts += o.contacts;
    res.residual_force = std::max(res.residual_force, o.residual_force);
    res.residual_couple = std::max(res.residual_couple, o.residual_couple);
    if (o.unstable) {  // the fastest measured (NaN: not measured, only until a rate is)
      const bool faster = res.unstable == 0 || (std::isnan(res.growth_rate) && !std::isnan(o.growth_rate)) ||
                          o.growth_rate > res.growth_rate;
      ++res.unstable;
      if (faster) res.unstable_rod = r, res.growth_rate = o.growth_rate;
    }
    if (o.ok || !res.ok) continue;
    res.ok = false;
    res.failed_rod = r;
    res.failed_node = o.worst_node;
    res.residual_force = o.residual_force;
    res.residual_couple = o.residual_couple;
  }
  return res;
}

}  // namespace manyrods
