// include/manyrods/statics.h — solve_static(batch): Newton equilibrium of the
// discrete rods under their loads and gravity (an analysis tool: statics for
// tests, initial states for scenes; not part of the time step). Double
// precision batches only. The method is described in host/core/analysis/statics.h.
#pragma once

#include "manyrods/batch.h"
#include "manyrods/step.h"
#include "manyrods/terms.h"

namespace manyrods {

struct StaticOptions {
  int load_steps = 10;
  int max_newton_iterations = 50;
  double tolerance = 1e-10;  // on |Δx|/L and |Δφ| (rad), the Newton update
  double max_update = 0.05;  // cap on one update (same measure)
};

struct StaticResult {
  bool converged = true;
  int iterations = 0;       // total Newton iterations
  double last_update = 0;   // size of the last Newton update
};

// Solves for static equilibrium under the batch's current loads and gravity,
// starting from the current state; loads are ramped in opt.load_steps equal
// steps. Velocities are set to zero. The Kelvin–Voigt term is ignored (no
// motion); kT selects the elastic terms and gravity.
template <Terms kT = kAllTerms>
StaticResult solve_static(RodBatch<double>& b, const StaticOptions& opt = {});

extern template StaticResult solve_static<kAllTerms>(RodBatch<double>&, const StaticOptions&);
extern template StaticResult solve_static<kNoKelvinVoigt>(RodBatch<double>&, const StaticOptions&);
extern template StaticResult solve_static<kNoGravity>(RodBatch<double>&, const StaticOptions&);
extern template StaticResult solve_static<kNoKelvinVoigtNoGravity>(RodBatch<double>&, const StaticOptions&);

}  // namespace manyrods
