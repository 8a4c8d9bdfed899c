// include/manyrods/stable_dt.h — an estimate of the largest stable time step
// of Position Verlet for the batch's rods (docs/model.md "Stable time step";
// the derivation is in host/core/analysis/stable_dt.h).
#pragma once

#include "manyrods/batch.h"
#include "manyrods/step.h"
#include "manyrods/terms.h"

namespace manyrods {

struct StableDt {
  double elastic = 0;           // 2/ω_max bound: Position Verlet, undamped or implicit KV
  double explicit_viscous = 0;  // additional limit of Viscous::explicit_rate (inf without KV)
  double omega_max = 0;         // the Gershgorin bound on ω_max, rad/s
};

// From the rods' parameters and the current state (a lower bound on the
// linear limit: Gershgorin's theorem; stiff rods: the flexural bound).
template <Terms kT = kAllTerms, class T>
StableDt stable_dt(const RodBatch<T>& b);

#define MANYRODS_STABLE_DT_DECLARATIONS(EXTERN, T)                        \
  EXTERN template StableDt stable_dt<kAllTerms, T>(const RodBatch<T>&);   \
  EXTERN template StableDt stable_dt<kNoKelvinVoigt, T>(const RodBatch<T>&); \
  EXTERN template StableDt stable_dt<kNoGravity, T>(const RodBatch<T>&);  \
  EXTERN template StableDt stable_dt<kNoKelvinVoigtNoGravity, T>(const RodBatch<T>&);
MANYRODS_STABLE_DT_DECLARATIONS(extern, float)
MANYRODS_STABLE_DT_DECLARATIONS(extern, double)

}  // namespace manyrods
