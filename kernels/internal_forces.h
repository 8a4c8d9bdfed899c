// kernels/internal_forces.h — internal nodal forces and element couples of the
// standard discrete Cosserat rod (Gazzola et al. 2018, R. Soc. open sci.
// 5:171628, eq. 2.12–2.13), with the seed's linear constitutive law
// (no rescaling of A and I with stretch; DESIGN.md §2). n and m are the TOTAL
// resultants (elastic + viscous), seed eq. (12)–(13).
//
//   node k:     F_k = Δʰ(Qᵀn)   = (Qᵀn)_k − (Qᵀn)_{k−1}
//   element k:  C_k = Δʰ(m) + Aʰ(D̂ κ × m) + (Q e × n) + (Jω) × ω
//             = m_{k+1} − m_k + ½(D̂κ×m)_k + ½(D̂κ×m)_{k+1} + (Q e)_k × n_k + (Jω)_k × ω_k
// (Voronoi k+1 joins elements k and k+1.) κ in κ × m is the TOTAL curvature
// (continuum term U × m). Ghost entries have zero stiffness, so they add
// nothing; a clamped root is a Voronoi point of length l̂_0/2 joining element 0
// to the clamp frame held in the ghost element before it.
//
// Stages: element_stage and voronoi_stage (strains → resultants → scratch),
// then node_force and element_couple gather from scratch (no scatter).
//
// element_stage  reads: model, state      writes: elem_force, elem_couple at k
// voronoi_stage  reads: model, state      writes: vor_moment, vor_kxm at k
// node_force     reads: elem_force k−1, k
// element_couple reads: vor_moment, vor_kxm k, k+1; elem_couple k; elem_inertia, elem_w k
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

template <Terms kT, class T>
MANYRODS_HD inline void voronoi_stage(int k, const ModelView<T>& m, const ConstStateView<T>& s,
                                      const ScratchView<T>& out) {
  const VoronoiStrain<T> vs = voronoi_strain(k, m, s);
  vec3<T> rate = {T(0), T(0), T(0)};
  if constexpr (kT.kelvin_voigt) rate = voronoi_strain_rate(k, m, s, vs);
  const vec3<T> mo = voronoi_resultant<kT>(k, m, vs.kappa, rate);
  store3(out.vor_moment, k, mo);
  store3(out.vor_kxm, k, m.vor_rest_length[k] * cross(vs.kappa, mo));
}

template <class T>
MANYRODS_HD inline vec3<T> node_force(int k, const ConstScratchView<T>& sc) {
  return load3(sc.elem_force, k) - load3(sc.elem_force, k - 1);
}

// Internal couple on element k, material frame, including the rigid-body
// term (Jω) × ω of Euler's equations J ω̇ = C − ω × Jω.
template <class T>
MANYRODS_HD inline vec3<T> element_couple(int k, const ModelView<T>& m, const ConstStateView<T>& s,
                                          const ConstScratchView<T>& sc) {
  const vec3<T> w = load3(s.elem_w, k);
  const vec3<T> jw = hadamard(load3(m.elem_inertia, k), w);
  return load3(sc.vor_moment, k + 1) - load3(sc.vor_moment, k) +
         T(0.5) * (load3(sc.vor_kxm, k) + load3(sc.vor_kxm, k + 1)) + load3(sc.elem_couple, k) +
         cross(jw, w);
}

}  // namespace manyrods
