// host/core/step/diagnostics.h — what a state is worth, outside the step: energies
// (kernels/energy.h), the first non-finite entry, and the generalized forces
// (for statics and analysis).
#pragma once

#include <cmath>
#include <utility>

#include "host/core/step/schedule.h"
#include "host/core/step/stages.h"
#include "kernels/energy.h"
#include "manyrods/step.h"

namespace manyrods {

// Generalized forces of the current state (for analysis: statics, linearized
// dynamics, tests): total node force (internal + external, lab frame) and
// element couple (internal + external, material frame, including (Jω)×ω),
// written per slot into force[3][slots] and couple[3][slots].
template <Terms kT = kAllTerms, class T>
void generalized_forces(RodBatch<T>& b, T* const force[3], T* const couple[3], const Exec& ex = {}) {
  compute_resultants<kT>(b, ex, whole(b));
  const ModelView<T> m = b.model_view();
  const LoadsView<T> l = b.loads_view();
  const ConstScratchView<T> sc = std::as_const(b).scratch_view();
  const ConstStateView<T> s = std::as_const(b).state_view();
  launch(b.slots(), ex, [&](int k) MANYRODS_KERNEL_LAMBDA {
    store3(force, k, node_force(k, sc) + node_external_force<kT>(k, m, l));
    const mat3<T> Q = load_frame(s.elem_Q, k);
    store3(couple, k, element_couple(k, sc) + euler_couple(load3(m.elem_inertia, k), load3(s.elem_w, k)) +
                          element_external_couple<kT>(k, l, Q));
  });
}

// Energies (include/manyrods/step.h), summed in double in slot order.
template <Terms kT, class T>
Energies energies(const RodBatch<T>& b, int rod) {
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
      if constexpr (kT.colliders || kT.rod_contact)
        if (b.contact.on) e.contact_work += double(b.contact.work[k]);
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

// The first non-finite entry of the state (rods in order; a rod's nodes,
// then its elements).
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
