// include/manyrods/fields.h — the one list of a batch's structure-of-arrays
// fields. Everything that has one entry per field is generated from it:
//
//   storage    Model / State / Scratch / Loads members    include/manyrods/batch.h
//   views      ModelView, StateView, ScratchView, …         kernels/views.h
//   allocation, fills, byte counts, view pointers         host/core/model/batch.cpp
//   state copies (advance's replay)                        host/core/step/integrators.h
//   checkpoints (HDF5 /checkpoint, restart)                host/scene/io/h5io.cpp, host/scene/run/runner.cpp
//   the memory estimate of a scene                        host/scene/setup/scene.cpp
//
// Adding a field is one line here (and the kernel that reads or writes it).
//
// Each entry is X(name, components, fill, float_only, "shape, unit: meaning"):
//   name        the member name in the storage struct and in the view; the
//               prefix says its grid: node_ (n+1 per rod), elem_ (n per rod),
//               vor_ (Voronoi points, the joints between elements);
//   components  1 (one array) or 3 / 9 (that many arrays, one per component:
//               a vector in x, y, z or a frame in row-major order);
//   fill        the value of every entry at allocation, ghosts included, as an
//               expression of the component index i (a frame fills with the
//               identity: i % 4 == 0);
//   float_only  1: allocated for float batches only (empty for double);
//   doc         the array's shape and unit, and what it holds.
// Every array is indexed by the slot index k (include/manyrods/batch.h "Slot
// layout"); units are SI.
#pragma once

// Constant during a run (rest state, stiffness, damping, masses).
#define MANYRODS_MODEL_FIELDS(X)                                                                  \
  X(node_mass, 1, 0, 0, "[slots] kg: lumped node mass")                                          \
  X(node_inv_mass, 1, 0, 0, "[slots] 1/kg: 0 for clamped and ghost nodes")                       \
  X(elem_rest_length, 1, 1, 0, "[slots] m: rest length l̂")                                       \
  X(elem_stiffness, 3, 0, 0, "[3][slots] N: κ1·G·A, κ2·G·A, E·A (C_F)")                           \
  X(elem_rest_strain, 3, (i == 2), 0, "[3][slots] 1: V0 (e3 for a straight rod)")               \
  X(elem_tau, 3, 0, 0, "[3][slots] s: τS, τS, τE (V_F = C_F·diag τ)")                             \
  X(elem_inertia, 3, 0, 0, "[3][slots] kg·m: ρ·l̂·(I1, I2, I3)")                                   \
  X(elem_inv_inertia, 3, 0, 0, "[3][slots] 1/(kg·m): 0 for ghost elements")                      \
  X(vor_rest_length, 1, 1, 0, "[slots] m: Voronoi length D̂")                                     \
  X(vor_stiffness, 3, 0, 0, "[3][slots] N·m²: E·I1, E·I2, G·J_T (C_M)")                           \
  X(vor_rest_curvature, 3, 0, 0, "[3][slots] 1/m: U0")                                           \
  X(vor_tau, 3, 0, 0, "[3][slots] s: τE, τE, τS (V_M = C_M·diag τ)")

// The state: the only thing a checkpoint needs.
#define MANYRODS_STATE_FIELDS(X)                                                                   \
  X(node_x, 3, 0, 0, "[3][slots] m: node positions, lab frame")                                  \
  X(node_v, 3, 0, 0, "[3][slots] m/s: node velocities, lab frame")                               \
  X(elem_Q, 9, (i % 4 == 0), 0, "[9][slots] 1: frame, row-major, rows = directors d1, d2, d3")   \
  X(elem_w, 3, 0, 0, "[3][slots] rad/s: angular velocity, material components")                  \
  X(node_xc, 3, 0, 1,                                                                            \
    "[3][slots] m: float only, the round-off of node_x carried to the next drift "               \
    "(compensated summation, kernels/integrate.h kinematic_node)")

// Derived each step from the state; each array names the kernel that writes it.
#define MANYRODS_SCRATCH_FIELDS(X)                                                                 \
  X(elem_force, 3, 0, 0, "[3][slots] N: Qᵀn, lab frame — element_stage")                         \
  X(elem_couple, 3, 0, 0, "[3][slots] N·m: (Q e) × n — element_stage")                           \
  X(vor_moment, 3, 0, 0, "[3][slots] N·m: m̃, the J-corrected moment — voronoi_stage")            \
  X(vor_kxm, 3, 0, 0, "[3][slots] N·m: D̂ κ × m — voronoi_stage")

// Dead external loads in the lab frame, set by the user between steps.
#define MANYRODS_LOADS_FIELDS(X)                                                                   \
  X(node_force, 3, 0, 0, "[3][slots] N: point force on a node")                                  \
  X(elem_couple, 3, 0, 0, "[3][slots] N·m: couple on an element")

// A batch's fluid arrays (RodBatch::fluid, include/manyrods/batch.h
// FluidData), allocated by set_fluid only (zero at first; the node arrays
// lumped: ℓ_k is half the elements on either side):
// X(name, its member in the kernels' FluidView (kernels/fluid.h), components, "shape, unit: meaning").
// The storage, the allocation (host/core/model/fluid.cpp) and the view
// (host/core/step/fluid_stage.h) come from it.
#define MANYRODS_FLUID_FIELDS(X)                                                                    \
  X(node_cn, cn, 1, "[slots] N·s/m: c⊥ℓ, the linear drag across the rod")                           \
  X(node_ct, ct, 1, "[slots] N·s/m: c∥ℓ, the linear drag along it")                                 \
  X(node_qn, qn, 1, "[slots] kg/m: ½ρC⊥dℓ, the quadratic drag across it")                           \
  X(node_qt, qt, 1, "[slots] kg/m: ½ρC∥πdℓ, the quadratic drag along it")                           \
  X(node_buoyancy, buoyancy, 1, "[slots] kg: ρ_f A ℓ, the displaced fluid's mass")                  \
  X(node_half_left, half_left, 1, "[slots] m: l̂_{k−1}/2 (0 off the rod)")                           \
  X(node_half_right, half_right, 1, "[slots] m: l̂_k/2 (0 off the rod)")                             \
  X(node_v_saved, saved, 3, "[3][slots] m/s: the velocities before the kick (scratch)")            \
  X(node_wind, wind, 3, "[3][slots] m/s: the wind at the nodes, with turbulence (scratch)")

// A batch's per-slot contact arrays (RodBatch::contact, include/manyrods/contact.h
// ContactData), allocated by set_contact:
// X(type, name, components, fill, "shape, unit: meaning") and, for the
// ones the contact kernels read or write, their member in ContactView
// (kernels/contact.h). The storage, the allocation
// (host/core/model/contact.cpp) and the view (host/core/step/contact_stage.h)
// come from these lists; the candidate lists (slots × capacity) and the
// per-rod arrays are ContactData's own members.
#define MANYRODS_CONTACT_VIEW_FIELDS(X)                                                                         \
  X(T, elem_radius, elem_radius, 1, 0, "[slots] m: the element's contact radius (0: ghost)")                    \
  X(int, elem_rod, elem_rod, 1, -1, "[slots] the element's rod (−1: ghost)")                                    \
  X(int, elem_count, elem_count, 1, 0, "[slots] the element's contacts in range (mass splitting)")              \
  X(int, elem_count_lo, elem_count_lo, 1, 0, "[slots] of them acting on node k (s < 1)")                        \
  X(int, elem_count_hi, elem_count_hi, 1, 0, "[slots] of them acting on node k+1 (s > 0)")                      \
  X(int, elem_push, elem_push, 1, 0, "[slots] its rod–rod pairs in range that can push within the step")       \
  X(T, elem_p0, p0, 3, 0, "[3][slots] N·s: the impulse on node k from element k's contacts")                   \
  X(T, elem_p1, p1, 3, 0, "[3][slots] N·s: the impulse on node k+1")                                           \
  X(T, elem_l, l, 3, 0, "[3][slots] N·m·s: the couple impulse on element k (lab)")                              \
  X(T, elem_q0, q0, 3, 0, "[3][slots] N·s: as elem_p0, of the contacts met in the implicit solve")             \
  X(T, elem_q1, q1, 3, 0, "[3][slots] N·s: as elem_p1, of the contacts met in the implicit solve")             \
  X(T, work, work, 1, 0, "[slots] J: the contact impulses' work on slot k's node and element, summed")          \
  X(T, node_v_start, v_start, 3, 0, "[3][slots] m/s: node k's velocity at the step's start (the work's mean velocity)") \
  X(T, elem_w_start, w_start, 3, 0, "[3][slots] rad/s: element k's angular velocity (material) at the step's start") \
  X(T, node_v_solve, v_solve, 3, 0, "[3][slots] m/s: node k's velocity before the implicit solve (kernels/contact_solve.h)") \
  X(T, elem_w_solve, w_solve, 3, 0, "[3][slots] rad/s: element k's angular velocity before the implicit solve") \
  X(int, neighbour_count, neighbour_count, 1, 0, "[slots] the element's rod–rod candidates")
#define MANYRODS_CONTACT_OWN_FIELDS(X)                                                                          \
  X(T, node_x_ref, 3, 0, "[3][slots] m: node positions at the last rebuild of the candidate lists")             \
  X(T, elem_skin, 1, 0, "[slots] m: element k's reach s_k at the last build (partners with gap < s_a + s_b are listed)")

// The arrays a user reads and sets by name, one entry each:
// X(group, field, public name, "shape, unit: meaning"). The Python Batch's
// views (state read-only, loads writable), the C API's mr_state_view and
// mr_loads_view members (filled by name, checked by size when the C API
// compiles) and the HDF5 frames' datasets (fields::public_name) take their
// names from this list.
#define MANYRODS_PUBLIC_ARRAYS(X)                                                                             \
  X(state, node_x, node_position, "(3, slots) m: node positions, lab frame")                                   \
  X(state, node_v, node_velocity, "(3, slots) m/s: node velocities, lab frame")                                \
  X(state, elem_Q, element_directors, "(3, 3, slots) 1: frames, [i, :, k] = director d_(i+1) of slot k")       \
  X(state, elem_w, element_omega, "(3, slots) rad/s: angular velocities, material components")                 \
  X(loads, node_force, node_force, "(3, slots) N: dead point forces on the nodes, lab frame")                  \
  X(loads, elem_couple, element_couple, "(3, slots) N·m: dead couples on the elements, lab frame")

// Counting helpers (for byte estimates): arrays of a group for a batch of
// this precision.
#define MANYRODS_FIELD_ARRAYS(name, n, fill, float_only, doc) +(float_only ? (is_float ? n : 0) : n)
namespace manyrods::fields {
constexpr int model_arrays(bool is_float = false) { return 0 MANYRODS_MODEL_FIELDS(MANYRODS_FIELD_ARRAYS); }
constexpr int state_arrays(bool is_float) { return 0 MANYRODS_STATE_FIELDS(MANYRODS_FIELD_ARRAYS); }
constexpr int scratch_arrays(bool is_float = false) { return 0 MANYRODS_SCRATCH_FIELDS(MANYRODS_FIELD_ARRAYS); }
constexpr int loads_arrays(bool is_float = false) { return 0 MANYRODS_LOADS_FIELDS(MANYRODS_FIELD_ARRAYS); }
// The public name of a field of MANYRODS_PUBLIC_ARRAYS: public_name::node_x
// is "node_position".
namespace public_name {
#define MANYRODS_PUBLIC_NAME(group, field, name, doc) inline constexpr const char* field = #name;
MANYRODS_PUBLIC_ARRAYS(MANYRODS_PUBLIC_NAME)
#undef MANYRODS_PUBLIC_NAME
}  // namespace public_name
}  // namespace manyrods::fields
#undef MANYRODS_FIELD_ARRAYS
