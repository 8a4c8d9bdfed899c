// host/scene_run.h — from a parsed scene to a stepping batch: the batch with
// the scene's term switches, loads and initial state applied, the time step,
// and the dispatch of the compile-time Terms (kernels/terms.h) that a scene
// selects at run time.
//
// Terms dispatch. Kelvin–Voigt and gravity are chosen at compile time for the
// whole batch (four instantiations of the step): Kelvin–Voigt is on when any
// group has damping and terms.kelvin_voigt; gravity when every group's
// terms.gravity is on and [simulation] gravity is not zero. When the groups
// differ, the batch has no gravity term and the groups with gravity carry it
// as a dead load m_j g on each node (the same force). Shear, stretch,
// bend and twist are switched off per group by zeroing that stiffness in
// the model after build_batch: with a zero stiffness the term's elastic and
// viscous resultants are exactly zero (V_F = C_F diag(τ), V_M = C_M diag(τ)),
// which is what the compile-time switch does too (kernels/terms.h: "off
// means the term contributes no force"); it saves no time. A group with
// terms.kelvin_voigt = false gets no damping.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "host/scene.h"
#include "manyrods/manyrods.h"

namespace manyrods::scene {

struct StepChoice {
  bool kelvin_voigt = false;
  bool gravity = false;
  Integrator integrator = Integrator::position_verlet;
};

StepChoice step_choice(const Scene& s);

// Builds the batch (SceneError naming the group on invalid rods). With
// `initial_state`, groups with initial_tip_force start in static equilibrium
// under it (solved in double precision, one rod at a time, identical rods
// solved once) and are released at t = 0.
template <class T>
RodBatch<T> build_scene_batch(const Scene& s, bool initial_state = true);

// [simulation] dt, or stable_dt(batch).elastic × dt_safety for "auto".
template <class T>
double scene_dt(const Scene& s, const RodBatch<T>& b);

// advance<Terms, Viscous::implicit, integrator>(b, dt, steps, ex) with the
// scene's terms (NonFiniteError as advance).
template <class T>
void advance_scene(RodBatch<T>& b, const StepChoice& c, T dt, std::int64_t steps, const Exec& ex);

// energies<Terms>(b, rod) with the scene's terms.
template <class T>
Energies scene_energies(const RodBatch<T>& b, const StepChoice& c, int rod = -1);

// Largest strain of rod `rod`: max over its elements of |σ| (shear and
// stretch, the library's element_strain) and over its joints of
// |κ − U0|·width/2 (bending and twist at the section's outer fibre).
template <class T>
double max_strain(const RodBatch<T>& b, int rod, double width);

// Node positions [nodes, 3] and element directors [elements, 3, 3] of all
// rods, without ghosts, in rod order (the HDF5 frame layout).
template <class T>
void gather_positions(const RodBatch<T>& b, std::vector<T>& out);
template <class T>
void gather_directors(const RodBatch<T>& b, std::vector<T>& out);

}  // namespace manyrods::scene
