// kernels/resultants.h — total (elastic + Kelvin–Voigt) stress resultants in
// the material frame, seed eq. (1), (7), (9):
//   n = C_F (V − V0) + V_F V̇,   C_F = diag(κ1GA, κ2GA, EA),  V_F = C_F diag(τS, τS, τE)
//   m = C_M (U − U0) + V_M U̇,   C_M = diag(EI1, EI2, GJ_T),  V_M = C_M diag(τE, τE, τS)
// A term switched off in Terms (shear: components 1–2 of n; stretch: 3 of n;
// bend: 1–2 of m; twist: 3 of m; kelvin_voigt: the V_F, V_M parts) is zero
// and costs nothing: the branches are on compile-time constants.
//
// reads: elem_stiffness, elem_tau, vor_stiffness, vor_rest_curvature, vor_tau
// writes: return values only
#pragma once

#include "manyrods/terms.h"
#include "kernels/views.h"

namespace manyrods {

// Elastic + viscous force for strain `strain` and rate `rate` with stiffness c
// and retardation times tau; components gated by (on12, on3).
template <bool kOn12, bool kOn3, bool kViscous, class T>
MANYRODS_HD inline vec3<T> kelvin_voigt_law(vec3<T> c, vec3<T> tau, vec3<T> strain, vec3<T> rate) {
  vec3<T> out = {T(0), T(0), T(0)};
  if constexpr (kOn12) {
    out.x = c.x * strain.x;
    out.y = c.y * strain.y;
    if constexpr (kViscous) {
      out.x += c.x * tau.x * rate.x;
      out.y += c.y * tau.y * rate.y;
    }
  }
  if constexpr (kOn3) {
    out.z = c.z * strain.z;
    if constexpr (kViscous) out.z += c.z * tau.z * rate.z;
  }
  return out;
}

template <Terms kT, class T>
MANYRODS_HD inline vec3<T> element_resultant(int k, const ModelView<T>& m, vec3<T> sigma,
                                             vec3<T> sigma_rate) {
  return kelvin_voigt_law<kT.shear, kT.stretch, kT.kelvin_voigt>(
      load3(m.elem_stiffness, k), load3(m.elem_tau, k), sigma, sigma_rate);
}

template <Terms kT, class T>
MANYRODS_HD inline vec3<T> voronoi_resultant(int k, const ModelView<T>& m, vec3<T> kappa,
                                             vec3<T> kappa_rate) {
  return kelvin_voigt_law<kT.bend, kT.twist, kT.kelvin_voigt>(
      load3(m.vor_stiffness, k), load3(m.vor_tau, k), kappa - load3(m.vor_rest_curvature, k),
      kappa_rate);
}

}  // namespace manyrods
