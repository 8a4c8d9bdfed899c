// include/manyrods/scene.h — TOML scene files (schema in docs/scenes.md) and
// the batch a scene builds (library manyrods::scene).
//
// A scene is a [simulation] table and one or more [[rods]] groups. Loading
// validates every key once, at the boundary: unknown
// keys, wrong types and out-of-range values raise SceneError, whose message
// starts with "file:line:column: key.path:" (toml++ source regions), e.g.
//
//   hair.toml:14:18: rods.0.material.youngs_modulus: must be > 0 (got -3.9e9)
//
// Key paths use the `--vary` spelling of the command-line tool: the first
// [[rods]] table is `rods.0`. A parsed scene holds the expanded rods as
// RodSpec (double precision) plus what the library's RodSpec does not carry:
// the group of each rod, its tip force, its initial (static) state and its
// term switches.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "manyrods/batch.h"
#include "manyrods/observables.h"
#include "manyrods/stable_dt.h"
#include "manyrods/strain.h"
#include "manyrods/statics.h"
#include "manyrods/step.h"

namespace manyrods::scene {

// Every problem with a scene file (or a --vary override of one).
struct SceneError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// A static solve that found no equilibrium where one may exist (Newton
// failing: a snap-through, a path that ends), naming the rod and residual
// (static_failure); a rod that is a mechanism under its loads is a
// SceneError (bad input).
struct StaticError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum class Precision { float64, float32 };

// The validity monitor of a run (docs/scenes.md "The validity monitor"):
// checked at every sample point (every 64 steps and every frame).
struct Validity {
  // the seed model's linear Kelvin–Voigt law holds for small strains: the
  // largest |σ| (shear, stretch) or |κ − U0|·width/2 (bending, twist at the
  // section's outer fibre) above this is a warning (the seed's own damped
  // cantilever reaches 5 %)
  double strain = 0.1;
  // an element stretched or sheared beyond this (|σ|) is nonsense for any
  // rod model here: a warning, and an error with on_violation = error
  double stretch = 0.5;
  // mechanical energy (kinetic + elastic + potential − contact work; damping
  // only lowers it) above its start by this fraction of the largest kinetic
  // + elastic energy seen, in a scene without a source of work (driven
  // roots, tip forces, moving colliders)
  double energy_growth = 0.01;
  bool error = false;  // on_violation = "error": stop the run (exit 1), else warn (exit 3)
};

struct Simulation {
  bool dt_auto = true;  // dt = "auto": stable_dt(batch).elastic × dt_safety
  double dt = 0;        // s, when !dt_auto
  double dt_safety = 0.9;
  // A step above the stable limit (dt, or dt_safety > 1) is refused by
  // scene_dt unless forced (`manyrods run --force-dt`): it either blows up
  // or, damped, runs into nonsense.
  bool force_dt = false;
  double duration = 0;         // s of simulated time
  double output_interval = 0;  // s of simulated time between frames (0: every step... see docs)
  Integrator integrator = Integrator::position_verlet;
  Precision precision = Precision::float64;
  Vec3 gravity{0, 0, 0};         // m/s²
  bool output_directors = true;  // write /element_directors frames
  Validity validity;             // [simulation] validity = { ... }
};

// Which terms a group's rods include (include/manyrods/terms.h). shear, stretch, bend
// and twist are switched off by zeroing that stiffness in the rods' model
// (identical to the compile-time switch: an off term contributes no force);
// kelvin_voigt off = no damping for the group; gravity off = the group's rods
// feel no gravity (below, "the batch of a scene": the compile-time term when all groups
// have it, dead node loads otherwise).
struct TermSwitches {
  bool shear = true, stretch = true, bend = true, twist = true, kelvin_voigt = true, gravity = true;
};

struct RodGroup {
  std::string name;
  int count = 0;
  int first_rod = 0;  // index of its first rod in Scene::rods
  int line = 0;       // source line of its [[rods]] table
  TermSwitches terms;
  Vec3 tip_force{0, 0, 0};  // N, lab frame, dead load on the last node
  bool has_initial_tip_force = false;
  Vec3 initial_tip_force{0, 0, 0};  // start in static equilibrium under it, released at t = 0
  double width = 0;                 // largest section dimension (m), for USD widths and strains
  bool has_friction = false;        // its own `friction` (include/manyrods/contact.h)
  Friction friction;
};

struct Override {
  std::string key;  // e.g. "rods.0.damping.tau_extension"
  double value = 0;
};

struct Scene {
  std::string source;  // file name used in messages
  std::string text;    // the TOML text as read
  Simulation sim;
  std::vector<RodGroup> groups;
  std::vector<RodSpec> rods;   // expanded
  std::vector<int> rod_group;  // [rods] group index
  // [[colliders]] and [contact] (docs/contact.md), with each rod's group friction
  ContactSpec contact;
  bool has_contact = false;
  // [fluid] (include/manyrods/fluid.h); also set, with a still fluid, when
  // some group has drag and the scene no [fluid] table
  Fluid fluid;
  bool has_fluid = false;
  // The motions the host sets by name (motion = "host", include/manyrods/drive.h
  // HostMotion), shared by the holds and colliders that name them; a file run
  // holds them at their initial (identity) pose.
  std::vector<std::shared_ptr<HostMotion>> host_motions;
  // [[observables]] (include/manyrods/observables.h)
  std::vector<Observable> observables;
  // The files the scene was read from: its source when that is a file, the
  // mesh colliders' OBJ files and the groups' from_curves files (a command
  // refuses to write over any of them: runner.h check_not_input).
  std::vector<std::string> inputs;
};

// Parses and validates. `overrides` set numeric values by key path before
// validation (the sweep); their errors name the key and "--vary".
Scene parse_scene(std::string_view text, const std::string& source,
                  const std::vector<Override>& overrides = {});
// Reads the file (SceneError if it cannot be read) and parses it.
Scene load_scene(const std::string& path);

// Estimated bytes of a batch of these rods (model, state, scratch, loads and
// the implicit viscous workspace) in the given precision.
std::uint64_t estimated_batch_bytes(const Scene& s);
// Throws SceneError when the batch would not fit in this machine's memory
// or exceeds the library's int slot index.
void check_batch_size(const Scene& s);

// ---- the batch of a scene ------------------------------------------------------
// From a parsed scene to a stepping batch: the batch with
// the scene's term switches, loads and initial state applied, the time step,
// and the dispatch of the compile-time Terms (include/manyrods/terms.h) that a scene
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
// which is what the compile-time switch does too (include/manyrods/terms.h: "off
// means the term contributes no force"); it saves no time. A group with
// terms.kelvin_voigt = false gets no damping.


struct StepChoice {
  bool kelvin_voigt = false;
  bool gravity = false;
  bool colliders = false;    // Terms::colliders (the scene has [[colliders]])
  bool rod_contact = false;  // Terms::rod_contact ([contact] rod_rod or self)
  Integrator integrator = Integrator::position_verlet;
};

StepChoice step_choice(const Scene& s);

// Builds the batch (SceneError naming the group on invalid rods). With
// `initial_state`, groups with initial_tip_force start in static equilibrium
// under it (solved in double precision, one rod at a time, in parallel,
// identical rods solved once) and are released at t = 0.
template <class T>
RodBatch<T> build_scene_batch(const Scene& s, bool initial_state = true);

// [simulation] dt, or stable_dt(batch).elastic × dt_safety for "auto".
// Then shortened to the largest step that divides output_interval into
// whole steps (frame_aligned_dt), so that frames fall on multiples of it.
// SceneError when that step exceeds stable_dt(batch).elastic (the limit of
// what the step integrates explicitly; an estimate below the true limit,
// docs/scenes.md "The step-size guard") unless sim.force_dt.
template <class T>
double scene_dt(const Scene& s, const RodBatch<T>& b);
double frame_aligned_dt(double dt, double interval);

// advance<Terms, Viscous::implicit, integrator>(b, dt, steps, ex) with the
// scene's terms (NonFiniteError as advance).
template <class T>
void advance_scene(RodBatch<T>& b, const StepChoice& c, T dt, std::int64_t steps, const Exec& ex);

// energies<Terms>(b, rod) with the scene's terms.
template <class T>
Energies scene_energies(const RodBatch<T>& b, const StepChoice& c, int rod = -1);

// stable_dt<Terms>(b) with the choice's terms (contact does not limit it).
template <class T>
StableDt scene_stable_dt(const RodBatch<T>& b, const StepChoice& c);

// solve_static<Terms>(b, opt) with the choice's Kelvin–Voigt and gravity
// terms; colliders push frictionlessly (host/core/analysis/statics.h
// collider_push). InputError for what the static solve does not take:
// rod-rod and self contact, a fluid's wind (its buoyancy
// counts; drag at rest in still fluid is zero), hold_time < 0 or not finite
// when given.
StaticResult scene_solve_static(RodBatch<double>& b, const StepChoice& c, const StaticOptions& opt = {});
// preload_rest_shape<Terms>(b) with the choice's terms (include/manyrods/statics.h:
// the rest shapes of the rods with RodSpec::preload, so that they stand as
// built; build_scene_batch calls it for groups with preload = true).
PreloadResult scene_preload(RodBatch<double>& b, const StepChoice& c);
// The rest strains and curvatures of `from` (a double batch of the same
// rods: a preload solved in double) into b.
template <class T>
void copy_rest_shape(const RodBatch<double>& from, RodBatch<T>& b) {
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < b.slots(); ++k) {
      b.model.elem_rest_strain[a][k] = T(from.model.elem_rest_strain[a][k]);
      b.model.vor_rest_curvature[a][k] = T(from.model.vor_rest_curvature[a][k]);
    }
}
// A preload without a rest shape, or whose rest shape makes an unstable
// equilibrium (PreloadResult::unstable), in words (the rod as
// static_failure names it); "" when neither.
std::string preload_failure(const PreloadResult& r, const RodBatch<double>& b, const Scene* s = nullptr);
// hold_reactions<Terms>(b) with the choice's terms.
std::vector<HoldReaction> scene_hold_reactions(const RodBatch<double>& b, const StepChoice& c);
// A static solve that found no equilibrium, in words: the rod (its name,
// index and group, from the scene when given), the node with the largest
// residual force, the load fraction reached and why (a mechanism under
// its loads, or Newton failing: a snap-through or no equilibrium near).
std::string static_failure(const StaticResult& r, const RodBatch<double>& b, const Scene* s = nullptr);
// b's state replaced by the scene's static equilibrium at t = 0
// (include/manyrods/any_batch.h static_equilibrium), velocities zero:
// `manyrods run --from-static`.
template <class T>
void start_from_static(const Scene& s, RodBatch<T>& b);

// Largest strain of a rod: manyrods/strain.h (max_strain, strain_peak,
// StrainPeak), named here too for scene code.
using manyrods::max_strain;
using manyrods::strain_peak;
using manyrods::StrainPeak;

// Node positions [nodes, 3] and element directors [elements, 3, 3] of all
// rods, without ghosts, in rod order (the HDF5 frame layout).
template <class T>
void gather_positions(const RodBatch<T>& b, std::vector<T>& out);
template <class T>
void gather_directors(const RodBatch<T>& b, std::vector<T>& out);

}  // namespace manyrods::scene
