// tests/reference.h — a plain per-rod reference implementation of the
// discrete Cosserat rod with Kelvin–Voigt damping, in double with Eigen.
//
// It is written from the equations documented at the top of kernels/*.h and
// shares no code with them (only the Terms flag struct): rotation logs and
// exponentials come from Eigen::AngleAxisd, the inverse right Jacobian is
// written out below, and every loop runs over one rod's own arrays (no slots,
// no ghosts). Tests compare the batch kernels against it.
//
// Conventions (the same as the library's, restated):
//   * Q has the directors as ROWS: a_material = Q a_lab.
//   * ω is in material components; Q̇ = −[ω]× Q, so a drift of length h is
//     Q ← exp(−[h ω]×) Q.
//   * element e joins nodes e and e+1; interior Voronoi point j joins elements
//     j and j+1; a clamped rod has one more Voronoi point (the "root") that
//     joins the clamp frame (element "−1", never moving) to element 0.
//
// Equations:
//   element:  σ = Q (x_{e+1} − x_e)/l̂ − V0,
//             σ̇ = (Q (v_{e+1} − v_e) − ω × Q(x_{e+1} − x_e))/l̂,
//             n = C_F σ + C_F diag(τ_F) σ̇
//   joint:    R = Q_b Q_aᵀ = exp([ψ]×), κ = −ψ/D̂ (total),
//             κ̇ = J_r(ψ)⁻¹ (Rᵀ ω_b − ω_a)/D̂,
//             m = C_M (κ − U0) + C_M diag(τ_M) κ̇
//   node force (lab):      F_k = Q_kᵀ n_k − Q_{k−1}ᵀ n_{k−1} + m_k g + f_k
//   joint couples (mat.):  on element a: +J_r(ψ)⁻ᵀ m,  on element b: −J_r(ψ)⁻¹ m
//     — the work-conjugate of the discrete curvature (kernels/internal_forces.h):
//     with δQ = −[δθ]×Q one has δψ = J_r⁻¹ δθ_a − J_r⁻¹ Rᵀ δθ_b, and
//     −∂E/∂θ_b = −R J_r⁻ᵀ m = −J_r⁻¹ m (J_rᵀ = R J_r).
//   element couple (mat.): C_e = (couples of the joints on both sides of e)
//                                + Q(x_{e+1} − x_e) × n_e + (J ω) × ω + Q c_e
//   energies: kinetic Σ½m|v|² + Σ½ωᵀJω; elastic Σ½l̂ σᵀC_Fσ + Σ½D̂(κ−U0)ᵀC_M(κ−U0);
//             potential −Σ(m g + f)·x; 2·D_v = Σ l̂ σ̇ᵀV_Fσ̇ + Σ D̂ κ̇ᵀV_Mκ̇
//   step: Position Verlet — drift ½h, forces (rates from the velocities at the
//         start of the kick), kick h, drift ½h; a clamped node 0 and the clamp
//         frame never move. The kick is v += h F/m and, for ω, the implicit
//         midpoint rule for the rigid-body term (kernels/integrate.h):
//           J (ω⁺ − ω)/h = C + Q c + (J ω̄) × ω̄,  ω̄ = (ω + ω⁺)/2,
//         solved by fixed-point sweeps ω⁺ ← ω + h J⁻¹(C + Q c + (Jω̄)×ω̄)
//         from ω⁺ = ω (the library does 4 such evaluations; the reference
//         can also iterate to convergence).
//
// Round-off scales. Next to each output the reference returns a "scale": the
// value the same formula takes when every operand is replaced by its magnitude
// (sums of absolute values, |a × b| → |a||b|, the log map by its condition).
// A floating-point evaluation of a formula with at most k roundings along any
// path has error ≤ k·u·scale (u the unit round-off; Higham, "Accuracy and
// Stability of Numerical Algorithms", §3.1, running error bound). Tests use
// these scales to derive their tolerances instead of guessing a relative one:
// a node force is a DIFFERENCE of neighbouring element forces and may be far
// smaller than either, so "relative to the result" would be meaningless.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "manyrods/terms.h"

namespace manyrods::ref {

using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;

// One rod, everything the discrete equations need. [n] = per element,
// [n+1] = per node, [n−1] = per interior Voronoi point.
struct Rod {
  // nodes
  std::vector<V3> x, v;      // [n+1] m, m/s
  std::vector<double> mass;  // [n+1] kg (node 0 of a clamped rod: any, it never moves)
  std::vector<V3> f_ext;     // [n+1] N, lab
  // elements
  std::vector<M3> Q;       // [n] rows = directors
  std::vector<V3> w;       // [n] rad/s, material
  std::vector<double> l0;  // [n] rest length l̂
  std::vector<V3> V0;      // [n] rest strain
  std::vector<V3> CF;      // [n] C_F diagonal, N
  std::vector<V3> tauF;    // [n] retardation times of V_F = C_F diag(tauF)
  std::vector<V3> J;       // [n] rotary inertia diagonal, kg·m²
  std::vector<V3> c_ext;   // [n] N·m, lab
  // interior Voronoi points
  std::vector<double> D;  // [n−1] D̂
  std::vector<V3> U0;     // [n−1] rest curvature
  std::vector<V3> CM;     // [n−1] C_M diagonal, N·m²
  std::vector<V3> tauM;   // [n−1] retardation times of V_M = C_M diag(tauM)
  // clamped root
  bool clamped = false;
  M3 Q_clamp = M3::Identity();  // clamp frame (never moves, ω = 0)
  double D_root = 0;            // l̂_0/2
  V3 U0_root = V3::Zero();
  V3 CM_root = V3::Zero();
  V3 tauM_root = V3::Zero();
  // gravity, m/s²
  V3 g = V3::Zero();

  int elements() const { return static_cast<int>(Q.size()); }
};

// The rod with every switched-off term's stiffness, viscosity or load set to
// zero (shear: C_F 1–2; stretch: C_F 3; bend: C_M 1–2; twist: C_M 3;
// kelvin_voigt: all τ; gravity: g; loads: f_ext, c_ext).
Rod with_terms(const Rod& rod, Terms terms);

// exp([w]×) and log of a rotation, via Eigen::AngleAxisd.
M3 rotation_exp(const V3& w);
V3 rotation_log(const M3& r);
// J_r(ψ)⁻¹ = I + ½[ψ]× + γ(θ)[ψ]×², γ = 1/θ² − (1 + cos θ)/(2 θ sin θ).
M3 inverse_right_jacobian(const V3& psi);
M3 skew(const V3& a);

struct Evaluation {
  // elements [n], material components
  std::vector<V3> sigma, sigma_rate, n;
  // interior Voronoi points [n−1]: total curvature, its rate, moment, D̂ κ × m
  std::vector<V3> kappa, kappa_rate, m, kxm;
  // root Voronoi point (clamped only)
  V3 root_kappa = V3::Zero(), root_kappa_rate = V3::Zero(), root_m = V3::Zero(), root_kxm = V3::Zero();
  // couples of each joint on its root-side element (a) and tip-side element
  // (b): +J_r⁻ᵀ m and −J_r⁻¹ m; root joint: a is the clamp
  std::vector<V3> on_a, on_b;  // [n−1]
  V3 root_on_a = V3::Zero(), root_on_b = V3::Zero();
  std::vector<V3> force;            // [n+1] lab, internal + external
  std::vector<V3> couple;           // [n] material, internal + external, with (Jω)×ω
  std::vector<V3> inertial_couple;  // [n] (Jω)×ω alone
  std::vector<V3> applied_couple;   // [n] internal + external, without (Jω)×ω
  // round-off scales (see the top of this file)
  std::vector<double> sigma_scale, sigma_rate_scale, n_scale;  // [n]
  std::vector<double> kappa_scale, kappa_rate_scale, m_scale;  // [n−1]
  std::vector<double> joint_couple_scale;                      // [n−1] on_a, on_b
  double root_kappa_scale = 0, root_kappa_rate_scale = 0, root_m_scale = 0, root_joint_couple_scale = 0;
  std::vector<double> force_scale;   // [n+1]
  std::vector<double> couple_scale;  // [n]
};

// Evaluates the rod with the switched-off terms zeroed (with_terms).
// positions_rounded: the operands x, v, Q themselves carry a relative error
// of order u (they were rounded to a lower precision, or were computed by a
// drift whose rounding differs); then e = x_{e+1} − x_e is no longer exact
// and the scales include |x_e| + |x_{e+1}| instead of |e| alone.
Evaluation evaluate(const Rod& rod, Terms terms = kAllTerms, bool positions_rounded = false);

struct Energies {
  double kinetic = 0, elastic = 0, potential = 0, dissipation = 0;  // dissipation = 2·D_v
  double kinetic_scale = 0, elastic_scale = 0, potential_scale = 0, dissipation_scale = 0;
};
Energies energies(const Rod& rod, Terms terms = kAllTerms);

// One Position Verlet step of length h. euler_evaluations: how many times the
// fixed-point map of the implicit midpoint rule is applied (the library: 4,
// i.e. the explicit guess and three sweeps); < 0: until it has converged.
Rod step(const Rod& rod, double h, Terms terms = kAllTerms, int euler_evaluations = 4);

}  // namespace manyrods::ref
