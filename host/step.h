// host/step.h — the time step as a short list of stages (DESIGN.md §3).
//
// Position Verlet (Gazzola et al. 2018; the scheme PyElastica uses), h = dt:
//   1. drift ½h:  x += ½h v,  Q ← exp(−½h ω) Q           kinematic_node/element
//   2. strains and total resultants at (x, Q)_{n+½} with the rates from
//      (v, ω)_n                                           element_stage, voronoi_stage
//   3. kick h:    v += h m⁻¹ F,  ω += h J⁻¹ C             dynamic_node/element
//   3b. (Viscous::implicit) (M + hD) u⁺ = M u               viscous_implicit_rod
//   4. drift ½h                                           kinematic_node/element
// Second order for the elastic (conservative) part, first order for the
// Kelvin–Voigt part in both treatments: Viscous::explicit_rate evaluates the
// viscous resultants with the velocities at the start of the kick (stable for
// dt ≲ 2/(τ ω_max²)); Viscous::implicit (the default) integrates them by
// backward Euler after the elastic kick (stable for any τ).
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "host/launch.h"
#include "kernels/energy.h"
#include "manyrods/batch.h"

namespace manyrods {

// Stages 2: scratch ← resultants of the current state.
template <Terms kT, class T>
void compute_resultants(RodBatch<T>& b, const Exec& ex) {
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> s = std::as_const(b).state_view();
  const ScratchView<T> sc = b.scratch_view();
  launch(b.slots(), ex, [&](int k) {
    element_stage<kT>(k, m, s, sc);
    voronoi_stage<kT>(k, m, s, sc);
  });
}

template <class T>
void drift(RodBatch<T>& b, T h, const Exec& ex) {
  const StateView<T> s = b.state_view();
  launch(b.slots(), ex, [&](int k) {
    kinematic_node(k, h, s);
    kinematic_element(k, h, s);
  });
}

template <Terms kT, class T>
void kick(RodBatch<T>& b, T h, const Exec& ex) {
  const ModelView<T> m = b.model_view();
  const LoadsView<T> l = b.loads_view();
  const ConstScratchView<T> sc = std::as_const(b).scratch_view();
  const StateView<T> s = b.state_view();
  launch(b.slots(), ex, [&](int k) {
    dynamic_node<kT>(k, h, m, l, sc, s);
    dynamic_element<kT>(k, h, m, l, sc, s);
  });
}

// How the Kelvin–Voigt force is integrated.
//   implicit:      backward Euler in the velocities after the elastic kick
//                  (kernels/viscous_implicit.h): stable for any τ, one
//                  block-tridiagonal solve per rod and step.
//   explicit_rate: the viscous resultants use the rates at the start of the
//                  kick; stable only for dt ≲ 2/(τ ω_max²). The accuracy
//                  reference.
enum class Viscous { implicit, explicit_rate };

// Stage 3b: the implicit viscous update, rod by rod.
template <Terms kT, class T>
void viscous_update(RodBatch<T>& b, T h, const Exec& ex) {
  const ModelView<T> m = b.model_view();
  const StateView<T> s = b.state_view();
  const ImplicitScratchView<T> sc = b.implicit_scratch_view();
  const int rods = b.rod_count();
#pragma omp parallel for num_threads(ex.threads) schedule(dynamic, 16) if (ex.threads > 1 && rods > 1)
  for (int r = 0; r < rods; ++r)
    viscous_implicit_rod<kT>(b.rods[r].offset + 1, b.rods[r].elements + 1, h, m, s, sc);
}

// One Position Verlet step of length dt for every rod in the batch.
template <Terms kT = kAllTerms, Viscous kV = Viscous::implicit, class T>
void step(RodBatch<T>& b, T dt, const Exec& ex = {}) {
  constexpr bool kImplicit = kT.kelvin_voigt && kV == Viscous::implicit;
  constexpr Terms kExplicit = [] {
    Terms t = kT;
    if (kImplicit) t.kelvin_voigt = false;
    return t;
  }();
  drift(b, T(0.5) * dt, ex);
  compute_resultants<kExplicit>(b, ex);
  kick<kExplicit>(b, dt, ex);
  if constexpr (kImplicit) viscous_update<kT>(b, dt, ex);
  drift(b, T(0.5) * dt, ex);
  b.state.time += double(dt);
  b.state.steps += 1;
}

// Generalized forces of the current state (for analysis: statics, linearized
// dynamics, tests): total node force (internal + external, lab frame) and
// element couple (internal + external, material frame, including (Jω)×ω),
// written per slot into force[3][slots] and couple[3][slots].
template <Terms kT = kAllTerms, class T>
void generalized_forces(RodBatch<T>& b, T* const force[3], T* const couple[3], const Exec& ex = {}) {
  compute_resultants<kT>(b, ex);
  const ModelView<T> m = b.model_view();
  const LoadsView<T> l = b.loads_view();
  const ConstScratchView<T> sc = std::as_const(b).scratch_view();
  const ConstStateView<T> s = std::as_const(b).state_view();
  launch(b.slots(), ex, [&](int k) {
    store3(force, k, node_force(k, sc) + node_external_force<kT>(k, m, l));
    const mat3<T> Q = load_frame(s.elem_Q, k);
    store3(couple, k, element_couple(k, sc) + euler_couple(load3(m.elem_inertia, k), load3(s.elem_w, k)) +
                          element_external_couple<kT>(k, l, Q));
  });
}

// Energies of rod `rod` (or of the whole batch when rod < 0), summed in
// double in index order (deterministic).
struct Energies {
  double kinetic = 0;       // translational + rotational
  double elastic = 0;       // stretch, shear, bend, twist
  double potential = 0;     // gravity and dead point forces
  double dissipation = 0;   // 2·D_v: rate of viscous energy loss, W
  double total() const { return kinetic + elastic + potential; }
};

template <Terms kT = kAllTerms, class T>
Energies energies(const RodBatch<T>& b, int rod = -1) {
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> s = b.state_view();
  const LoadsView<T> l = b.loads_view();
  Energies e;
  auto add_range = [&](int first, int last) {  // slots [first, last)
    for (int k = first; k < last; ++k) {
      e.kinetic += double(node_kinetic_energy(k, m, s)) + double(element_kinetic_energy(k, m, s));
      e.elastic += double(element_elastic_energy<kT>(k, m, s)) + double(voronoi_elastic_energy<kT>(k, m, s));
      e.potential += double(node_potential_energy<kT>(k, m, l, s));
      e.dissipation += double(element_dissipation<kT>(k, m, s)) + double(voronoi_dissipation<kT>(k, m, s));
    }
  };
  if (rod >= 0) {
    const int o = b.rods[rod].offset;
    add_range(o, o + b.rods[rod].elements + 2);
  } else {
    for (const RodInfo& r : b.rods) add_range(r.offset, r.offset + r.elements + 2);
  }
  return e;
}

// The first non-finite entry of the state, if any: rod, what and index.
struct NonFinite {
  bool found = false;
  int rod = -1;
  std::string field;  // "node" or "element"
  int index = -1;
};

template <class T>
NonFinite find_non_finite(const RodBatch<T>& b) {
  for (int r = 0; r < b.rod_count(); ++r) {
    const int n = b.rods[r].elements;
    for (int j = 0; j <= n; ++j) {
      const int k = b.node_index(r, j);
      for (int d = 0; d < 3; ++d)
        if (!std::isfinite(b.state.node_x[d][k]) || !std::isfinite(b.state.node_v[d][k]))
          return {true, r, "node", j};
    }
    for (int e = 0; e < n; ++e) {
      const int k = b.elem_index(r, e);
      for (int i = 0; i < 9; ++i)
        if (!std::isfinite(b.state.elem_Q[i][k])) return {true, r, "element", e};
      for (int d = 0; d < 3; ++d)
        if (!std::isfinite(b.state.elem_w[d][k])) return {true, r, "element", e};
    }
  }
  return {};
}

}  // namespace manyrods
