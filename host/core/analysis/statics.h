// host/core/analysis/statics.h — static equilibrium of the discrete rods by Newton's method.
//
// Unknowns: the position of every free node and a rotation increment φ of
// every element frame (Q ← exp(−[φ]×) Q, material components). Residual: the
// generalized forces at zero velocity (node forces, element couples): the
// elastic terms plus λ × the external loads (gravity with the fluid's
// buoyancy, point forces and couples), and the colliders' push and friction
// (static_colliders.h), and with rod–rod or self contact the rods' pushes on
// each other (static_contact.h). A rod is solved on its own (rods whose
// kernel blocks do not overlap in parallel) with a banded Jacobian from
// central differences; rods that may touch each other are solved together
// (solve_group), their bands and the touching pairs' blocks by sparse LU. The loads, and driven holds walked to
// their pose at the hold time, are ramped along the load path in adaptive
// increments (halved where Newton fails, doubled where it converges fast),
// so that large deflections are reached along the equilibrium path; a
// failure is diagnosed as a mechanism (the loads push along a zero-stiffness
// motion) or a Newton failure (docs/model.md "Static equilibrium").
//
// This is an analysis tool (statics, connector loads, initial states), not
// part of the time step.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cstdlib>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include <Eigen/SparseCore>
#include <Eigen/SparseLU>

#include "host/core/analysis/static_colliders.h"
#include "host/core/analysis/static_contact.h"
#include "host/core/step/contact_stage.h"
#include "host/core/step/diagnostics.h"
#include "manyrods/statics.h"

namespace manyrods {

namespace detail {

struct RodDofs {
  std::vector<int> node_slots;  // free nodes
  std::vector<int> elem_slots;  // all elements
  int size() const { return 3 * int(node_slots.size() + elem_slots.size()); }
};

// Where a residual is evaluated: the resultants over seg (a rod's blocks;
// null: the whole batch), the external loads at load fraction lambda, and
// the colliders placed (null or empty: none) pressing on rod `rod` (−1:
// every rod).
struct ResidualAt {
  const Segment* seg = nullptr;
  double lambda = 1;
  const std::vector<ColliderFrame<double>>* colliders = nullptr;
  int rod = -1;
  bool current_anchors = false;  // friction only from anchors whose node has not moved since (collider_push)
};

// The residual of the unknowns d at load fraction at.lambda: the internal
// forces and couples (the elastic terms of kT) plus lambda times the
// external ones (gravity, the displaced fluid's buoyancy with it, point
// forces and couples), at rest, plus the colliders' push and friction
// (collider_push).
// The resultants are computed over at.seg (a rod's kernel blocks,
// rod_blocks; the whole batch by default), so a rod's residual costs its
// own slots, not the batch's; f and c receive the generalized forces on
// those slots.
template <Terms kT>
Eigen::VectorXd static_residual(RodBatch<double>& b, const RodDofs& d, std::array<Array<double>, 3>& f,
                                std::array<Array<double>, 3>& c, const ResidualAt& at = {}) {
  const Segment* seg = at.seg;
  const double lambda = at.lambda;
  constexpr Terms kInternal = [] {
    Terms t = kT;
    t.kelvin_voigt = t.gravity = t.loads = t.colliders = t.rod_contact = false;
    return t;
  }();
  const Segment r = seg ? *seg : whole(b);
  compute_resultants<kInternal>(b, Exec{}, r);
  const ModelView<double> m = b.model_view();
  const LoadsView<double> l = b.loads_view();
  const ConstScratchView<double> sc = std::as_const(b).scratch_view();
  const ConstStateView<double> s = std::as_const(b).state_view();
  const bool buoyancy = kT.gravity && b.fluid.on && b.fluid.buoyancy;
  for (int k = r.begin; k < r.end; ++k) {
    vec3<double> ext = node_external_force<kT>(k, m, l);
    if (buoyancy) ext = ext + (-b.fluid.node_buoyancy[k]) * m.gravity;
    const vec3<double> fk = node_force(k, sc) + lambda * ext;
    const mat3<double> Q = load_frame(s.elem_Q, k);
    const vec3<double> ck = element_couple(k, sc) + lambda * element_external_couple<kT>(k, l, Q);
    f[0][k] = fk.x, f[1][k] = fk.y, f[2][k] = fk.z;
    c[0][k] = ck.x, c[1][k] = ck.y, c[2][k] = ck.z;
  }
  if (at.colliders && !at.colliders->empty())
    for (int rr = at.rod < 0 ? 0 : at.rod; rr < (at.rod < 0 ? b.rod_count() : at.rod + 1); ++rr)
      collider_push(b, rr, *at.colliders, f, at.current_anchors);
  Eigen::VectorXd res(d.size());
  int i = 0;
  for (int k : d.node_slots)
    for (int a = 0; a < 3; ++a) res[i++] = f[a][k];
  for (int k : d.elem_slots)
    for (int a = 0; a < 3; ++a) res[i++] = c[a][k];
  return res;
}

// The colliders' part of the residual alone (their push and friction on
// rod at.rod's nodes, every rod's for −1), ordered as static_residual's
// (the elements' rows zero): the Jacobian takes its differences with a
// step of its own (collider_step).
inline Eigen::VectorXd collider_residual(const RodBatch<double>& b, const RodDofs& d, std::array<Array<double>, 3>& f,
                                         const ResidualAt& at) {
  const int r0 = at.rod < 0 ? 0 : at.rod, r1 = at.rod < 0 ? b.rod_count() : at.rod + 1;
  for (int rr = r0; rr < r1; ++rr) {
    const RodInfo& rod = b.rods[std::size_t(rr)];
    for (int k = rod.offset + 1; k <= rod.offset + 1 + rod.elements; ++k) f[0][k] = f[1][k] = f[2][k] = 0;
    collider_push(b, rr, *at.colliders, f, at.current_anchors);
  }
  Eigen::VectorXd res = Eigen::VectorXd::Zero(d.size());
  int i = 0;
  for (int k : d.node_slots)
    for (int a = 0; a < 3; ++a) res[i++] = f[a][k];
  return res;
}

// The difference step (m) for the colliders' part of the Jacobian: a
// quarter of the shallowest pressed touch's overlap — the push is
// quadratic in the overlap there, so a central difference that stays on one
// side of the surface is exact, and one across it is not: a steel wire's
// weight presses it nanometres into a floor, far less than the step h of
// the rods' terms (1e-6 L), whose differences across the surface left
// Newton converging linearly to a stall — and a tenth of the friction's
// stick length; at most h, at least 1e-10 L (round-off).
inline double collider_step(const RodBatch<double>& b, const ResidualAt& at, double h, double length) {
  double step = h;
  const int r0 = at.rod < 0 ? 0 : at.rod, r1 = at.rod < 0 ? b.rod_count() : at.rod + 1;
  for (int rr = r0; rr < r1; ++rr)
    each_collider_push(b, rr, *at.colliders, [&](int, int ci, double, vec3<double>, double g, double delta) {
      if (g < 0) step = std::min(step, -0.25 * g);
      const ColliderFrame<double>& col = (*at.colliders)[std::size_t(ci)];
      if (col.mu[0] > 0 || col.mu[2] > 0) step = std::min(step, kStickLength * delta);  // (ε/10: δ = r/10)
    });
  return std::max(step, 1e-10 * length);
}

// Rod r's unknowns: its free nodes and its free elements (a clamped
// interior node holds the frames on either side).
inline RodDofs rod_dofs(const RodBatch<double>& b, int r) {
  RodDofs d;
  for (int j = 0; j <= b.elements(r); ++j)
    if (b.model.node_inv_mass[b.node_index(r, j)] != 0) d.node_slots.push_back(b.node_index(r, j));
  for (int e = 0; e < b.elements(r); ++e)
    if (b.model.elem_inv_inertia[0][b.elem_index(r, e)] != 0) d.elem_slots.push_back(b.elem_index(r, e));
  return d;
}

inline void apply_dofs(RodBatch<double>& b, const RodDofs& d, const Eigen::VectorXd& dx) {
  int i = 0;
  for (int k : d.node_slots)
    for (int a = 0; a < 3; ++a) b.state.node_x[a][k] += dx[i++];
  for (int k : d.elem_slots) {
    const vec3<double> phi = {dx[i], dx[i + 1], dx[i + 2]};
    i += 3;
    mat3<double> q;
    for (int j = 0; j < 9; ++j) q.m[j] = b.state.elem_Q[j][k];
    q = mul(rotation_exp(-phi), q);
    for (int j = 0; j < 9; ++j) b.state.elem_Q[j][k] = q.m[j];
  }
}

// The cell of dof `col` (node j and element j share cell j: their slot less
// the rod's first) and its component (0–2 a node's x, y, z; 3–5 an
// element's rotation).
inline int dof_cell(const RodDofs& d, int col, int first) {
  const int nn = 3 * int(d.node_slots.size());
  return (col < nn ? d.node_slots[col / 3] : d.elem_slots[(col - nn) / 3]) - first;
}

// Moves dof `col` by h: what apply_dofs does with h in that entry and zeros
// elsewhere, touching that unknown only.
inline void apply_dof(RodBatch<double>& b, const RodDofs& d, int col, double h) {
  const int nn = 3 * int(d.node_slots.size());
  if (col < nn) {
    b.state.node_x[col % 3][d.node_slots[col / 3]] += h;
    return;
  }
  const int k = d.elem_slots[(col - nn) / 3], a = (col - nn) % 3;
  const vec3<double> phi = {a == 0 ? h : 0.0, a == 1 ? h : 0.0, a == 2 ? h : 0.0};
  mat3<double> q;
  for (int j = 0; j < 9; ++j) q.m[j] = b.state.elem_Q[j][k];
  q = mul(rotation_exp(-phi), q);
  for (int j = 0; j < 9; ++j) b.state.elem_Q[j][k] = q.m[j];
}

// ∂r/∂q by central differences: steps h_rel·length for positions, h_rel
// (rad) for rotations. The residual of cell r (its node's force, its
// element's couple) depends only on the unknowns of cells r − 2 … r + 2
// (node forces on the strains of the two elements beside the node; element
// couples on the curvatures of the two joints beside the element, which
// reach one element further): columns of one component whose cells are
// kBand apart are perturbed together, and each row takes the difference of
// the one column within its reach — the same numbers as one column at a
// time (tests/test_statics.cpp), with 2 × 6 × kBand residuals instead of 2
// per unknown. The state is restored exactly after each group. Each entry
// within reach goes to store(row, col, value), to be added (grouped), or every entry
// (one column at a time, for the test).
constexpr int kReach = 2;
template <Terms kT, class Store>
void jacobian_entries(RodBatch<double>& b, const RodDofs& d, std::array<Array<double>, 3>& f,
                      std::array<Array<double>, 3>& c, double length, double h_rel, bool grouped, Store&& store,
                      const ResidualAt& at = {}) {
  constexpr int kBand = 2 * kReach + 1;
  const int m = d.size(), nn = 3 * int(d.node_slots.size());
  const int first = std::min(d.node_slots.empty() ? 1 << 30 : d.node_slots[0], d.elem_slots.empty() ? 1 << 30 : d.elem_slots[0]);
  std::vector<int> cell(static_cast<std::size_t>(m)), group;
  int cells = 0;
  for (int i = 0; i < m; ++i) cells = std::max(cells, (cell[std::size_t(i)] = dof_cell(d, i, first)) + 1);
  std::vector<std::vector<int>> rows_of(static_cast<std::size_t>(cells));  // the unknowns of each cell
  for (int i = 0; i < m; ++i) rows_of[std::size_t(cell[std::size_t(i)])].push_back(i);
  const int groups = grouped ? 6 * kBand : m;
  // one pass of differences: the residual res() with each unknown's step
  // (0: the unknown is left out of this pass)
  auto pass = [&](auto&& res, auto&& step_of) {
    for (int gi = 0; gi < groups; ++gi) {
      group.clear();
      for (int col = 0; col < m; ++col) {
        const int comp = col < nn ? col % 3 : 3 + (col - nn) % 3;
        if ((grouped ? (comp == gi / kBand && cell[std::size_t(col)] % kBand == gi % kBand) : col == gi) && step_of(col) > 0)
          group.push_back(col);
      }
      if (group.empty()) continue;
      auto shift = [&](double s) {
        for (int col : group) apply_dof(b, d, col, s * step_of(col));
      };
      shift(1);
      const Eigen::VectorXd rp = res();
      shift(-2);
      const Eigen::VectorXd rm = res();
      shift(1);
      for (int col : group) {
        const double h = step_of(col);
        if (!grouped) {
          for (int row = 0; row < m; ++row) store(row, col, (rp[row] - rm[row]) / (2 * h));
          continue;
        }
        const int cc = cell[std::size_t(col)];
        for (int rc = std::max(0, cc - kReach); rc <= std::min(cells - 1, cc + kReach); ++rc)
          for (int row : rows_of[std::size_t(rc)]) store(row, col, (rp[row] - rm[row]) / (2 * h));
      }
    }
  };
  // The rods' terms and loads with the step h; the colliders' push and
  // friction (position unknowns only) with their own (collider_step); the
  // entries of the two passes add.
  const bool colliders = at.colliders && !at.colliders->empty();
  ResidualAt body = at;
  if (colliders) body.colliders = nullptr;
  pass([&] { return static_residual<kT>(b, d, f, c, body); },
       [&](int col) { return col < nn ? h_rel * length : h_rel; });
  if (colliders) {
    const double hc = collider_step(b, at, h_rel * length, length);
    pass([&] { return collider_residual(b, d, f, at); }, [&](int col) { return col < nn ? hc : 0.0; });
  }
}

// The Jacobian as a dense matrix (grouped, or one column at a time).
template <Terms kT>
Eigen::MatrixXd residual_jacobian(RodBatch<double>& b, const RodDofs& d, std::array<Array<double>, 3>& f,
                                  std::array<Array<double>, 3>& c, double length, double h_rel,
                                  bool grouped = true) {
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(d.size(), d.size());
  jacobian_entries<kT>(b, d, f, c, length, h_rel, grouped, [&](int row, int col, double v) { J(row, col) += v; });
  return J;
}

// The Jacobian in band storage. Ordered by cell (node, then element), the
// unknowns make J banded: entry (i, j) in that order is zero beyond
// w = 6 (kReach + 1) − 1 either side of the diagonal. Stored as
// B(i, j − i + w) for |j − i| ≤ w, with room for the fill-in of LU with
// partial pivoting (up to 2w right of the diagonal): m × (3w + 1).
struct BandedJacobian {
  static constexpr int w = 6 * (kReach + 1) - 1;
  std::vector<int> order, pos;  // banded position -> unknown, unknown -> banded position
  Eigen::MatrixXd B;            // [m, 3w + 1], column j − i + w
  void plan(const RodDofs& d, int first) {
    const int m = d.size();
    order.resize(std::size_t(m));
    pos.resize(std::size_t(m));
    for (int i = 0; i < m; ++i) order[std::size_t(i)] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return dof_cell(d, a, first) < dof_cell(d, b, first); });
    for (int i = 0; i < m; ++i) pos[std::size_t(order[std::size_t(i)])] = i;
  }
  // J·x (x, J·x in the unknowns' order), from the band as computed
  Eigen::VectorXd times(const Eigen::VectorXd& x) const {
    const int m = int(B.rows());
    Eigen::VectorXd y = Eigen::VectorXd::Zero(m);
    for (int i = 0; i < m; ++i) {
      double v = 0;
      for (int j = std::max(0, i - w); j <= std::min(m - 1, i + w); ++j) v += B(i, j - i + w) * x[order[std::size_t(j)]];
      y[order[std::size_t(i)]] = v;
    }
    return y;
  }
  Eigen::MatrixXd dense() const {
    const int m = int(B.rows());
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(m, m);
    for (int i = 0; i < m; ++i)
      for (int j = std::max(0, i - w); j <= std::min(m - 1, i + w); ++j)
        J(order[std::size_t(i)], order[std::size_t(j)]) = B(i, j - i + w);
    return J;
  }
};

template <Terms kT>
void banded_jacobian(RodBatch<double>& b, const RodDofs& d, std::array<Array<double>, 3>& f,
                     std::array<Array<double>, 3>& c, double length, double h_rel, BandedJacobian& J,
                     const ResidualAt& at = {}) {
  constexpr int w = BandedJacobian::w;
  J.B.setZero(d.size(), 3 * w + 1);
  jacobian_entries<kT>(
      b, d, f, c, length, h_rel, true,
      [&](int row, int col, double v) {
        J.B(J.pos[std::size_t(row)], J.pos[std::size_t(col)] - J.pos[std::size_t(row)] + w) += v;
      },
      at);
}

// Solves J x = rhs by Gaussian elimination with partial pivoting within the
// band (the pivot is sought in the w rows below; the rows swapped bring
// fill-in up to 2w right of the diagonal): m·w·3w operations instead of the
// dense LU's ⅔m³ — for the seed cantilever (m = 300) 50 times fewer — and
// the same pivots as the dense LU (column k is zero below row k + w).
// false when a pivot is zero (a singular J: the caller falls back to a
// pivoted QR).
inline bool solve_banded(const BandedJacobian& J, const Eigen::VectorXd& rhs, Eigen::VectorXd& x) {
  constexpr int w = BandedJacobian::w;
  const int m = int(J.B.rows());
  Eigen::MatrixXd A = J.B;  // A(i, j − i + w)
  auto at = [&](int i, int j) -> double& { return A(i, j - i + w); };
  Eigen::VectorXd y(m);
  for (int i = 0; i < m; ++i) y[i] = rhs[J.order[std::size_t(i)]];
  for (int k = 0; k < m; ++k) {
    const int last = std::min(m - 1, k + w), right = std::min(m - 1, k + 2 * w);
    int p = k;
    for (int i = k + 1; i <= last; ++i)
      if (std::abs(at(i, k)) > std::abs(at(p, k))) p = i;
    if (at(p, k) == 0) return false;
    if (p != k) {
      // row p holds entries from column p − w ≤ k on; row k's from k − w,
      // but those left of k are eliminated already (and not read again)
      for (int j = k; j <= right; ++j) {
        const double t = j - p + w <= 3 * w ? at(p, j) : 0.0;
        if (j - p + w <= 3 * w) at(p, j) = at(k, j);
        at(k, j) = t;
      }
      std::swap(y[k], y[p]);
    }
    for (int i = k + 1; i <= last; ++i) {
      const double l = at(i, k) / at(k, k);
      if (l == 0) continue;
      for (int j = k + 1; j <= right; ++j) at(i, j) -= l * at(k, j);
      y[i] -= l * y[k];
    }
  }
  for (int k = m - 1; k >= 0; --k) {
    double v = y[k];
    for (int j = k + 1; j <= std::min(m - 1, k + 2 * w); ++j) v -= at(k, j) * y[j];
    y[k] = v / at(k, k);
  }
  x.resize(m);
  for (int i = 0; i < m; ++i) x[J.order[std::size_t(i)]] = y[i];
  return x.allFinite();
}

// kT without the Kelvin–Voigt term: statics has no motion, no viscous force.
template <Terms kT>
inline constexpr Terms kStaticTerms = [] {
  Terms t = kT;
  t.kelvin_voigt = false;
  return t;
}();

// Velocities to zero (a state at rest), and the generalized-force arrays
// (one value per slot) sized for b.
inline void at_rest(RodBatch<double>& b, std::array<Array<double>, 3>& f, std::array<Array<double>, 3>& c) {
  for (auto* a : {&b.state.node_v, &b.state.elem_w})
    for (auto& x : *a)
      for (std::size_t k = 0; k < x.size(); ++k) x[k] = 0;
  for (int a = 0; a < 3; ++a) {
    f[a].resize(b.slots(), 0.0);
    c[a].resize(b.slots(), 0.0);
  }
}

// A rod's slots [o, o + n + 2) rounded out to whole kernel blocks (kGuard
// slots, the unit launch_with_fallback runs in): the range its residual
// computes resultants over. Rods whose ranges are disjoint can be solved at
// the same time.
inline Segment rod_blocks(const RodInfo& rod) {
  const int lo = rod.offset / kGuard * kGuard;
  const int hi = (rod.offset + rod.elements + 2 + kGuard - 1) / kGuard * kGuard;
  return {lo, hi, 0, 0, false};
}

// A driven hold's way from where it is to its pose at the solve's hold time
// (StaticOptions::hold_time), walked with the load fraction λ: the node on
// the straight line, each held frame turned at a constant rate,
// Q(λ) = exp(λ ψ) Q_start with exp(ψ) = Q_end Q_startᵀ.
struct HoldPath {
  int node = -1;
  vec3<double> x0{}, x1{};
  int frame[2] = {-1, -1};
  mat3<double> q0[2]{};
  vec3<double> psi[2]{};
};

inline std::vector<HoldPath> hold_paths(const RodBatch<double>& b, int rod, double t) {
  std::vector<HoldPath> out;
  if (!std::isfinite(t)) return out;
  for (const DrivenHold& d : b.driven) {
    if (d.rod != rod) continue;
    const Pose p = b.motions[std::size_t(d.motion)]->at(t);
    mat3<double> R;
    for (int i = 0; i < 9; ++i) R.m[i] = p.rotation[i];
    HoldPath h;
    h.node = d.node;
    for (int a = 0; a < 3; ++a) (&h.x0.x)[a] = b.state.node_x[a][d.node];
    h.x1 = mul_add(R, vec3<double>{d.x0[0], d.x0[1], d.x0[2]},
                   vec3<double>{p.translation[0], p.translation[1], p.translation[2]});
    for (int f = 0; f < 2; ++f) {
      if ((h.frame[f] = d.frame[f]) < 0) continue;
      for (int i = 0; i < 9; ++i) h.q0[f].m[i] = b.state.elem_Q[i][d.frame[f]];
      mat3<double> q0b;
      for (int i = 0; i < 9; ++i) q0b.m[i] = d.q0[f][i];
      const mat3<double> q1 = mul_transpose(q0b, R);  // Q = Q₀ Rᵀ (include/manyrods/drive.h)
      double theta, s, c;
      h.psi[f] = rotation_log(mul_transpose(q1, h.q0[f]), theta, s, c);
    }
    out.push_back(h);
  }
  return out;
}

inline void place_holds(RodBatch<double>& b, const std::vector<HoldPath>& paths, double lambda) {
  for (const HoldPath& h : paths) {
    const vec3<double> x = h.x0 + lambda * (h.x1 - h.x0);
    b.state.node_x[0][h.node] = x.x, b.state.node_x[1][h.node] = x.y, b.state.node_x[2][h.node] = x.z;
    for (int f = 0; f < 2; ++f) {
      if (h.frame[f] < 0) continue;
      const mat3<double> q = mul(rotation_exp(lambda * h.psi[f]), h.q0[f]);
      for (int i = 0; i < 9; ++i) b.state.elem_Q[i][h.frame[f]] = q.m[i];
    }
  }
}

// What one rod's solve found (solve_static merges them).
struct RodOutcome {
  bool ok = true;
  int iterations = 0, increments = 0;
  double last_update = 0, lambda = 1;
  double residual_force = 0, residual_couple = 0;
  int worst_node = -1, zero_modes = 0;
  bool mechanism = false;
  bool warm = false;  // started in equilibrium under the full loads
  int rod = -1;       // the rod with the largest residual force (of a group)
  int stick = 0, slip = 0;  // collider contacts with friction: sticking, at the friction limit
  bool walk = false;        // on the holds' walk under the full loads (the second leg, with friction)
};

// The largest |force| on a free node and |couple| on a free element of the
// residual vector r (ordered as RodDofs), and the node of the first.
inline void residual_size(const RodDofs& d, const Eigen::VectorXd& r, int first_node, RodOutcome& o) {
  o.residual_force = o.residual_couple = 0;
  const int nn = int(d.node_slots.size());
  for (int i = 0; i < nn; ++i) {
    const double v = r.segment(3 * i, 3).norm();
    if (v > o.residual_force || o.worst_node < 0) o.residual_force = v, o.worst_node = d.node_slots[std::size_t(i)] - first_node;
  }
  for (int i = nn; i < nn + int(d.elem_slots.size()); ++i) o.residual_couple = std::max(o.residual_couple, r.segment(3 * i, 3).norm());
}

// The round-off floor of rod r's residual: the size (force, couple) below
// which its entries are round-off of the elastic terms, not a state's
// imbalance. A strain is computed from node differences that carry round-off
// ε|x| (ε: double's epsilon, |x| the largest coordinate of the rod's nodes,
// the origin included), so a node's force is known to C_F ε|x|/ℓ (C_F: the
// element's largest of κGA, EA); a curvature from frames that carry ε, so an
// element's couple is known to C_M ε/D̂ plus the shear force's C_F ε|x|.
inline std::array<double, 2> residual_floor(const RodBatch<double>& b, int r) {
  const RodInfo& rod = b.rods[std::size_t(r)];
  double x = 0, force = 0, couple = 0;
  for (int j = 0; j <= rod.elements; ++j)
    for (int a = 0; a < 3; ++a) x = std::max(x, std::abs(b.state.node_x[a][rod.offset + 1 + j]));
  for (int e = 0; e < rod.elements; ++e) {
    const int k = rod.offset + 1 + e;
    const double cf = std::max({b.model.elem_stiffness[0][k], b.model.elem_stiffness[1][k], b.model.elem_stiffness[2][k]});
    force = std::max(force, cf / b.model.elem_rest_length[k]);
    couple = std::max(couple, cf);
    if (e + 1 < rod.elements) {
      const double cm = std::max({b.model.vor_stiffness[0][k + 1], b.model.vor_stiffness[1][k + 1], b.model.vor_stiffness[2][k + 1]});
      couple = std::max(couple, cm / b.model.vor_rest_length[k + 1] / std::max(x, 1e-300));
    }
  }
  constexpr double eps = std::numeric_limits<double>::epsilon();
  return {eps * force * x, eps * couple * x};
}

// The Newton matrix's rows of the frames' turns about their own d3 get
// 1e-6 of their diagonal added. Between two ends that leave the frames free
// (pins, a free end) a rod of isotropic section can spin its frames about
// their axes at no cost: J is singular along that motion, its LU's pivot
// there is round-off, and the update it gives is round-off divided by
// round-off, which the trust region then scales everything down by. The
// term gives that motion a finite, small update; the residual, hence the
// equilibrium, is unchanged, and modes with stiffness above ~1e-6 of the
// diagonal converge as before (at most 1e-6 slower per iteration).
inline void regularize_spin(BandedJacobian& J, int node_unknowns) {
  constexpr int w = BandedJacobian::w;
  for (int i = node_unknowns + 2; i < int(J.B.rows()); i += 3) {  // (unknown i: an element's turn about d3)
    double& diag = J.B(J.pos[std::size_t(i)], w);
    diag += 1e-6 * std::abs(diag);
  }
}

// Whether J q = −r has no solution because J is singular and r has a part
// outside J's range: the loads push along a motion that costs no energy.
// J is scaled symmetrically by its diagonal first (D^-½ J D^-½: a rod
// stiffened in shear and stretch has stiffnesses 1e10 apart, whose soft
// modes would otherwise look singular), then a rank-revealing QR takes
// pivots below 1e-8 of the largest as zero (the finite-difference
// Jacobian's zero modes come out near 1e-10) and the least-squares
// residual above 1e-6 of |r| as outside the range. zero_modes: the rank
// deficiency.
inline bool singular_against(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, int& zero_modes) {
  Eigen::VectorXd s(J.rows());
  for (int i = 0; i < J.rows(); ++i) s[i] = J(i, i) != 0 ? 1 / std::sqrt(std::abs(J(i, i))) : 1.0;
  const Eigen::MatrixXd A = s.asDiagonal() * J * s.asDiagonal();
  const Eigen::VectorXd rs = s.asDiagonal() * r;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  qr.setThreshold(1e-8);
  zero_modes = int(A.cols()) - int(qr.rank());
  if (zero_modes == 0) return false;
  const Eigen::VectorXd q = qr.solve(-rs);
  return (A * q + rs).norm() > 1e-6 * rs.norm();
}
// The largest Newton problem (unknowns) whose failure is diagnosed with a
// dense QR (singular_against; O(m³): 1,500 unknowns, a 250-element rod,
// take about a second).
inline constexpr int kDenseDiagnosis = 1500;

// A group of rods solved together (rods that touch each other: rod–rod
// contact couples their unknowns; static_contact.h contact_groups): each
// rod's unknowns (RodDofs) stacked in the group's order.
struct GroupDofs {
  std::vector<int> rods;
  std::vector<RodDofs> d;
  std::vector<int> start;      // rod i's first unknown; start.back(): all of them
  std::vector<Segment> seg;    // rod i's kernel blocks (rod_blocks)
  std::vector<double> length;  // rod i's rest length
  std::vector<std::vector<int>> node_row;  // rod i's node j → the row of its x (−1: held)
  bool contact = false;        // its rods meet each other or themselves (static_rod_contact)
  int size() const { return start.back(); }
  int index_of(int rod) const {  // the group's index of `rod`
    return rods.size() == 1 ? 0 : int(std::lower_bound(rods.begin(), rods.end(), rod) - rods.begin());
  }
  // the row of node slot k of rod `rod` (−1: held)
  int row(const RodBatch<double>& b, int rod, int k) const {
    const int i = index_of(rod);
    return node_row[std::size_t(i)][std::size_t(k - b.rods[std::size_t(rod)].offset - 1)];
  }
};

inline GroupDofs group_dofs(const RodBatch<double>& b, const std::vector<int>& rods, bool contact) {
  GroupDofs g;
  g.rods = rods;
  g.contact = contact;
  g.start.push_back(0);
  for (int r : rods) {
    const RodInfo& rod = b.rods[std::size_t(r)];
    g.d.push_back(rod_dofs(b, r));
    g.start.push_back(g.start.back() + g.d.back().size());
    g.seg.push_back(rod_blocks(rod));
    double length = 0;
    for (int e = 0; e < rod.elements; ++e) length += b.model.elem_rest_length[b.elem_index(r, e)];
    g.length.push_back(length);
    std::vector<int> rows(std::size_t(rod.elements + 1), -1);
    const RodDofs& d = g.d.back();
    for (std::size_t i = 0; i < d.node_slots.size(); ++i)
      rows[std::size_t(d.node_slots[i] - rod.offset - 1)] = g.start[g.start.size() - 2] + 3 * int(i);
    g.node_row.push_back(std::move(rows));
  }
  return g;
}

// The residual of group g at load fraction lam: each rod's (static_residual
// over its blocks, with the colliders) stacked, plus the rod–rod and self
// contacts' push (static_contact.h pair_push) on the free nodes. touching
// (if given) receives the pairs that push; rod_scale (if given) each rod's
// largest |force| and |couple| on its slots, held ones included.
template <Terms kT>
Eigen::VectorXd group_residual(RodBatch<double>& b, const GroupDofs& g, std::array<Array<double>, 3>& f,
                               std::array<Array<double>, 3>& c, double lam,
                               const std::vector<ColliderFrame<double>>* colliders,
                               std::vector<ElementPair>* touching = nullptr,
                               std::vector<std::array<double, 2>>* rod_scale = nullptr) {
  Eigen::VectorXd res(g.size());
  if (rod_scale) rod_scale->assign(g.rods.size(), {0.0, 0.0});
  for (std::size_t i = 0; i < g.rods.size(); ++i) {
    const int r = g.rods[i];
    res.segment(g.start[i], g.d[i].size()) = static_residual<kT>(b, g.d[i], f, c, ResidualAt{&g.seg[i], lam, colliders, r});
    if (!rod_scale) continue;
    const RodInfo& rod = b.rods[std::size_t(r)];
    for (int k = rod.offset; k < rod.offset + rod.elements + 2; ++k) {
      (*rod_scale)[i][0] = std::max((*rod_scale)[i][0], std::sqrt(f[0][k] * f[0][k] + f[1][k] * f[1][k] + f[2][k] * f[2][k]));
      (*rod_scale)[i][1] = std::max((*rod_scale)[i][1], std::sqrt(c[0][k] * c[0][k] + c[1][k] * c[1][k] + c[2][k] * c[2][k]));
    }
  }
  if (touching) touching->clear();
  if (g.contact)
    each_push(
        b, g.rods,
        [&](int rod, int k, vec3<double> push) {
          if (const int row = g.row(b, rod, k); row >= 0)
            for (int x = 0; x < 3; ++x) res[row + x] += (&push.x)[x];
        },
        touching);
  return res;
}

// The touching pairs' part of the group's Jacobian, as triplets: central
// differences of each pair's push (pair_push) in its four nodes' positions,
// steps of 1e-3 δ (δ: the law's smooth width, 0.1 × the smaller radius),
// so that a stencil stays within the law's pieces at the overlaps statics
// reaches (docs/model.md "Rod–rod contact").
inline void contact_jacobian(RodBatch<double>& b, const GroupDofs& g, const std::vector<ElementPair>& pairs,
                             std::vector<Eigen::Triplet<double>>& out) {
  for (const ElementPair& p : pairs) {
    const std::array<int, 4> nodes = pair_nodes(p);
    int rows[4];
    for (int a = 0; a < 4; ++a) rows[a] = g.row(b, b.contact.elem_rod[a < 2 ? p.lo : p.hi], nodes[std::size_t(a)]);
    const double h = 1e-4 * std::min(b.contact.elem_radius[p.lo], b.contact.elem_radius[p.hi]);
    for (int a = 0; a < 4; ++a) {
      if (rows[a] < 0) continue;
      for (int x = 0; x < 3; ++x) {
        double& xa = b.state.node_x[x][nodes[std::size_t(a)]];
        const double keep = xa;
        vec3<double> fp[4], fm[4];
        xa = keep + h;
        pair_push(b, p, fp);
        xa = keep - h;
        pair_push(b, p, fm);
        xa = keep;
        for (int o = 0; o < 4; ++o) {
          if (rows[o] < 0) continue;
          for (int y = 0; y < 3; ++y) out.emplace_back(rows[o] + y, rows[a] + x, ((&fp[o].x)[y] - (&fm[o].x)[y]) / (2 * h));
        }
      }
    }
  }
}

// Rods `rods` to static equilibrium together (solve_static's method): Newton
// at each load fraction λ, increments adapted (halved where Newton fails,
// doubled up to 1/load_steps where it converges in a few iterations). A
// rod alone (no contacts with itself) solves its banded Jacobian
// (solve_banded); rods that touch, or a rod touching itself, solve the
// group's sparse Jacobian — each rod's band plus the touching pairs'
// blocks (contact_jacobian) — by sparse LU.
template <Terms kT>
RodOutcome solve_group(RodBatch<double>& b, const std::vector<int>& rods, const StaticOptions& opt,
                       std::array<Array<double>, 3>& f, std::array<Array<double>, 3>& c,
                       const std::vector<ColliderFrame<double>>* colliders) {
  RodOutcome out;
  const GroupDofs g = group_dofs(b, rods, static_rod_contact(b));
  const std::size_t nr = rods.size();
  std::vector<HoldPath> paths;
  for (int r : rods) {
    const std::vector<HoldPath> p = hold_paths(b, r, opt.hold_time);
    paths.insert(paths.end(), p.begin(), p.end());
  }
  const int m = g.size();
  // Friction at the colliders: anchors where the rods touch them now (their
  // first contact points; kept ones stay where their solve left them)
  const bool friction = colliders && static_friction(*colliders);
  auto anchor = [&] {
    if (!friction) return;
    out.stick = out.slip = 0;
    for (int r : rods) {
      const AnchorCount n = update_anchors(b, r, *colliders);
      out.stick += n.stick, out.slip += n.slip;
    }
  };
  if (m == 0) {  // every unknown held: only the holds move (and their anchors follow)
    place_holds(b, paths, 1);
    anchor();
    return out;
  }
  anchor();
  // Warm: the rods are already in equilibrium under their full loads (a
  // solve before this one; their holds may have moved since): the loads
  // stay full and only the holds walk, the whole way in the first
  // increment. Told by the residual at full load, with the holds where
  // they are: for each rod, its forces below 1e-6 of the largest force on
  // a node of the rod (held ones included: they carry the reactions) or of
  // an external one, and its couples likewise against the couples on the
  // rod's elements (or, if larger, that force times an element's length).
  bool warm = true;
  {
    std::vector<std::array<double, 2>> scale;
    const Eigen::VectorXd r1 = group_residual<kT>(b, g, f, c, 1.0, colliders, nullptr, &scale);
    const Eigen::VectorXd ext = r1 - group_residual<kT>(b, g, f, c, 0.0, colliders);
    for (std::size_t i = 0; i < nr; ++i) {
      double left[2] = {0, 0};
      const int nodes = int(g.d[i].node_slots.size());
      for (int j = 0; j < g.d[i].size() / 3; ++j) {
        const int at = g.start[i] + 3 * j, kind = j < nodes ? 0 : 1;
        scale[i][std::size_t(kind)] = std::max(scale[i][std::size_t(kind)], ext.segment(at, 3).norm());
        left[kind] = std::max(left[kind], r1.segment(at, 3).norm());
      }
      // (couples against at least the forces' over an element: a straight
      // rod carries none, and its couples' round-off would decide)
      const RodInfo& rod = b.rods[std::size_t(rods[i])];
      scale[i][1] = std::max(scale[i][1], scale[i][0] * g.length[i] / std::max(rod.elements, 1));
      warm = warm && left[0] <= 1e-6 * scale[i][0] && left[1] <= 1e-6 * scale[i][1];
    }
  }
  out.warm = warm;
  // The load path: the loads and the driven holds reach their full values
  // together (a warm group's loads stay full: only its holds walk). With
  // friction at the colliders the path has two legs, the loads first with
  // the holds where they are, then the holds walked under the full loads:
  // friction is path-dependent, and a cable dragged by its connector lies
  // under its whole weight while it is dragged (walked together, the
  // holds would move the rods while their friction is a fraction of it).
  bool full = warm, walking = true;
  auto loads = [&](double lam) { return full ? 1.0 : lam; };
  auto residual = [&](double lam, std::vector<ElementPair>* touching = nullptr) {
    return group_residual<kT>(b, g, f, c, loads(lam), colliders, touching);
  };
  std::vector<BandedJacobian> J(nr);
  for (std::size_t i = 0; i < nr; ++i) J[i].plan(g.d[i], b.rods[std::size_t(rods[i])].offset);  // (cells count from the rod's first slot)
  // the coupled system (rods that touch): its matrix and factorization
  Eigen::SparseMatrix<double> A;
  Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
  bool coupled = false;
  std::vector<ElementPair> touching;
  // J at load fraction lam, with the pairs touching there: each rod's
  // band, and, where rods touch, the sparse matrix and its LU
  auto jacobian = [&](double lam) {
    for (std::size_t i = 0; i < nr; ++i) {
      const ResidualAt at{&g.seg[i], loads(lam), colliders, rods[i]};
      banded_jacobian<kT>(b, g.d[i], f, c, g.length[i], 1e-6, J[i], at);
      regularize_spin(J[i], 3 * int(g.d[i].node_slots.size()));
    }
    coupled = !touching.empty();  // (rods that do not touch: each its own band)
    if (!coupled) return true;
    std::vector<Eigen::Triplet<double>> t;
    constexpr int w = BandedJacobian::w;
    for (std::size_t i = 0; i < nr; ++i) {
      const int rows = int(J[i].B.rows());
      for (int ii = 0; ii < rows; ++ii)
        for (int jj = std::max(0, ii - w); jj <= std::min(rows - 1, ii + w); ++jj)
          if (const double v = J[i].B(ii, jj - ii + w); v != 0)
            t.emplace_back(g.start[i] + J[i].order[std::size_t(ii)], g.start[i] + J[i].order[std::size_t(jj)], v);
    }
    contact_jacobian(b, g, touching, t);
    A.resize(m, m);
    A.setFromTriplets(t.begin(), t.end());
    lu.compute(A);
    return lu.info() == Eigen::Success;
  };
  auto dense = [&]() -> Eigen::MatrixXd {
    if (coupled) return Eigen::MatrixXd(A);
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(m, m);
    for (std::size_t i = 0; i < nr; ++i) D.block(g.start[i], g.start[i], g.d[i].size(), g.d[i].size()) = J[i].dense();
    return D;
  };
  // the rods' state at the last load fraction reached (their slots o … o + n + 1)
  std::vector<double> saved;
  auto keep = [&](bool save) {
    std::size_t i = 0;
    auto move = [&](double& x) {
      if (save) {
        if (i == saved.size()) saved.push_back(0);
        saved[i++] = x;
      } else {
        x = saved[i++];
      }
    };
    for (int r : rods)
      for (int k = b.rods[std::size_t(r)].offset; k < b.rods[std::size_t(r)].offset + b.rods[std::size_t(r)].elements + 2; ++k) {
        for (int a = 0; a < 3; ++a) move(b.state.node_x[a][k]);
        for (int a = 0; a < 9; ++a) move(b.state.elem_Q[a][k]);
      }
  };
  // the largest update of a rod: |Δx|/L over its free nodes, |Δφ| over its elements
  auto update_size = [&](const Eigen::VectorXd& dq) {
    double upd = 0;
    for (std::size_t i = 0; i < nr; ++i) {
      const int nn = 3 * int(g.d[i].node_slots.size()), mi = g.d[i].size();
      if (nn > 0) upd = std::max(upd, dq.segment(g.start[i], nn).cwiseAbs().maxCoeff() / g.length[i]);
      if (mi > nn) upd = std::max(upd, dq.segment(g.start[i] + nn, mi - nn).cwiseAbs().maxCoeff());
    }
    return upd;
  };
  // Whether residual r is round-off: each rod's node forces and element
  // couples within 16 times its floor (residual_floor; a node's force sums
  // two elements' forces of three terms each, each known to about the
  // floor: measured 2–2.6 times it where Newton stalls). There, and where
  // the updates have stopped shrinking, the state is an equilibrium as far
  // as double precision can tell: at a neutral equilibrium (a cable over a
  // frictionless capsule with equal loads, free to slide around it) J is
  // singular along the motions that cost nothing, and the update along
  // them is round-off divided by round-off, which never falls below the
  // tolerance.
  auto at_floor = [&](const Eigen::VectorXd& r) {
    for (std::size_t i = 0; i < nr; ++i) {
      RodOutcome o;
      residual_size(g.d[i], r.segment(g.start[i], g.d[i].size()), 0, o);
      const std::array<double, 2> floor = residual_floor(b, rods[i]);
      if (!(o.residual_force <= 16 * floor[0] && o.residual_couple <= 16 * floor[1])) return false;
    }
    return true;
  };
  // Newton at load fraction lam: true when the update falls below the
  // tolerance, or stalls where the residual is round-off (at_floor).
  // A warm group (a re-solve after its holds moved: near its solution, where
  // J hardly changes) keeps its Jacobian from one iteration to the next
  // while the updates shrink at least fourfold (chord steps: a residual
  // costs a 60th of the finite-difference J); it takes a fresh one at the
  // first iteration, when the updates stall, when the pairs in touch
  // change (keeping the rods' bands then made the re-solves of a harness
  // slower), and before a failed solve is diagnosed. Other groups take a
  // fresh one every iteration (Newton).
  auto newton = [&](double lam, int& iterations) {
    iterations = 0;
    double last = 0, before = 0;  // this increment's last two updates
    std::vector<ElementPair> now;
    Eigen::VectorXd r0 = residual(lam, &now);
    for (int it = 0; it < opt.max_newton_iterations; ++it) {
      if (!r0.allFinite()) return false;
      bool fresh = !warm || it == 0 || (it >= 2 && !(last < 0.25 * before)) || now != touching;
      bool factored = true;
      if (fresh) {
        touching = now;
        factored = jacobian(lam);
      }
      // Equilibrium: r(q) = 0 (r = generalized force). Newton: J Δq = −r,
      // by banded LU with partial pivoting (solve_banded; sparse LU for a
      // coupled group); where J is singular or nearly so the LU's solution
      // does not solve the system, and a rank-revealing pivoted QR takes
      // over. A singular J whose range misses −r (the loads push along a
      // motion that costs no energy: a free rod in gravity, a pendulum off
      // its vertical) has no Newton step: the rods are a mechanism under
      // their loads.
      Eigen::VectorXd dq;
      auto solved = [&] {
        if (!coupled) {
          dq.resize(m);
          for (std::size_t i = 0; i < nr; ++i) {
            const Eigen::VectorXd ri = r0.segment(g.start[i], g.d[i].size());
            Eigen::VectorXd x;
            if (!solve_banded(J[i], -ri, x) || !((J[i].times(x) + ri).norm() <= 1e-8 * (ri.norm() + J[i].B.norm() * x.norm())))
              return false;
            dq.segment(g.start[i], g.d[i].size()) = x;
          }
          return true;
        }
        if (!factored) return false;
        dq = lu.solve(-r0);
        return lu.info() == Eigen::Success && dq.allFinite() &&
               (A * dq + r0).norm() <= 1e-8 * (r0.norm() + A.norm() * dq.norm());
      };
      bool ok = solved();
      if (!ok && !fresh) {  // a kept Jacobian: take a fresh one before judging
        touching = now;
        factored = jacobian(lam);
        fresh = true;
        ok = solved();
      }
      if (!ok) {
        if (coupled && m > kDenseDiagnosis) return false;  // (too large for a dense QR)
        const Eigen::MatrixXd D = dense();
        if (singular_against(D, r0, out.zero_modes)) {
          out.mechanism = true;
          return false;
        }
        dq = D.colPivHouseholderQr().solve(-r0);
      }
      if (!dq.allFinite()) return false;
      const double upd = update_size(dq);
      // converged: the residual is round-off and a fresh Newton update no
      // longer shrinks (it would, quadratically, if it were not noise) —
      // the state is left as it is (docs/model.md "Static equilibrium")
      if (fresh && iterations > 0 && upd > 0.5 * last && at_floor(r0)) return true;
      // Trust region: a full Newton step far from the solution can jump to
      // another branch of the (non-convex) equilibrium problem; cap it.
      if (upd > opt.max_update) dq *= opt.max_update / upd;
      if (g.contact) {  // and no rod through another (pass_through_limit)
        double dmax = 0;
        for (std::size_t i = 0; i < nr; ++i)
          for (std::size_t j = 0; j < g.d[i].node_slots.size(); ++j) dmax = std::max(dmax, dq.segment(g.start[i] + 3 * int(j), 3).norm());
        const double alpha = pass_through_limit(
            b, rods,
            [&](int rod, int k) {
              const int row = g.row(b, rod, k);
              return row < 0 ? vec3<double>{0, 0, 0} : vec3<double>{dq[row], dq[row + 1], dq[row + 2]};
            },
            dmax);
        if (alpha < 1e-3) return false;  // (stuck against a pair: a smaller increment)
        dq *= alpha;
      }
      for (std::size_t i = 0; i < nr; ++i) apply_dofs(b, g.d[i], dq.segment(g.start[i], g.d[i].size()));
      Eigen::VectorXd r1 = residual(lam, &now);
      // Touching rods: the step is cut back where it overshoots the
      // equilibrium along its direction. r is the negative gradient of the
      // potential energy Π (elastic, the loads', the pushes'), so
      // dΠ/dα = −r(q + α dq)·dq: negative at α = 0 (Newton's direction
      // descends), and a step past the minimum along dq ends where it is
      // positive. A push switching on within the step (its penalty far
      // stiffer than the rods' bending) makes Newton's step overshoot; the
      // step is then moved to where dΠ/dα vanishes, by regula falsi on the
      // bracket (at most three residuals), accepted once |dΠ/dα| is below
      // half its value at the start.
      if (g.contact) {
        const double d0 = r0.dot(dq);
        double lo = 0, hi = 1, dlo = d0, dhi = r1.dot(dq), at = 1;
        for (int k = 0; k < 3 && d0 > 0 && dhi < -0.5 * d0; ++k) {
          const double next = lo + (hi - lo) * dlo / (dlo - dhi);
          for (std::size_t i = 0; i < nr; ++i) apply_dofs(b, g.d[i], (next - at) * dq.segment(g.start[i], g.d[i].size()));
          at = next;
          r1 = residual(lam, &now);
          const double d = r1.dot(dq);
          if (d >= 0) {
            if (d <= 0.5 * d0) break;
            lo = at, dlo = d;
          } else {
            hi = at, dhi = d;
          }
        }
      }
      r0 = std::move(r1);
      ++iterations;
      // converged: below the tolerance, or at the round-off floor (a small
      // update that no longer shrinks with a fresh Jacobian: Newton's would,
      // quadratically)
      const bool floor = upd < 1e-8 && iterations > 1 && fresh && upd > 0.5 * out.last_update;
      before = last;
      last = out.last_update = upd;
      if (upd < opt.tolerance || floor) return true;
    }
    return false;
  };
  // the residual's worst rod (by its largest node force), its node and sizes
  auto judge = [&](double lam) {
    const Eigen::VectorXd r = residual(lam);
    RodOutcome worst;
    for (std::size_t i = 0; i < nr; ++i) {
      RodOutcome o;
      residual_size(g.d[i], r.segment(g.start[i], g.d[i].size()), b.rods[std::size_t(rods[i])].offset + 1, o);
      if (i == 0 || o.residual_force > worst.residual_force) worst.residual_force = o.residual_force, worst.worst_node = o.worst_node, out.rod = rods[i];
      worst.residual_couple = std::max(worst.residual_couple, o.residual_couple);
    }
    out.residual_force = worst.residual_force, out.residual_couple = worst.residual_couple, out.worst_node = worst.worst_node;
  };
  const double largest = warm ? 1.0 : 1.0 / std::max(1, opt.load_steps);
  auto holds = [&](double lam) { place_holds(b, paths, walking ? lam : 0.0); };
  // one leg of the load path, lam from 0 to 1; false (out says why) where
  // it fails
  auto leg = [&] {
    double lam = 0, inc = largest;
    int failures = 0;
    bool retrying = false;  // a first "mechanism" is being tried again at a small increment
    keep(true);
    while (lam < 1) {
      const double next = 1 - lam <= inc * (1 + 1e-9) ? 1.0 : lam + inc;
      holds(next);
      int its = 0;
      const bool ok = !(g.contact && overlap_too_deep(b, rods)) && newton(next, its);
      out.iterations += its;
      if (ok) {
        lam = next;
        ++out.increments;
        anchor();  // (the force is unchanged: the equilibrium holds)
        keep(true);
        retrying = false;
        if (its <= 4) inc = std::min(2 * inc, largest);
        continue;
      }
      keep(false);  // back to lam
      // Are the rods a mechanism under their loads here? (The banded LU may
      // "solve" a singular J through a pivot of round-off size; the dense
      // rank-revealing QR says, at the first failure and at the last.)
      if (!out.mechanism && (++failures == 1 || inc * 0.5 < opt.min_load_step) && m <= kDenseDiagnosis) {
        const Eigen::VectorXd r0 = residual(next, &touching);
        jacobian(next);
        out.mechanism = singular_against(dense(), r0, out.zero_modes);
        keep(false);  // (the Jacobian's ±h steps leave round-off)
      }
      holds(lam);
      inc *= 0.5;
      // A mechanism has no equilibrium at any load; a rod whose soft modes
      // the diagnosis cannot tell from zero ones (a stiff hair: its bending
      // 1e-9 of its shear, the pivots' threshold 1e-8) has one, which a
      // smaller increment reaches. So the first diagnosis of a mechanism is
      // tried once more, at a sixteenth of the increment: a failure there
      // confirms it.
      if (retrying) {
        out.mechanism = true;
      } else if (out.mechanism) {
        retrying = true;
        out.mechanism = false;
        inc = std::max(opt.min_load_step, inc / 16);
        continue;
      }
      if (out.mechanism || inc < opt.min_load_step) {
        out.ok = false;
        out.lambda = lam;
        holds(std::min(1.0, lam + 2 * inc));
        judge(std::min(1.0, lam + 2 * inc));
        holds(lam);
        return false;
      }
    }
    return true;
  };
  const bool moves = std::any_of(paths.begin(), paths.end(), [](const HoldPath& h) {
    return norm(h.x1 - h.x0) > 0 || norm(h.psi[0]) > 0 || norm(h.psi[1]) > 0;
  });
  if (friction && !warm && moves) {
    walking = false;  // the loads, the holds where they are
    if (!leg()) return out;
    full = walking = true;  // the holds, under the full loads
    out.walk = true;
  }
  if (!leg()) return out;
  judge(1.0);
  return out;
}

// The batch's colliders placed at time t (NaN: the batch's time), for the
// static residual (none when the batch has no contact).
inline std::vector<ColliderFrame<double>> static_colliders(const RodBatch<double>& b, double t) {
  std::vector<ColliderFrame<double>> frames;
  if (!b.contact.on || b.contact.spec.colliders.empty()) return frames;
  frames.resize(b.contact.spec.colliders.size());
  place_colliders(b.contact, std::isfinite(t) ? t : b.state.time, 1.0, frames.data());
  return frames;
}

// Rod r's positions and frames back to those of `start` (its slots).
inline void restore_rod(RodBatch<double>& b, const State<double>& start, int r) {
  const RodInfo& rod = b.rods[std::size_t(r)];
  for (int k = rod.offset; k < rod.offset + rod.elements + 2; ++k) {
    for (int a = 0; a < 3; ++a) b.state.node_x[a][k] = start.node_x[a][k];
    for (int a = 0; a < 9; ++a) b.state.elem_Q[a][k] = start.elem_Q[a][k];
  }
}

// Groups of rods (solve_group) in waves whose kernel blocks are disjoint
// (each group's span: its rods' rod_blocks, first to last): the groups of
// a wave can be solved at the same time. Returns group indices.
inline std::vector<std::vector<int>> static_waves(const RodBatch<double>& b, const std::vector<std::vector<int>>& groups) {
  std::vector<Segment> span(groups.size());
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    span[gi] = rod_blocks(b.rods[std::size_t(groups[gi].front())]);
    for (int r : groups[gi]) {
      const Segment s = rod_blocks(b.rods[std::size_t(r)]);
      span[gi].begin = std::min(span[gi].begin, s.begin), span[gi].end = std::max(span[gi].end, s.end);
    }
  }
  std::vector<int> order(groups.size());
  for (std::size_t gi = 0; gi < groups.size(); ++gi) order[gi] = int(gi);
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return span[std::size_t(x)].begin < span[std::size_t(y)].begin; });
  std::vector<std::vector<int>> waves;
  std::vector<int> last_end;  // per wave, the end of its last group's span
  for (int gi : order) {
    std::size_t w = 0;
    while (w < waves.size() && last_end[w] > span[std::size_t(gi)].begin) ++w;
    if (w == waves.size()) waves.emplace_back(), last_end.push_back(0);
    waves[w].push_back(gi);
    last_end[w] = span[std::size_t(gi)].end;
  }
  return waves;
}

// solve(g) for each group g (an index of `groups`) that take(g) picks, wave
// by wave (static_waves): the groups of a wave at the same time on
// OpenMP's threads (one at a time with threads == 1).
template <class Take, class Solve>
void each_group_in_waves(const RodBatch<double>& b, const std::vector<std::vector<int>>& groups, int threads,
                         Take&& take, Solve&& solve) {
  for (const std::vector<int>& wave : static_waves(b, groups)) {
    std::vector<int> todo;
    for (int gi : wave)
      if (take(gi)) todo.push_back(gi);
    auto one = [&](std::size_t i) { solve(todo[i]); };
    if (threads == 1 || todo.size() < 2)
      for (std::size_t i = 0; i < todo.size(); ++i) one(i);
    else
      parallel_tasks(todo.size(), one);
  }
}

// Each rod its own group.
inline std::vector<std::vector<int>> single_rods(const RodBatch<double>& b) {
  std::vector<std::vector<int>> groups(std::size_t(b.rod_count()));
  for (int r = 0; r < b.rod_count(); ++r) groups[std::size_t(r)] = {r};
  return groups;
}

// solve(r) for each rod that take(r) picks, as each_group_in_waves with
// each rod its own group.
template <class Take, class Solve>
void each_rod_in_waves(const RodBatch<double>& b, int threads, Take&& take, Solve&& solve) {
  each_group_in_waves(b, single_rods(b), threads, take, solve);
}

}  // namespace detail

// solve_static (include/manyrods/statics.h).
template <Terms kT>
StaticResult solve_static(RodBatch<double>& b, const StaticOptions& opt) {
  constexpr Terms kStatic = detail::kStaticTerms<kT>;
  std::array<Array<double>, 3> f, c;
  detail::at_rest(b, f, c);
  const std::vector<ColliderFrame<double>> colliders = detail::static_colliders(b, opt.hold_time);
  const bool friction = detail::static_friction(colliders);
  if (friction) detail::drop_stale_anchors(b, int(colliders.size()));
  // With rod–rod contact, rods whose boxes overlap are solved together
  // (contact_groups); where the boxes of rods of two groups, each the
  // union of where the rod started and where the solve left it, overlap,
  // the groups join and are solved again from where they started, until
  // no two groups' boxes overlap: a rod cannot have passed through a rod
  // of another group.
  const bool joining = detail::static_rod_contact(b) && b.contact.spec.rod_rod;  // (self contact alone: each rod alone)
  const std::vector<std::array<double, 6>> boxes = joining ? detail::rod_boxes(b) : std::vector<std::array<double, 6>>{};
  const State<double> start = joining ? b.state : State<double>{};
  const std::vector<std::vector<StaticAnchor>> anchors = joining && friction ? b.contact.static_anchors
                                                                            : std::vector<std::vector<StaticAnchor>>{};
  std::vector<std::vector<int>> groups = joining ? detail::contact_groups(b, boxes) : detail::single_rods(b);
  std::vector<detail::RodOutcome> outcome(groups.size());
  std::vector<char> todo(groups.size(), 1);
  StaticResult res;
  for (;;) {
    detail::each_group_in_waves(
        b, groups, opt.threads, [&](int gi) { return todo[std::size_t(gi)] != 0; },
        [&](int gi) {
          outcome[std::size_t(gi)] = detail::solve_group<kStatic>(b, groups[std::size_t(gi)], opt, f, c, &colliders);
        });
    for (std::size_t gi = 0; gi < groups.size(); ++gi) {
      if (!todo[gi]) continue;
      const detail::RodOutcome& o = outcome[gi];
      res.iterations += o.iterations;
      res.load_increments += o.increments;
    }
    if (!joining) break;
    bool failed = false;
    for (const detail::RodOutcome& o : outcome) failed = failed || !o.ok;
    if (failed) break;
    std::vector<std::vector<int>> joined = detail::contact_groups(b, detail::box_union(boxes, detail::rod_boxes(b)), groups);
    if (joined.size() == groups.size()) break;
    // the groups that are not one of the old ones are solved again
    std::vector<detail::RodOutcome> kept(joined.size());
    std::vector<char> again(joined.size(), 1);
    for (std::size_t j = 0; j < joined.size(); ++j)
      for (std::size_t gi = 0; gi < groups.size(); ++gi)
        if (groups[gi] == joined[j]) again[j] = 0, kept[j] = outcome[gi];
    for (std::size_t j = 0; j < joined.size(); ++j)  // (solved again from where they started)
      if (again[j])
        for (int r : joined[j]) {
          detail::restore_rod(b, start, r);
          if (friction) b.contact.static_anchors[std::size_t(r)] = anchors[std::size_t(r)];
        }
    groups = std::move(joined);
    outcome = std::move(kept);
    todo = std::move(again);
  }
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    const detail::RodOutcome& o = outcome[gi];
    if (o.warm) res.warm_rods += int(groups[gi].size());
    res.sticking += o.stick;
    res.slipping += o.slip;
    res.last_update = std::max(res.last_update, o.last_update);
    if (res.converged) {
      res.residual_force = std::max(res.residual_force, o.residual_force);
      res.residual_couple = std::max(res.residual_couple, o.residual_couple);
    }
    if (o.ok || !res.converged) continue;
    res.converged = false;
    res.failed_rod = o.rod;
    res.failed_node = o.worst_node;
    res.load_reached = o.lambda;
    res.holds_walk = o.walk;
    res.residual_force = o.residual_force;
    res.residual_couple = o.residual_couple;
    res.zero_modes = o.zero_modes;
    res.mechanism = o.mechanism;
  }
  return res;
}

// The reactions (include/manyrods/statics.h): the generalized forces of a
// copy at rest; a held node's force and its held frames' couples (material
// components, turned to the lab frame by Qᵀ), negated.
template <Terms kT>
std::vector<HoldReaction> hold_reactions(const RodBatch<double>& batch) {
  RodBatch<double> b = batch;
  std::array<Array<double>, 3> f, c;
  detail::at_rest(b, f, c);
  const std::vector<ColliderFrame<double>> colliders = detail::static_colliders(b, b.state.time);
  detail::ResidualAt at;
  at.colliders = &colliders;
  at.current_anchors = true;  // (friction held by the last static solve, in the state it left)
  (void)detail::static_residual<detail::kStaticTerms<kT>>(b, detail::RodDofs{}, f, c, at);  // (f, c on every slot)
  if (detail::static_rod_contact(b)) {  // the rods' pushes on each other and themselves
    std::vector<int> all(std::size_t(b.rod_count()));
    std::iota(all.begin(), all.end(), 0);
    detail::each_push(b, all, [&](int, int k, vec3<double> push) {
      for (int a = 0; a < 3; ++a) f[a][k] += (&push.x)[a];
    });
  }
  std::vector<HoldReaction> out;
  for (int r = 0; r < b.rod_count(); ++r) {
    const RodInfo& rod = b.rods[std::size_t(r)];
    const int n = rod.elements, o = rod.offset;
    int taken = -1;  // the last element slot counted (an element held by two clamps counts once)
    for (int j = 0; j <= n; ++j) {
      const int k = o + 1 + j;
      if (b.model.node_inv_mass[k] != 0) continue;
      HoldReaction h;
      h.rod = r;
      h.node = j;
      for (int a = 0; a < 3; ++a) h.force[a] = -f[a][k];
      // the frames this hold keeps: a clamped end's clamp frame (a ghost
      // element), a clamped interior node's elements j − 1 and j
      int frames[2] = {-1, -1};
      if (j == 0 && rod.clamped_root) {
        frames[0] = o;
      } else if (j == n && rod.clamped_tip) {
        frames[0] = o + n + 1;
      } else if (j > 0 && j < n && b.model.elem_inv_inertia[0][o + j] == 0 && b.model.elem_inv_inertia[0][k] == 0) {
        frames[0] = o + j;
        frames[1] = k;
      }
      h.clamped = frames[0] >= 0;
      for (const int e : frames) {
        if (e < 0 || e <= taken) continue;
        taken = e;
        for (int a = 0; a < 3; ++a)  // Qᵀ c: rows of Q are the directors
          for (int d = 0; d < 3; ++d) h.moment[a] -= b.state.elem_Q[3 * d + a][e] * c[d][e];
      }
      out.push_back(h);
    }
  }
  return out;
}

}  // namespace manyrods
