// include/manyrods/batch.h — rods, and the batch that holds many of them in
// structure-of-arrays form (docs/architecture.md "Data: Model, State, Scratch, Loads").
//
// Slot layout. Rod r with n_r elements owns the slots [o_r, o_r + n_r + 2):
//
//   slot        o_r      o_r+1     o_r+2   …   o_r+n_r   o_r+n_r+1
//   element     ghost    e0        e1      …   e_{n−1}   ghost (tip)
//   node        ghost    node 0    node 1  …   node n−1  node n
//   Voronoi     ghost    root      v0      …   v_{n−2}   tip (ghost)
//
// Node k lies between elements k−1 and k; Voronoi point k joins elements k−1
// and k. The root ghost element holds the clamp frame of a clamped rod, and
// the root Voronoi point (length l̂_0/2, the stiffness of element 0) ties
// element 0 to it; for a free root its stiffness is zero. A clamped tip is the
// mirror image: the tip ghost element holds its clamp frame and the tip
// Voronoi point (length l̂_{n−1}/2) ties element n−1 to it. Ghost entries have
// zero mass, stiffness and inverse inertia, so a kernel sweeps all slots with
// no branch at rod boundaries and ghosts never change the result. The slot
// count is padded to a multiple of the kernel block (64).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "manyrods/array.h"
#include "manyrods/contact.h"
#include "manyrods/drive.h"
#include "manyrods/fields.h"
#include "manyrods/fluid.h"
#include "manyrods/material.h"

namespace manyrods {

// Vec3, Mat3 (row-major, rows = directors d1, d2, d3): include/manyrods/drive.h

// An interior node held in place (pinned: node fixed, frames free) or in
// place and orientation (clamped: the node and the frames of the two
// elements that meet there, i.e. the clamp grips the half elements on either
// side), optionally following a rigid motion (driven: the node, and the held
// frames, follow it as a driven root does; include/manyrods/drive.h).
enum class HoldKind { pinned, clamped };
struct NodeHold {
  int node = 1;  // 1 … n−1 (the root and the tip have their own fields)
  HoldKind kind = HoldKind::clamped;
  std::shared_ptr<const RootMotion> motion;  // null: static
};

// One rod as the user describes it (double precision, SI units).
struct RodSpec {
  std::string name;
  std::vector<Vec3> nodes;   // [n+1] centerline
  std::vector<Mat3> frames;  // [n] element frames, rows = d1, d2, d3
  Section section;
  Material material;
  Damping damping;
  // Multiplies C_F = (κ1GA, κ2GA, EA), e.g. 1e4 for a nearly inextensible,
  // unshearable rod (the elastica case of docs/validation.md). The viscous V_F scales with it.
  double shear_stretch_scale = 1;
  // Held ends (docs/scenes.md "Constraints"). Clamped: the node and the
  // frame at that end are held (the clamp frame, in the ghost element, is
  // tied to the end element by half a Voronoi spring); pinned: the node is
  // held and the frame is free. At most one of clamped/pinned per end.
  bool clamped_root = false;          // node 0 fixed, frame fixed at s = 0
  bool pinned_root = false;           // node 0 fixed, frame free
  // Node n fixed, frame fixed at s = L (a cable between two connectors, a
  // fiber held at both ends), or (pinned_tip) node n fixed, frame free.
  bool clamped_tip = false;
  bool pinned_tip = false;
  std::optional<Mat3> tip_frame;      // clamp frame at s = L (default: frames[n−1])
  // Interior nodes 1 … n−1 held (NodeHold): pinned, clamped, or driven.
  std::vector<NodeHold> holds;
  // Stiff rods (hair, wire: shear, stretch and twist far stiffer than
  // bending): integrate shear, stretch and twist linearly implicitly so that
  // the stable step is the bending one (≈ 1e-4 s and more for hair instead of
  // 4e-8 s). First order in the stiff components, which it damps; see
  // kernels/viscous_implicit.h and README "Stiff rods". Position Verlet only.
  // A stiff rod takes any holds; holds that stretch it give a stretch that
  // depends on the step (docs/model.md "Held nodes in the implicit solve").
  bool stiff_implicit = false;
  std::optional<Mat3> root_frame;     // clamp frame at s = 0 (default: frames[0])
  // A driven root (include/manyrods/drive.h): the held root (node 0 and, if
  // clamped, the clamp frame) follows this rigid motion of the given root;
  // needs clamped_root or pinned_root. Rods may share one motion.
  std::shared_ptr<const RootMotion> root_motion;
  // A driven tip: the same for node n and the tip's clamp frame; needs
  // clamped_tip or pinned_tip. A rotation about the rod's axis twists it.
  std::shared_ptr<const RootMotion> tip_motion;
  // Drag and buoyancy coefficients in a fluid (include/manyrods/fluid.h;
  // they act only when the batch has a fluid, RodBatch::set_fluid).
  Drag drag;
  // Rest shape. Empty = the given geometry is the rest shape (unstressed).
  std::vector<Vec3> rest_curvature;   // [n−1] U0 at interior Voronoi points, 1/m
  std::vector<Vec3> rest_strain;      // [n] V0, rest lengths are the given ones
  // A tapered rod: element e's section is `section` scaled by
  // section_scale[e] in every dimension (area × f², second moments and
  // torsion constant × f⁴, contact radius × f; a hair thicker at its root
  // than at its tip). Stiffness, mass, rotary inertia, contact radius, drag
  // and buoyancy follow the local section; a joint's bending and twisting
  // stiffness is the length-weighted mean of its two elements'. Empty:
  // uniform (f = 1). [n] numbers > 0.
  std::vector<double> section_scale;
  // Gravity preload: the rest shape (from the two above, or the geometry)
  // is then changed so that the rod as given is its static equilibrium
  // under gravity, its loads and the colliders it rests on
  // (include/manyrods/statics.h preload_rest_shape, which the scene layer,
  // AnyBatch::from_rods and Python call when the batch is built).
  bool preload = false;
  // Initial motion. Empty = at rest.
  std::vector<Vec3> velocities;          // [n+1] m/s
  std::vector<Vec3> angular_velocities;  // [n] rad/s, material components

  // A straight rod: d3 along `direction`, d1 along `normal` made orthogonal.
  static RodSpec straight(const Vec3& start, const Vec3& direction, const Vec3& normal,
                          double length, int elements);
  // A rod along a polyline with the given frames.
  static RodSpec polyline(std::vector<Vec3> nodes, std::vector<Mat3> frames);
  // Frames for a polyline: d3 along each segment, d1 carried by parallel
  // transport from `first_normal` (a twist-free, "Bishop" frame); a zero
  // first_normal: normal_across(the first element). InputError for
  // coincident nodes and a first_normal along the first element.
  static std::vector<Mat3> parallel_transport_frames(const std::vector<Vec3>& nodes,
                                                     const Vec3& first_normal);
  // The coordinate axis least aligned with `direction` (a normal that is
  // never parallel to it).
  static Vec3 normal_across(const Vec3& direction);
  int elements() const { return static_cast<int>(frames.size()); }
};

// A rod's end hold as one value, a HoldKind as for interior holds (nullopt:
// free): what the pairs (clamped_root, pinned_root) and (clamped_tip,
// pinned_tip) say. Scene files, Python and the C API translate their hold
// names through these two.
enum class RodEnd { root, tip };
inline std::optional<HoldKind> end_hold(const RodSpec& r, RodEnd end) {
  const bool root = end == RodEnd::root;
  if (root ? r.clamped_root : r.clamped_tip) return HoldKind::clamped;
  if (root ? r.pinned_root : r.pinned_tip) return HoldKind::pinned;
  return std::nullopt;
}
inline void set_end_hold(RodSpec& r, RodEnd end, std::optional<HoldKind> kind) {
  bool& clamped = end == RodEnd::root ? r.clamped_root : r.clamped_tip;
  bool& pinned = end == RodEnd::root ? r.pinned_root : r.pinned_tip;
  clamped = kind == HoldKind::clamped;
  pinned = kind == HoldKind::pinned;
}

// A run of slots holding whole rods [rod_begin, rod_end), 64-aligned. A
// "fused" segment is small enough (≤ kSegmentSlots) to stay in L2 while the
// step runs all its stages on it; a rod longer than that gets a segment of
// its own, stepped stage by stage (docs/architecture.md "The segment
// schedule").
inline constexpr int kSegmentSlots = 2048;

struct Segment {
  int begin = 0, end = 0;          // slots
  int rod_begin = 0, rod_end = 0;  // rods
  bool fused = true;
  bool stiff = false;  // its rods are stiff (RodSpec::stiff_implicit): a segment holds only one kind
  int driven_begin = 0, driven_end = 0;  // its entries of RodBatch::driven
  // its groups of the implicit-solve plans, [0] without and [1] with the
  // Kelvin–Voigt term (StepWorkspace::solve_plan, host/core/step/workspace.h)
  int groups_begin[2] = {0, 0}, groups_end[2] = {0, 0};
};

// A held node on a rigid motion (a driven root, tip or interior hold): its
// motion (index into RodBatch::motions), its node's slot and the slots of
// the frames it holds (the clamp frame in the ghost element at a root or
// tip, pinned or not, which gives the motion's Ω to the implicit solve; the
// two elements around a clamped interior node; −1: none), and the node and
// frames it was built with (the pose-identity ones). `reference`: the
// implicit solve of its rod runs relative to this hold's rigid motion
// (host/core/step/implicit_solve.h): a driven root, else the one driven hold of a
// stiff rod.
struct DrivenHold {
  int rod = 0;
  int motion = 0;
  int node = 0;
  int frame[2] = {-1, -1};
  Vec3 x0{};
  Mat3 q0[2]{};
  bool reference = false;
};

struct RodInfo {
  std::string name;
  int elements = 0;
  int offset = 0;  // o_r, first slot
  bool clamped_root = false;
  bool clamped_tip = false;
  bool stiff_implicit = false;  // RodSpec::stiff_implicit
  bool preload = false;         // RodSpec::preload
  bool damped = false;          // some retardation time > 0
  bool driven = false;          // some hold on a motion (entries of RodBatch::driven)
  // held unknowns with prescribed, possibly non-zero, velocities besides the
  // reference hold (DrivenHold::reference): its implicit solve keeps them
  // (host/core/step/implicit_plan.h, SolveGroup::lift)
  bool prescribed = false;
  // its first driven hold is the reference of the implicit solve
  // (DrivenHold::reference): a driven root, or a stiff rod's only hold
  bool driven_reference = false;
  ElasticConstants elastic{};
  SectionProperties section{};
  RetardationTimes tau{};
  double contact_radius = 0;  // m: the radius its centreline is swept by in contact (include/manyrods/contact.h)
  // RodSpec::section_scale (empty: uniform); element e's contact radius is
  // contact_radius × its scale (element_radius)
  std::vector<double> section_scale;
  double scale(int e) const { return section_scale.empty() ? 1.0 : section_scale[std::size_t(e)]; }
  double element_radius(int e) const { return contact_radius * scale(e); }
  Drag drag{};                // RodSpec::drag
};

// One field of the lists in include/manyrods/fields.h: one array, or one
// array per component.
template <class T, int N>
using FieldArray = std::conditional_t<N == 1, Array<T>, std::array<Array<T>, N>>;

#define MANYRODS_STORAGE_MEMBER(name, n, fill, float_only, doc) FieldArray<T, n> name;

// The batch's fluid (set_fluid fills it; include/manyrods/fluid.h): its
// node arrays are include/manyrods/fields.h MANYRODS_FLUID_FIELDS, allocated
// only when a fluid is set (a batch without one holds none).
template <class T>
struct FluidData {
  bool on = false;
  bool linear = false, quadratic = false, buoyancy = false;  // which parts any rod has
  Fluid spec;
  std::vector<TurbulentMode> modes;  // from spec.turbulence
#define MANYRODS_FLUID_MEMBER(name, view, n, doc) FieldArray<T, n> name;
  MANYRODS_FLUID_FIELDS(MANYRODS_FLUID_MEMBER)
#undef MANYRODS_FLUID_MEMBER
};

// Constant during a run (include/manyrods/fields.h MANYRODS_MODEL_FIELDS has
// every array with its shape and unit).
template <class T>
struct Model {
  MANYRODS_MODEL_FIELDS(MANYRODS_STORAGE_MEMBER)
  std::array<T, 3> gravity{T(0), T(0), T(0)};  // m/s²
};

// The only thing a checkpoint needs (MANYRODS_STATE_FIELDS); state_hash
// hashes its real entries. node_xc is allocated for float batches only (empty
// for double); code that sets node_x directly should zero it.
template <class T>
struct State {
  MANYRODS_STATE_FIELDS(MANYRODS_STORAGE_MEMBER)
  double time = 0;
  std::int64_t steps = 0;
};

// Derived each step (MANYRODS_SCRATCH_FIELDS says which kernel writes what).
template <class T>
struct Scratch {
  MANYRODS_SCRATCH_FIELDS(MANYRODS_STORAGE_MEMBER)
};

// Dead external loads in the lab frame, set by the user between steps
// (MANYRODS_LOADS_FIELDS).
template <class T>
struct Loads {
  MANYRODS_LOADS_FIELDS(MANYRODS_STORAGE_MEMBER)
};

#undef MANYRODS_STORAGE_MEMBER

// The kernels' views of the arrays (kernels/views.h; code that launches
// kernels includes it).
template <class T> struct ModelView;
template <class T> struct StateView;
template <class T> struct ConstStateView;
template <class T> struct ScratchView;
template <class T> struct ConstScratchView;
template <class T> struct LoadsView;
template <class T> struct ImplicitScratchView;

// An owning, copyable handle of the step's workspace (defined in
// host/core/step/workspace.h; a copy copies it).
template <class T> struct StepWorkspace;
template <class T>
class WorkspaceHandle {
 public:
  WorkspaceHandle();
  ~WorkspaceHandle();
  WorkspaceHandle(const WorkspaceHandle& o);
  WorkspaceHandle(WorkspaceHandle&& o) noexcept;
  WorkspaceHandle& operator=(const WorkspaceHandle& o);
  WorkspaceHandle& operator=(WorkspaceHandle&& o) noexcept;
  StepWorkspace<T>& operator*() const { return *p_; }
  StepWorkspace<T>* operator->() const { return p_.get(); }

 private:
  std::unique_ptr<StepWorkspace<T>> p_;
};

// The fluid of the batch's rods (include/manyrods/fluid.h); validates it and
// the rods' drag coefficients (InputError naming the field or rod).
template <class T> class RodBatch;
template <class T>
void set_fluid(RodBatch<T>& b, const Fluid& fluid);

template <class T>
class RodBatch {
 public:
  using value_type = T;  // float or double
  Model<T> model;
  State<T> state;
  Scratch<T> scratch;
  Loads<T> loads;
  std::vector<RodInfo> rods;
  std::vector<Segment> segments;  // cover [0, slots), in order
  // Driven holds (include/manyrods/drive.h), by rod index (root, interior
  // nodes in order, tip); the distinct motions.
  std::vector<DrivenHold> driven;
  std::vector<std::shared_ptr<const RootMotion>> motions;
  // The step's own data: the implicit solve's plans and buffers, the
  // fallback kernels' flags (host/core/step/workspace.h). Not API: opaque
  // here, copied with the batch.
  WorkspaceHandle<T> workspace;
  // What the rods touch (set_contact, include/manyrods/contact.h); off by default.
  ContactData<T> contact;
  // The fluid the rods are in (set_fluid, include/manyrods/fluid.h); off by default.
  FluidData<T> fluid;

  int rod_count() const { return static_cast<int>(rods.size()); }
  int slots() const { return slots_; }
  std::int64_t element_count() const { return element_count_; }
  int elements(int rod) const { return rods[rod].elements; }
  int node_index(int rod, int node) const { return rods[rod].offset + 1 + node; }
  int elem_index(int rod, int element) const { return rods[rod].offset + 1 + element; }
  // interior Voronoi point j ∈ [0, n−1) joins elements j and j+1
  int vor_index(int rod, int j) const { return rods[rod].offset + 2 + j; }
  int root_vor_index(int rod) const { return rods[rod].offset + 1; }
  int tip_vor_index(int rod) const { return rods[rod].offset + rods[rod].elements + 1; }

  Vec3 position(int rod, int node) const;
  Vec3 velocity(int rod, int node) const;
  Mat3 frame(int rod, int element) const;
  Vec3 angular_velocity(int rod, int element) const;  // material components
  void set_velocity(int rod, int node, const Vec3& v);
  void set_angular_velocity(int rod, int element, const Vec3& w);
  void set_node_force(int rod, int node, const Vec3& f);         // N, lab frame
  void set_element_couple(int rod, int element, const Vec3& c);  // N·m, lab frame
  void set_gravity(const Vec3& g);
  // Bytes held by model, state, scratch and loads.
  std::size_t bytes() const;

  ModelView<T> model_view() const;
  StateView<T> state_view();
  ConstStateView<T> state_view() const;
  ScratchView<T> scratch_view();
  ConstScratchView<T> scratch_view() const;
  LoadsView<T> loads_view() const;
  // Elimination buffer of thread t (< threads) for the rods of one segment:
  // cell c of a rod starting at slot `first` of segment r is entry
  // first − r.begin + c. Allocates on first use (not thread-safe: call
  // before any parallel region, with the largest thread count).
  // (min_cells: at least that many cells per thread, e.g. for a lane group)
  void reserve_implicit_scratch(int threads, int min_cells = 0);
  ImplicitScratchView<T> implicit_scratch_view(int thread, int cell_offset);
  // Thread t's double buffer (a float batch with stiff rods, after
  // reserve_implicit_scratch).
  ImplicitScratchView<double> wide_implicit_scratch_view(int thread);
  bool any_stiff() const { return any_stiff_; }
  // Elements of the rods whose implicit solve with the Kelvin–Voigt term is
  // cut into partitions (a long rod alone in its lane group).
  std::int64_t partitioned_elements() const;
  // The step's fluid stage runs (set_fluid with some rod that has drag or buoyancy).
  bool any_fluid() const { return fluid.on; }

  // Used by build_batch.
  void allocate(int slots, std::int64_t elements);

 private:
  int slots_ = 0;
  std::int64_t element_count_ = 0;
  bool any_stiff_ = false;
  template <class U>
  friend RodBatch<U> build_batch(const std::vector<RodSpec>&, const Vec3&);
};

// Validates every rod (InputError naming rod and field) and lays them out.
template <class T>
RodBatch<T> build_batch(const std::vector<RodSpec>& rods, const Vec3& gravity = {0, 0, 0});

// FNV-1a (64-bit) over the bytes of the real (non-ghost) state entries in rod
// order: each node's x and v (and, for float, node_xc), then each element's
// Q and ω; not time and steps. Equal hashes mean bit-identical states (up to
// the hash's collisions); a one-ulp change of one entry changes it. Used by
// the tests, the benchmarks and `manyrods run`. A new State field is added
// here by hand (docs/architecture.md "Adding a field").
template <class T>
std::uint64_t state_hash(const RodBatch<T>& b);

extern template class RodBatch<float>;
extern template class RodBatch<double>;
extern template RodBatch<float> build_batch<float>(const std::vector<RodSpec>&, const Vec3&);
extern template RodBatch<double> build_batch<double>(const std::vector<RodSpec>&, const Vec3&);
extern template std::uint64_t state_hash<float>(const RodBatch<float>&);
extern template std::uint64_t state_hash<double>(const RodBatch<double>&);

}  // namespace manyrods
