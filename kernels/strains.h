// kernels/strains.h — discrete strains and their exact rates.
//
// Element k (nodes k, k+1; rest length l̂), seed eq. (1) strain V = Rᵀ∂sφ:
//   e = x_{k+1} − x_k,   V = Q e / l̂,   σ = V − V0.
// Its rate, differentiating with Q̇ = −[ω]×Q (objective: zero for any rigid
// motion, since then Q(v_{k+1} − v_k) = ω × Q e):
//   σ̇ = ( Q (v_{k+1} − v_k) − ω × (Q e) ) / l̂.
//
// Voronoi point k (joint of elements a = k−1 and b = k; rest length D̂):
//   R = Q_b Q_aᵀ = exp([ψ]×),   κ = −ψ / D̂    (so that Q_b ≈ (I − D̂[κ]×) Q_a,
//   the discrete form of ∂s d_i = U × d_i). ψ is the rotation axis of R, so κ
//   has the same components in frames a and b.
// Its exact rate: RᵀṘ = [ω_a − Rᵀω_b]× = [J_r(ψ) ψ̇]×, hence
//   κ̇ = J_r(ψ)⁻¹ (Rᵀ ω_b − ω_a) / D̂.
// Rᵀω_b is ω_b in frame-a components; the plain difference (ω_b − ω_a)/D̂ is
// not objective on a curved rod (docs/validation.md "3a Objectivity under
// rigid motion") and is not used.
//
// reads: node_x, node_v, elem_Q, elem_w, elem_rest_length, elem_rest_strain,
//        vor_rest_length   writes: return values only
#pragma once

#include "kernels/views.h"

namespace manyrods {

template <class T>
struct ElementStrain {
  mat3<T> Q;
  vec3<T> Qe;     // Q (x_{k+1} − x_k), material components
  vec3<T> sigma;  // V − V0
};

template <class T>
MANYRODS_HD inline ElementStrain<T> element_strain(int k, const ModelView<T>& m,
                                                   const ConstStateView<T>& s) {
  ElementStrain<T> r;
  r.Q = load_frame(s.elem_Q, k);
  const vec3<T> e = load3(s.node_x, k + 1) - load3(s.node_x, k);
  r.Qe = mul(r.Q, e);
  r.sigma = (T(1) / m.elem_rest_length[k]) * r.Qe - load3(m.elem_rest_strain, k);
  return r;
}

template <class T>
MANYRODS_HD inline vec3<T> element_strain_rate(int k, const ModelView<T>& m,
                                               const ConstStateView<T>& s,
                                               const ElementStrain<T>& es) {
  const vec3<T> dv = load3(s.node_v, k + 1) - load3(s.node_v, k);
  const vec3<T> w = load3(s.elem_w, k);
  return (T(1) / m.elem_rest_length[k]) * (mul(es.Q, dv) - cross(w, es.Qe));
}

template <class T>
struct VoronoiStrain {
  mat3<T> R;      // Q_k Q_{k−1}ᵀ
  vec3<T> psi;    // log R
  T theta, s, c;  // |ψ|, sin, cos
  T gamma;        // γ(θ) of J_r(ψ)⁻¹ (kernels/math.h)
  vec3<T> kappa;  // total curvature −ψ/D̂ (rest curvature not subtracted)
};

// kSmall: the branch-free path, valid when the joint turns by θ ≤ ½ rad
// (see voronoi_stage_small); launchers redo the others with kSmall = false.
template <bool kSmall = false, class T>
MANYRODS_HD inline VoronoiStrain<T> voronoi_strain(int k, const ModelView<T>& m,
                                                   const ConstStateView<T>& s) {
  VoronoiStrain<T> r;
  r.R = mul_transpose(load_frame(s.elem_Q, k), load_frame(s.elem_Q, k - 1));
  if constexpr (kSmall) {
    r.psi = rotation_log_small(r.R, r.theta, r.s, r.c);
    r.gamma = inverse_right_jacobian_gamma_small(r.theta * r.theta);
  } else {
    r.psi = rotation_log(r.R, r.theta, r.s, r.c);
    r.gamma = inverse_right_jacobian_gamma(r.theta, r.s, r.c);
  }
  r.kappa = (T(-1) / m.vor_rest_length[k]) * r.psi;
  return r;
}


template <class T>
MANYRODS_HD inline vec3<T> voronoi_strain_rate(int k, const ModelView<T>& m,
                                               const ConstStateView<T>& s,
                                               const VoronoiStrain<T>& vs) {
  const vec3<T> wa = load3(s.elem_w, k - 1);
  const vec3<T> wb_in_a = mul_transpose(vs.R, load3(s.elem_w, k));
  return (T(1) / m.vor_rest_length[k]) *
         inverse_right_jacobian_apply(vs.psi, vs.gamma, wb_in_a - wa);
}

}  // namespace manyrods
