// kernels/internal_forces.h — internal nodal forces and element couples of the
// standard discrete Cosserat rod (Gazzola et al. 2018, R. Soc. open sci.
// 5:171628, eq. 2.12–2.13), with the seed's linear constitutive law
// (no rescaling of A and I with stretch; docs/model.md "Differences from the
// standard scheme"). n and m are the TOTAL resultants (elastic + viscous),
// seed eq. (12)–(13).
//
//   node k:     F_k = Δʰ(Qᵀn)   = (Qᵀn)_k − (Qᵀn)_{k−1}
//   element k:  C_k = Δʰ(m) + Aʰ(D̂ κ × m) + (Q e × n)
//             = m_{k+1} − m_k + ½(D̂κ×m)_k + ½(D̂κ×m)_{k+1} + (Q e)_k × n_k
//   and the rigid-body term (Jω) × ω of Euler's equations (kernels/integrate.h).
// (Voronoi k+1 joins elements k and k+1.) κ in κ × m is the TOTAL curvature
// (continuum term U × m).
//
// One refinement over Gazzola et al.: the moment that enters Δʰ is
//   m̃ = m + γ(θ) ψ × (ψ × m),  γ = 1/12 + θ²/720 + …  (ψ = −D̂κ, θ = |ψ|)
// which makes the couples EXACTLY the work-conjugate of the discrete
// curvature: a joint's couples on its elements a, b are +J_r(ψ)⁻ᵀ m and
// −J_r(ψ)⁻¹ m (J_r the right Jacobian of SO(3)), the power of which is
// −m·κ̇ D̂ with the exact rate of kernels/strains.h. Gazzola's form keeps the
// first two terms of J_r⁻¹ = I + ½[ψ]× + γ[ψ]×²; without the third the
// internal couples do work that the elastic energy does not account for, an
// O(θ²) relative error (8% of the moment at θ = 1 rad, a curly hair) that
// shows in 3-D as an energy drift independent of dt. For planar bending
// ψ × m = 0 and both forms coincide. Ghost entries have zero stiffness, so they add
// nothing; a clamped root is a Voronoi point of length l̂_0/2 joining element 0
// to the clamp frame held in the ghost element before it.
//
// Stiff rods (kBendRate, kernels/viscous_implicit.h "Stiff rods"): their
// bending moment also carries bend_tau · C_M U̇ on components 1–2, with
// bend_tau = −c h and U̇ the rate at the start-of-step velocities, so that
// with the implicit solve's +c h the bending force is evaluated at
// x_{n+½} + c h (u⁺ − u_n).
//
// Stages: element_stage and voronoi_stage (strains → resultants → scratch),
// then node_force and element_couple gather from scratch (no scatter).
//
// element_stage  reads: model, state      writes: elem_force, elem_couple at k
// voronoi_stage  reads: model, state      writes: vor_moment (m̃), vor_kxm at k
// node_force     reads: elem_force k−1, k
// element_couple reads: vor_moment, vor_kxm k, k+1; elem_couple k
#pragma once

#include "kernels/resultants.h"
#include "kernels/strains.h"

namespace manyrods {

template <Terms kT, class T>
MANYRODS_HD inline void element_stage(int k, const ModelView<T>& m, const ConstStateView<T>& s,
                                      const ScratchView<T>& out) {
  const ElementStrain<T> es = element_strain(k, m, s);
  vec3<T> rate = {T(0), T(0), T(0)};
  if constexpr (kT.kelvin_voigt) rate = element_strain_rate(k, m, s, es);
  const vec3<T> n = element_resultant<kT>(k, m, es.sigma, rate);
  store3(out.elem_force, k, mul_transpose(es.Q, n));
  store3(out.elem_couple, k, cross(es.Qe, n));
}

template <Terms kT, bool kSmall = false, bool kBendRate = false, class T>
MANYRODS_HD inline void voronoi_stage(int k, const ModelView<T>& m, const ConstStateView<T>& s,
                                      const ScratchView<T>& out, T bend_tau = T(0)) {
  const VoronoiStrain<T> vs = voronoi_strain<kSmall>(k, m, s);
  vec3<T> rate = {T(0), T(0), T(0)};
  if constexpr (kT.kelvin_voigt || kBendRate) rate = voronoi_strain_rate(k, m, s, vs);
  vec3<T> mo = voronoi_resultant<kT>(k, m, vs.kappa, rate);
  if constexpr (kBendRate && kT.bend) {  // a stiff rod's bending correction (above)
    const vec3<T> c = load3(m.vor_stiffness, k);
    mo.x += c.x * bend_tau * rate.x;
    mo.y += c.y * bend_tau * rate.y;
  }
  store3(out.vor_moment, k, mo + vs.gamma * cross(vs.psi, cross(vs.psi, mo)));
  store3(out.vor_kxm, k, m.vor_rest_length[k] * cross(vs.kappa, mo));
}

// The branch-free Voronoi stage; returns true when joint k turns by more
// than ½ rad, where its result is not valid and the launcher redoes it with
// voronoi_stage<kT, false>.
template <Terms kT, bool kBendRate = false, class T>
MANYRODS_HD inline bool voronoi_stage_small(int k, const ModelView<T>& m, const ConstStateView<T>& s,
                                            const ScratchView<T>& out, T bend_tau = T(0)) {
  voronoi_stage<kT, true, kBendRate>(k, m, s, out, bend_tau);
  T tr = T(0);
  MANYRODS_UNROLL
  for (int i = 0; i < 9; ++i) tr += s.elem_Q[i][k] * s.elem_Q[i][k - 1];
  return !(T(0.5) * (tr - T(1)) >= T(kSmallRotationCos));
}

template <class T>
MANYRODS_HD inline vec3<T> node_force(int k, const ConstScratchView<T>& sc) {
  return load3(sc.elem_force, k) - load3(sc.elem_force, k - 1);
}

// Internal (elastic + viscous) couple on element k, material frame.
template <class T>
MANYRODS_HD inline vec3<T> element_couple(int k, const ConstScratchView<T>& sc) {
  return load3(sc.vor_moment, k + 1) - load3(sc.vor_moment, k) +
         T(0.5) * (load3(sc.vor_kxm, k) + load3(sc.vor_kxm, k + 1)) + load3(sc.elem_couple, k);
}

// The rigid-body term of Euler's equations J ω̇ = C + (Jω) × ω.
template <class T>
MANYRODS_HD inline vec3<T> euler_couple(vec3<T> inertia, vec3<T> w) {
  return cross(hadamard(inertia, w), w);
}

}  // namespace manyrods
