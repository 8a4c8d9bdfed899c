// tests/linear.h — linearized dynamics of a batch about its current state:
// stiffness K = −∂(generalized force)/∂q by central differences and the
// diagonal mass M (node masses, element inertias), q = (free node positions,
// element rotation increments φ with Q ← exp(−[φ]×)Q). The eigenproblem
// K φ = ω² M φ gives the discrete model's natural frequencies, independent
// of any time stepping.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "host/core/advanced.h"

namespace manyrods::testing {

struct Linearization {
  Eigen::MatrixXd K;        // symmetrized
  Eigen::VectorXd M;        // diagonal
  std::vector<int> slot;    // slot of each dof
  std::vector<int> kind;    // 0 = node position, 1 = element rotation
  std::vector<int> axis;    // 0, 1, 2 (lab axis for nodes, material for rotations)
};

struct Modes {
  Eigen::VectorXd omega;    // ascending, rad/s
  Eigen::MatrixXd shapes;   // columns: M-orthonormal mode shapes in q
};

template <Terms kT = Terms{true, true, true, true, false, false, true}>
Linearization linearize(RodBatch<double>& b, int rod, double h_rel = 1e-6) {
  detail::RodDofs d;
  const int n = b.elements(rod);
  double length = 0;
  for (int e = 0; e < n; ++e) length += b.model.elem_rest_length[b.elem_index(rod, e)];
  Linearization lin;
  for (int j = 0; j <= n; ++j) {
    const int k = b.node_index(rod, j);
    if (b.model.node_inv_mass[k] == 0) continue;
    d.node_slots.push_back(k);
  }
  for (int e = 0; e < n; ++e) d.elem_slots.push_back(b.elem_index(rod, e));
  const int m = d.size(), nn = 3 * int(d.node_slots.size());
  lin.M.resize(m);
  for (std::size_t i = 0; i < d.node_slots.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      lin.M[3 * i + a] = b.model.node_mass[d.node_slots[i]];
      lin.slot.push_back(d.node_slots[i]);
      lin.kind.push_back(0);
      lin.axis.push_back(a);
    }
  for (std::size_t i = 0; i < d.elem_slots.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      lin.M[nn + 3 * i + a] = b.model.elem_inertia[a][d.elem_slots[i]];
      lin.slot.push_back(d.elem_slots[i]);
      lin.kind.push_back(1);
      lin.axis.push_back(a);
    }
  std::array<Array<double>, 3> f, c;
  for (int a = 0; a < 3; ++a) {
    f[a].resize(b.slots(), 0.0);
    c[a].resize(b.slots(), 0.0);
  }
  lin.K = -detail::residual_jacobian<kT>(b, d, f, c, length, h_rel);
  lin.K = 0.5 * (lin.K + lin.K.transpose()).eval();
  return lin;
}

inline Modes modes(const Linearization& lin) {
  const Eigen::VectorXd s = lin.M.cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd A = s.asDiagonal() * lin.K * s.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(A);
  Modes md;
  md.omega = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  md.shapes = s.asDiagonal() * es.eigenvectors();
  return md;
}

// Fraction of mode j's kinetic-energy norm (M-weighted) in dofs of the given
// kind and axis.
inline double mode_fraction(const Linearization& lin, const Modes& md, int j, int kind, int axis) {
  double part = 0, all = 0;
  for (int i = 0; i < lin.M.size(); ++i) {
    const double w = lin.M[i] * md.shapes(i, j) * md.shapes(i, j);
    all += w;
    if (lin.kind[i] == kind && lin.axis[i] == axis) part += w;
  }
  return part / all;
}

// The frequencies (ascending) of the modes dominated (> 50%) by kind/axis.
inline std::vector<double> modes_of(const Linearization& lin, const Modes& md, int kind, int axis) {
  std::vector<double> w;
  for (int j = 0; j < md.omega.size(); ++j)
    if (mode_fraction(lin, md, j, kind, axis) > 0.5) w.push_back(md.omega[j]);
  return w;
}

// Sets the state to amplitude·(mode j) about the current state, at rest.
inline void excite_mode(RodBatch<double>& b, int rod, const Linearization& lin, const Modes& md,
                        int j, double amplitude) {
  detail::RodDofs d;
  for (std::size_t i = 0; i < lin.slot.size(); i += 3)
    (lin.kind[i] == 0 ? d.node_slots : d.elem_slots).push_back(lin.slot[i]);
  (void)rod;
  detail::apply_dofs(b, d, amplitude * md.shapes.col(j));
}

}  // namespace manyrods::testing
