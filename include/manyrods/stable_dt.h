// include/manyrods/stable_dt.h — an estimate of the largest stable time step
// of Position Verlet for the batch's rods (docs/model.md "Stable time step";
// the derivation is in host/core/analysis/stable_dt.h).
#pragma once

#include <limits>

#include "manyrods/batch.h"
#include "manyrods/step.h"
#include "manyrods/terms.h"

namespace manyrods {

struct StableDt {
  double elastic = 0;           // 2/ω_max bound: Position Verlet, undamped or implicit KV (inf: no limit)
  double explicit_viscous = 0;  // additional limit of Viscous::explicit_rate (inf without KV)
  double omega_max = 0;         // the Gershgorin bound on ω_max, rad/s
  // Stiff rods (RodSpec::stiff_implicit) have no stable-step limit: their
  // step is an accuracy choice. This is the one dt = "auto" takes for them,
  // h·ω₄ = ¼ with ω₄ the fourth clamped–free bending frequency of each stiff
  // rod (inf: no stiff rod). 2.4e-3 s for human hair, n-independent.
  double accuracy = std::numeric_limits<double>::infinity();
  // The step dt = "auto" scales by its safety factor: the smaller of the two.
  double automatic() const { return elastic < accuracy ? elastic : accuracy; }
};

// From the rods' parameters and the current state (a lower bound on the
// linear limit of the explicit parts: Gershgorin's theorem).
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
