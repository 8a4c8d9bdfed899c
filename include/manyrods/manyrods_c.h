/* include/manyrods/manyrods_c.h — the C API of manyrods, for host
 * applications (animation packages, game engines, plug-ins) and any language
 * with a C foreign-function interface. Library: libmanyrods_c.so (SONAME
 * libmanyrods_c.so.MR_ABI_VERSION), CMake target manyrods::c. Guide:
 * docs/c_api.md; example: examples/c/.
 *
 * Conventions.
 * - Handles are opaque (mr_batch). Every call that can fail returns an
 *   mr_status, MR_OK = 0; on failure mr_last_error() gives the message (the
 *   library's, naming what and where, e.g. a scene file's line), valid until
 *   this thread's next failing call. No C++ exception crosses the API.
 * - Settings and descriptions are plain structs filled with their defaults
 *   by mr_default_*() (so code written today keeps compiling when fields are
 *   added at the end: always start from the defaults).
 * - Units are SI. Positions are read as the host stores them: all nodes of
 *   all rods in rod order, x y z interleaved (mr_batch_copy_positions_*), or
 *   without a copy through the library's own arrays (mr_batch_state_view:
 *   one array per component, indexed by slot, each rod's nodes at
 *   consecutive slots, mr_batch_rod_slots).
 * - A batch is used by one thread at a time (the step itself runs on the
 *   threads mr_batch_set_threads gives it). Distinct batches are independent.
 * - Bit for bit, a batch made from a scene steps as `manyrods run` does.
 */
#ifndef MANYRODS_MANYRODS_C_H
#define MANYRODS_MANYRODS_C_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The version of this header; mr_version() gives the library's.
 * MR_VERSION = major * 10000 + minor * 100 + patch. A program checks
 * mr_abi_version() == MR_ABI_VERSION at start-up (the structs' layout). */
#define MR_VERSION_MAJOR 0
#define MR_VERSION_MINOR 1
#define MR_VERSION_PATCH 0
#define MR_VERSION (MR_VERSION_MAJOR * 10000 + MR_VERSION_MINOR * 100 + MR_VERSION_PATCH)
#define MR_ABI_VERSION 0

/* The library is built with hidden visibility: only MR_API names are exported. */
#if defined(__GNUC__)
#define MR_API __attribute__((visibility("default")))
#else
#define MR_API
#endif

typedef enum mr_status {
  MR_OK = 0,
  MR_ERROR_ARGUMENT = 1,    /* a null pointer, an index or count out of range, a bad value */
  MR_ERROR_INPUT = 2,       /* a scene file or rod description that is not valid */
  MR_ERROR_IO = 3,          /* a file that cannot be read or written */
  MR_ERROR_NON_FINITE = 4,  /* the state became non-finite (a step too large); the batch keeps the bad state */
  MR_ERROR_MEMORY = 5,      /* out of memory */
  MR_ERROR_INTERNAL = 6,    /* anything else (a bug: please report the message) */
  MR_ERROR_NO_EQUILIBRIUM = 7 /* mr_batch_solve_static found no equilibrium (Newton failed: a snap-through) */
} mr_status;

typedef enum mr_precision { MR_DOUBLE = 0, MR_FLOAT = 1 } mr_precision;

/* A held end of a rod. */
typedef enum mr_end { MR_END_FREE = 0, MR_END_CLAMPED = 1, MR_END_PINNED = 2 } mr_end;

/* Cross-sections (docs/model.md "Sections"). */
typedef enum mr_shape { MR_CIRCLE = 0, MR_ELLIPSE = 1, MR_RECTANGLE = 2, MR_HOLLOW_CIRCLE = 3 } mr_shape;

typedef struct mr_batch mr_batch;

/* The message of this thread's last failing call ("" when none). */
MR_API const char* mr_last_error(void);
/* The library's version (as MR_VERSION), its text ("0.1.0"), its ABI. */
MR_API int mr_version(void);
MR_API const char* mr_version_string(void);
MR_API int mr_abi_version(void);

/* ---- batches from scene files ---------------------------------------------- */

/* The scene's batch (docs/scenes.md): its rods, initial state, colliders,
 * contact, fluid and integrator, in the scene's precision. */
MR_API mr_status mr_batch_create_from_scene(const char* path, mr_batch** out);

/* ---- batches from rods described in C --------------------------------------- */

/* One rod. nodes: (elements + 1) points, x y z interleaved, the rod's shape,
 * which is also its rest shape (unstressed). frames: elements frames, each 9
 * numbers row-major with rows d1, d2, d3 (d3 along the element), or NULL
 * for twist-free frames carried along the rod by parallel transport from
 * first_normal (any vector not along the first element; 0, 0, 0: the
 * coordinate axis least aligned with it). */
typedef struct mr_rod_desc {
  int elements;
  const double* nodes;
  const double* frames;
  double first_normal[3];
  mr_shape shape;
  double section_a;       /* circle: radius; ellipse: semi-axis along d1; rectangle: width along d1; hollow: outer radius */
  double section_b;       /* ellipse: semi-axis along d2; rectangle: height along d2; hollow: inner radius */
  double density;         /* kg/m³ */
  double youngs_modulus;  /* Pa */
  double poisson_ratio;   /* or shear_modulus: exactly one of them (the other NaN) */
  double shear_modulus;   /* Pa */
  /* Kelvin–Voigt retardation times (s): shear and extension; 0, 0: undamped */
  double tau_shear;
  double tau_extension;
  mr_end root;
  mr_end tip;
  /* Host-driven ends: the held end follows the named driver's pose
   * (mr_batch_set_driver_pose); NULL: static. Rods naming one driver share it. */
  const char* root_driver;
  const char* tip_driver;
  int stiff;              /* 1: stiff rod (hair, wire; docs/model.md "Stiff rods") */
  const double* section_scale; /* a tapered rod: `elements` factors > 0, each element's section scaled by its
                                  (area x f^2, second moments x f^4, contact radius x f); NULL: uniform */
  int preload;            /* 1: gravity preload: the rest shape solved so that the rod as given stands still
                             under gravity (mr_batch_preload again after setting loads; docs/model.md) */
} mr_rod_desc;

typedef struct mr_batch_settings {
  mr_precision precision;
  double gravity[3];      /* m/s² */
} mr_batch_settings;

/* 10 elements of a 1 cm radius circular section, E = 1 MPa, ν = 0.5,
 * ρ = 1000 kg/m³, undamped, root clamped, tip free, frames by parallel
 * transport from a chosen first_normal (0, 0, 0), nodes NULL (set them). */
MR_API void mr_default_rod_desc(mr_rod_desc* rod);
/* Double precision, gravity (0, 0, −9.81). */
MR_API void mr_default_batch_settings(mr_batch_settings* settings);
/* A batch of `count` rods; MR_ERROR_INPUT naming the rod for an invalid one. */
MR_API mr_status mr_batch_create(const mr_rod_desc* rods, size_t count, const mr_batch_settings* settings,
                                 mr_batch** out);

MR_API void mr_batch_destroy(mr_batch* b); /* NULL: nothing */

/* ---- stepping ------------------------------------------------------------------ */

/* `count` steps of length dt (s). MR_ERROR_NON_FINITE names the first bad
 * rod and step. A dt above the stable step (mr_batch_stable_dt) is refused
 * before any step, as `manyrods run` refuses it: MR_ERROR_INPUT with the
 * limit and the safe value (0.9 of the limit), unless mr_batch_set_force_dt. */
MR_API mr_status mr_batch_step(mr_batch* b, double dt, int count);
/* 1: step at any dt (the stable-step guard of mr_batch_step off); 0: guarded
 * (the default; a scene with simulation.force_dt = true starts at 1). */
MR_API mr_status mr_batch_set_force_dt(mr_batch* b, int force);
/* The step the scene asks for (its dt, or "auto": 0.9 of the stable step, or
 * of the stiff rods' accuracy step where that is smaller, aligned to its
 * frames); for rods described in C the same without the frames. */
MR_API double mr_batch_dt(const mr_batch* b);
/* The largest stable step of the current state (s): Position Verlet's
 * elastic limit (the implicit Kelvin–Voigt solve adds none; stiff rods add
 * none: infinity for a batch of stiff rods only). */
MR_API double mr_batch_stable_dt(const mr_batch* b);
/* Threads the step runs on (default 1; the results do not depend on it). */
MR_API mr_status mr_batch_set_threads(mr_batch* b, int threads);
MR_API double mr_batch_time(const mr_batch* b);
MR_API int64_t mr_batch_steps(const mr_batch* b);
/* A hash of the whole state (the one `manyrods run` prints). */
MR_API uint64_t mr_batch_state_hash(const mr_batch* b);

typedef struct mr_energies {
  double kinetic, elastic, potential, dissipation, contact_work;
} mr_energies;
/* Of one rod, or of all (rod = -1). */
MR_API mr_status mr_batch_energies(const mr_batch* b, int rod, mr_energies* out);

/* A manyrods output file with this state (`manyrods run --restart` continues a scene's). */
MR_API mr_status mr_batch_save(const mr_batch* b, const char* path);

/* ---- statics ---------------------------------------------------------------------- */

typedef struct mr_static_result {
  int converged;                           /* 1: the rods are in equilibrium */
  int iterations, load_increments;         /* Newton iterations, load increments (all rods) */
  double residual_force, residual_couple;  /* N, N m: the largest left on a free node / element */
  int failed_rod, failed_node;             /* without equilibrium: the first such rod, its worst node (else -1) */
  double load_reached;                     /* its load fraction reached */
  int mechanism;                           /* 1: it is free to move under its loads */
  int warm_rods;                           /* rods already in equilibrium under their loads (a re-solve after a
                                              hold moved): only their holds walked */
  int sticking, slipping;                  /* collider contacts with friction: nodes stuck where they first
                                              touched, nodes at the friction limit */
} mr_static_result;
/* The static equilibrium of the batch's rods under its loads, gravity and
 * buoyancy, the colliders' push and friction and the rods' contact (a
 * double-precision batch without wind), every
 * driven hold at its pose at `time` (s; NAN: the holds stay where they are),
 * found by Newton's method along an adaptive load path from the current
 * state; velocities become zero, and with a time the batch's time becomes it.
 * `result` (may be NULL) is filled in every case. MR_ERROR_INPUT for a float
 * batch, wind, a bad time, and a rod that is a mechanism under its
 * loads (a free rod in gravity); MR_ERROR_NO_EQUILIBRIUM when Newton finds
 * none (the message names the rod, node and residual; the rods are left
 * where the solve stopped). */
MR_API mr_status mr_batch_solve_static(mr_batch* b, double time, mr_static_result* result);

/* Gravity preload again: the rest shapes of the rods with `preload` solved
 * so that the rods as they are now stand still under gravity and the loads
 * as they are now (mr_batch_create did it for the rods as given). `rods`,
 * `contacts` (may be NULL): the rods preloaded and the collider touches that
 * carry load. MR_ERROR_INPUT naming the rod and node where no rest shape
 * does (a free rod in gravity), or naming the rod where the equilibrium it
 * makes is an unstable one (a long hair standing up); every rest shape is
 * then left as it was. */
MR_API mr_status mr_batch_preload(mr_batch* b, int* rods, int* contacts);

typedef struct mr_hold_reaction {
  int rod, node;     /* the held node */
  int clamped;       /* 1: a clamp (it exerts a moment too), 0: a pin */
  double force[3];   /* N, lab frame: what the hold exerts on its rod */
  double moment[3];  /* N m */
} mr_hold_reaction;
/* The reactions at every held node (rod by rod, root to tip), at rest: at
 * a static equilibrium the connector loads, which balance the loads on
 * each rod. *count: on entry the capacity of `out` (0 with out NULL: just
 * count), on return the number of holds; MR_ERROR_ARGUMENT when the
 * capacity is short. Double-precision batches. */
MR_API mr_status mr_batch_hold_reactions(const mr_batch* b, mr_hold_reaction* out, size_t* count);

/* ---- reading the state ----------------------------------------------------------- */

MR_API size_t mr_batch_rod_count(const mr_batch* b);
/* All rods' nodes (each rod: elements + 1). */
MR_API size_t mr_batch_node_count(const mr_batch* b);
/* Rod `rod`'s first node in the all-nodes order and its node count. */
MR_API mr_status mr_batch_rod_nodes(const mr_batch* b, size_t rod, size_t* first, size_t* count);

/* All nodes, x y z interleaved, into xyz (room for `count` nodes, 3 × count
 * numbers); MR_ERROR_ARGUMENT when count < mr_batch_node_count. */
MR_API mr_status mr_batch_copy_positions_f32(const mr_batch* b, float* xyz, size_t count);
MR_API mr_status mr_batch_copy_positions_f64(const mr_batch* b, double* xyz, size_t count);

/* The library's own state arrays, without a copy: pointers into the batch,
 * valid until mr_batch_destroy, their values updated by every step.
 * Each field is `components` arrays of `slots` numbers (float when precision
 * is MR_FLOAT, else double), component c of slot k at
 * base[c * component_stride + k]. Rod r's node i is at slot
 * first_slot + i (mr_batch_rod_slots), its element i at the same slot. Slots
 * between rods hold no node. Read-only: the step owns them. */
typedef struct mr_state_view {
  mr_precision precision;
  size_t slots;
  size_t component_stride;
  const void* node_position;      /* 3 components, m */
  const void* node_velocity;      /* 3, m/s */
  const void* element_directors;  /* 9: component 3 i + j is director d_i's lab component j */
  const void* element_omega;      /* 3, angular velocity in the element's material frame, rad/s */
} mr_state_view;
MR_API mr_status mr_batch_state_view(const mr_batch* b, mr_state_view* out);
/* Rod `rod`'s first node slot and its element count. */
MR_API mr_status mr_batch_rod_slots(const mr_batch* b, size_t rod, size_t* first_slot, int* elements);

/* External loads the host sets (wind, a hand), held from step to step until
 * changed: node forces (N) and element couples (N·m), 3 components each in
 * the lab frame, laid out as the state (mr_state_view). Writable; zero at
 * creation (a scene's dead loads aside). */
typedef struct mr_loads_view {
  mr_precision precision;
  size_t slots;
  size_t component_stride;
  void* node_force;
  void* element_couple;
} mr_loads_view;
MR_API mr_status mr_batch_loads_view(mr_batch* b, mr_loads_view* out);

/* ---- poses the host sets each frame ---------------------------------------------- */

/* p ↦ rotation · p + translation; rotation row-major, a proper rotation. */
typedef struct mr_pose {
  double rotation[9];
  double translation[3];
} mr_pose;
MR_API void mr_pose_identity(mr_pose* pose);

/* Drivers: the host motions of the batch (a scene's motion = "host" tables,
 * by name; mr_rod_desc root_driver/tip_driver): held roots, tips, interior
 * nodes and colliders that follow them. Each starts at the identity pose. */
MR_API size_t mr_batch_driver_count(const mr_batch* b);
/* Its name (valid until mr_batch_destroy), NULL for an index out of range. */
MR_API const char* mr_batch_driver_name(const mr_batch* b, size_t driver);
MR_API mr_status mr_batch_find_driver(const mr_batch* b, const char* name, size_t* driver);
/* The driver moves from its pose at the batch's time to `pose` at `time`
 * (≥ the batch's time; translation linear, rotation along the shortest arc)
 * and holds it after: a host sets, once per frame, the pose of the frame's
 * end, then steps to it. time = the batch's time jumps there (for a first
 * placement only: the rods see an infinite velocity). */
MR_API mr_status mr_batch_set_driver_pose(mr_batch* b, size_t driver, const mr_pose* pose, double time);
/* The same move turning about `pivot` (a point of the driver's body, in the
 * coordinates of its identity pose): the pose maps x to
 * R (x − pivot) + pivot + translation, and during the move the pivot's image
 * travels on a straight line (a head turned about its neck keeps the neck in
 * place while it turns, where mr_batch_set_driver_pose moves the origin's). */
MR_API mr_status mr_batch_set_driver_pose_about(mr_batch* b, size_t driver, const mr_pose* pose,
                                                const double pivot[3], double time);

#ifdef __cplusplus
}
#endif

#endif /* MANYRODS_MANYRODS_C_H */
