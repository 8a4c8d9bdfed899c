// include/manyrods/statics.h — solve_static(batch): Newton equilibrium of the
// discrete rods under their loads and gravity (an analysis tool: statics for
// tests, initial states for scenes; not part of the time step). Double
// precision batches only. The method is described in host/core/analysis/statics.h.
#pragma once

#include <vector>

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

// What one hold exerts on its rod, in the lab frame: the force on the held
// node (N) and, for a clamp, the couple on the frames it holds (N·m: a
// clamped end's clamp frame, a clamped interior node's two elements; an
// element held by two clamps counts for the first).
struct HoldReaction {
  int rod = 0;
  int node = 0;  // 0 … n
  bool clamped = false;
  Vec3 force{};
  Vec3 moment{};
};

// The reactions of every held node of the batch (rod by rod, root to tip),
// from the balance of the held unknowns at the batch's positions and frames,
// at rest (velocities taken as zero): R = −(internal + external force) on
// the node, M = −Σ Qᵀ(internal + external couple) over the held frames. At
// a static equilibrium (solve_static) these are the support reactions
// (connector loads); they balance the loads on the rod, force and moment
// (docs/model.md "Static equilibrium"). kT: the elastic terms, gravity and
// loads to count (the Kelvin–Voigt term is ignored).
template <Terms kT = kAllTerms>
std::vector<HoldReaction> hold_reactions(const RodBatch<double>& b);

extern template std::vector<HoldReaction> hold_reactions<kAllTerms>(const RodBatch<double>&);
extern template std::vector<HoldReaction> hold_reactions<kNoKelvinVoigt>(const RodBatch<double>&);

}  // namespace manyrods
