// include/manyrods/statics.h — solve_static(batch): Newton equilibrium of the
// discrete rods under their loads and gravity (an analysis tool: statics for
// tests, initial states for scenes; not part of the time step). Double
// precision batches only. The method is described in host/core/analysis/statics.h.
#pragma once

#include <limits>
#include <vector>

#include "manyrods/batch.h"
#include "manyrods/step.h"
#include "manyrods/terms.h"

namespace manyrods {

struct StaticOptions {
  // The first load increment is 1/load_steps; then each is halved where
  // Newton fails and doubled (up to 1/load_steps) where it converges in a
  // few iterations, down to min_load_step, below which the solve gives up.
  int load_steps = 10;
  double min_load_step = 1.0 / 4096;
  int max_newton_iterations = 50;
  double tolerance = 1e-10;  // on |Δx|/L and |Δφ| (rad), the Newton update
  double max_update = 0.05;  // cap on one update (same measure)
  // Driven holds (include/manyrods/drive.h) put at their motion's pose at
  // this time (s), walked there from where they are along the load path;
  // NaN: they stay where they are.
  double hold_time = std::numeric_limits<double>::quiet_NaN();
  int threads = 0;  // 1: one rod at a time; otherwise rods in parallel on OpenMP's threads
};

struct StaticResult {
  bool converged = true;
  int iterations = 0;       // total Newton iterations
  int load_increments = 0;  // load increments taken, all rods
  // rods that started in equilibrium under their full loads (a warm start:
  // a solve before this one, the holds moved since): only their holds
  // walked, the whole way in one increment where Newton allows
  int warm_rods = 0;
  // Collider contacts with friction at the end (docs/model.md "Static
  // equilibrium", Friction at the colliders), each a node pressed on a
  // collider: stuck where it first touched it, or at the friction limit
  // (slipping: its friction on the cone, μ times its push across the rod,
  // μa along it)
  int sticking = 0, slipping = 0;
  double last_update = 0;   // the largest last Newton update of a rod
  // What is left out of balance: the largest |force| on a free node (N)
  // and |couple| on a free element (N·m), at the full load when converged,
  // else the failed rod's at the load it could not reach.
  double residual_force = 0, residual_couple = 0;
  // When not converged: the first rod without an equilibrium, its node
  // with the largest residual force, the load fraction it reached (with
  // friction at a collider and holds that walk, the loads come first and
  // then the holds: on that second leg, holds_walk, the fraction of the
  // walk), and
  // whether it is a mechanism under its loads (its stiffness matrix has
  // zero_modes zero-energy motions along which the loads push: a free rod
  // in gravity, a pendulum away from its vertical) or the Newton solve
  // failed (a limit point: the path snaps through, or no equilibrium near).
  int failed_rod = -1, failed_node = -1;
  double load_reached = 1;
  int zero_modes = 0;
  bool mechanism = false;
  bool holds_walk = false;
};

// Solves for static equilibrium under the batch's current loads and gravity
// (and the buoyancy of a fluid), the colliders' push and friction and,
// with rod–rod or self contact (ContactSpec::rod_rod, self), the rods'
// pushes on each other (frictionless; rods that may touch are solved
// together), starting from the current state, rod by rod; loads (and
// driven holds, with opt.hold_time) are ramped along the load path in
// adaptive increments. Friction at a collider (its static coefficients)
// holds a node where it first touched it, up to μ times its push, and
// lets it slip beyond, along the load path; the batch keeps those contact
// points (ContactData::static_anchors) for the next solve of the same
// state, so that a re-solve after a hold moved remembers where the rods
// stuck. A rod already in equilibrium under its
// full loads (solved before, its holds moved since: an interactive drag)
// keeps them and walks only its holds, in one increment where Newton
// allows (a warm start). Velocities are set to zero. Rods
// without an equilibrium are left at the last load fraction reached
// (StaticResult says which). The Kelvin–Voigt term is ignored (no
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
// loads to count (the Kelvin–Voigt term is ignored); a fluid's buoyancy
// counts with gravity; the colliders' and, with rod–rod or self contact,
// the rods' pushes on the held node count as external forces.
template <Terms kT = kAllTerms>
std::vector<HoldReaction> hold_reactions(const RodBatch<double>& b);

extern template std::vector<HoldReaction> hold_reactions<kAllTerms>(const RodBatch<double>&);
extern template std::vector<HoldReaction> hold_reactions<kNoKelvinVoigt>(const RodBatch<double>&);
extern template std::vector<HoldReaction> hold_reactions<kNoGravity>(const RodBatch<double>&);
extern template std::vector<HoldReaction> hold_reactions<kNoKelvinVoigtNoGravity>(const RodBatch<double>&);

// Gravity preload (docs/model.md "Gravity preload"): the rest strains V0
// and curvatures U0 of the rods with RodSpec::preload solved so that their
// shape now (as built or imported) is their static equilibrium under the
// batch's gravity (with a fluid's buoyancy), dead loads and the colliders
// they rest on, at rest: simulated, they stay where they are. A rod with a
// free tip has one such rest shape (the internal forces summed from the
// tip); with more holds, the one of least complementary energy (Menabrea:
// the preload stress a linear analysis of the structure built in this
// shape gives). Colliders push (frictionless) on the touches within one
// contact radius of their surface, as much as they can. Rod–rod contact
// carries nothing. Where a rod has no such rest shape (a free rod in
// gravity) its rest shape is left as it was and PreloadResult says which;
// velocities are kept. Double-precision batches; kT selects the elastic
// terms and gravity.
struct PreloadResult {
  bool ok = true;
  int rods = 0;      // rods preloaded
  int contacts = 0;  // collider touches that carry load
  // The largest force (N) and couple (N·m) left out of balance at the
  // rods' new rest shapes (round-off when ok); when not ok, the first rod
  // without one and its node with the largest force left.
  double residual_force = 0, residual_couple = 0;
  int failed_rod = -1, failed_node = -1;
  // Of the rods in equilibrium, those whose equilibrium is unstable (a
  // small perturbation grows: a hair standing up beyond its buckling load
  // under its own weight): how many, the one that would fall away fastest
  // and its growth rate γ (1/s: a perturbation grows as e^{γt}; NaN for a
  // rod of more than 1,500 unknowns, whose growth is not measured). Their
  // rest shapes are the preload's all the same: what to do is the caller's
  // choice (the scene, Python and C refuse them).
  int unstable = 0, unstable_rod = -1;
  double growth_rate = 0;
};

template <Terms kT = kAllTerms>
PreloadResult preload_rest_shape(RodBatch<double>& b, int threads = 0);

extern template PreloadResult preload_rest_shape<kAllTerms>(RodBatch<double>&, int);
extern template PreloadResult preload_rest_shape<kNoKelvinVoigt>(RodBatch<double>&, int);
extern template PreloadResult preload_rest_shape<kNoGravity>(RodBatch<double>&, int);
extern template PreloadResult preload_rest_shape<kNoKelvinVoigtNoGravity>(RodBatch<double>&, int);

}  // namespace manyrods
