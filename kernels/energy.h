// kernels/energy.h — per-index energies and dissipation (diagnostics; not
// part of the step).
//
//   kinetic      ½ m |v|² (node),  ½ ωᵀ J ω (element)
//   elastic      ½ σᵀ C_F σ l̂ (element),  ½ (κ−U0)ᵀ C_M (κ−U0) D̂ (Voronoi)
//   dissipation  2·D_v density, seed eq. (11):  σ̇ᵀ V_F σ̇ l̂ + κ̇ᵀ V_M κ̇ D̂
//                (the mechanical energy falls at exactly this rate)
//   potential    −m g·x − f_ext·x  (dead loads)
// Terms switched off contribute nothing, as in the step.
//
// reads: model, state, loads   writes: return values only
#pragma once

#include "kernels/integrate.h"

namespace manyrods {

template <class T>
MANYRODS_HD inline T node_kinetic_energy(int k, const ModelView<T>& m, const ConstStateView<T>& s) {
  const vec3<T> v = load3(s.node_v, k);
  return T(0.5) * m.node_mass[k] * dot(v, v);
}

template <class T>
MANYRODS_HD inline T element_kinetic_energy(int k, const ModelView<T>& m, const ConstStateView<T>& s) {
  const vec3<T> w = load3(s.elem_w, k);
  return T(0.5) * dot(w, hadamard(load3(m.elem_inertia, k), w));
}

template <Terms kT, class T>
MANYRODS_HD inline T element_elastic_energy(int k, const ModelView<T>& m, const ConstStateView<T>& s) {
  const vec3<T> sigma = element_strain(k, m, s).sigma;
  const vec3<T> zero = {T(0), T(0), T(0)};
  const vec3<T> n = kelvin_voigt_law<kT.shear, kT.stretch, false>(
      load3(m.elem_stiffness, k), load3(m.elem_tau, k), sigma, zero);
  return T(0.5) * m.elem_rest_length[k] * dot(sigma, n);
}

template <Terms kT, class T>
MANYRODS_HD inline T voronoi_elastic_energy(int k, const ModelView<T>& m, const ConstStateView<T>& s) {
  const vec3<T> dk = voronoi_strain(k, m, s).kappa - load3(m.vor_rest_curvature, k);
  const vec3<T> zero = {T(0), T(0), T(0)};
  const vec3<T> mo = kelvin_voigt_law<kT.bend, kT.twist, false>(
      load3(m.vor_stiffness, k), load3(m.vor_tau, k), dk, zero);
  return T(0.5) * m.vor_rest_length[k] * dot(dk, mo);
}

// 2·D_v contributions: the rate at which Kelvin–Voigt removes energy.
template <Terms kT, class T>
MANYRODS_HD inline T element_dissipation(int k, const ModelView<T>& m, const ConstStateView<T>& s) {
  if constexpr (!kT.kelvin_voigt) return T(0);
  const ElementStrain<T> es = element_strain(k, m, s);
  const vec3<T> rate = element_strain_rate(k, m, s, es);
  const vec3<T> zero = {T(0), T(0), T(0)};
  const vec3<T> nv = kelvin_voigt_law<kT.shear, kT.stretch, true>(
      load3(m.elem_stiffness, k), load3(m.elem_tau, k), zero, rate);
  return m.elem_rest_length[k] * dot(rate, nv);
}

template <Terms kT, class T>
MANYRODS_HD inline T voronoi_dissipation(int k, const ModelView<T>& m, const ConstStateView<T>& s) {
  if constexpr (!kT.kelvin_voigt) return T(0);
  const VoronoiStrain<T> vs = voronoi_strain(k, m, s);
  const vec3<T> rate = voronoi_strain_rate(k, m, s, vs);
  const vec3<T> zero = {T(0), T(0), T(0)};
  const vec3<T> mv = kelvin_voigt_law<kT.bend, kT.twist, true>(
      load3(m.vor_stiffness, k), load3(m.vor_tau, k), zero, rate);
  return m.vor_rest_length[k] * dot(rate, mv);
}

template <Terms kT, class T>
MANYRODS_HD inline T node_potential_energy(int k, const ModelView<T>& m, const LoadsView<T>& l,
                                           const ConstStateView<T>& s) {
  return -dot(node_external_force<kT>(k, m, l), load3(s.node_x, k));
}

}  // namespace manyrods
