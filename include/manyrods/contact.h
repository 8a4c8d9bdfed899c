// include/manyrods/contact.h — what rods touch: colliders (plane, sphere,
// capsule, a closed triangle mesh as a signed-distance grid) and each other
// (rod–rod and self contact), with Coulomb friction (docs/contact.md has the
// model, the contact law and its derivation).
//
//   set_contact(batch, spec)     colliders, rod–rod/self switches, friction,
//                                validated (InputError naming collider, rod, node)
//   contact_stats(batch[, rods]) contacts and deepest penetration now (of rods [begin, end))
//
// and step with Terms::colliders / Terms::rod_contact on (include/manyrods/terms.h).
//
// The contact law in one paragraph. Each contact (an element's centreline
// segment, swept by its radius, against a collider or another element) is a
// spring of stiffness k = Ω² m_c / h² and a dashpot c = 2 ζ Ω m_c / h on the
// gap g (distance minus the radii), where m_c is the contact's effective mass
// and h the step. It is integrated by backward Euler on the gap at the end of
// the step, so that its impulse is closed-form and the step is stable for any
// Ω: the user does not tune a penalty, and contact does not shrink the step.
// Friction is exact Coulomb on the same step's normal impulse: the contact
// point sticks while the impulse that stops it lies in the (possibly
// elliptic) cone μ_s λ, and slides with μ_k λ otherwise.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "manyrods/array.h"
#include "manyrods/drive.h"
#include "manyrods/fields.h"

namespace manyrods {

// Coulomb coefficients (≥ 0, kinetic ≤ static). The *_axial ones, when ≥ 0,
// apply along the rod's tangent and the others across it (an elliptic cone:
// snakes and crawlers); −1 = isotropic.
struct Friction {
  double static_coefficient = 0;
  double kinetic_coefficient = 0;
  double static_axial = -1;
  double kinetic_axial = -1;
};

// A signed-distance grid of a closed triangle mesh (negative inside), in the
// collider's body frame: φ at the nodes of a regular grid, trilinear between
// them (load_mesh_grid builds it, include/manyrods/mesh.h).
struct DistanceGrid {
  Vec3 origin{0, 0, 0};  // m, the node (0, 0, 0)
  double spacing = 0;    // m
  int n[3] = {0, 0, 0};  // nodes per axis
  std::vector<float> phi;  // [n2][n1][n0] m
  // the mesh it came from, for USD export
  std::vector<Vec3> vertices;
  std::vector<int> triangles;  // [3 × triangles]
};

enum class ColliderKind { plane, sphere, capsule, mesh };

// A rigid collider. Geometry in its body frame, placed in the lab by its
// motion (the rigid motions of driven roots, include/manyrods/drive.h; none:
// static, the body frame is the lab).
struct Collider {
  std::string name;
  ColliderKind kind = ColliderKind::plane;
  Vec3 point{0, 0, 0}, normal{0, 0, 1};  // plane: a point and the outward normal
  Vec3 center{0, 0, 0};                  // sphere
  Vec3 a{0, 0, 0}, b{0, 0, 0};           // capsule: the axis segment
  double radius = 0;                     // sphere, capsule
  std::shared_ptr<const DistanceGrid> grid;  // mesh
  Friction friction;
  std::shared_ptr<const RootMotion> motion;
};

// What a batch touches (set_contact).
struct ContactSpec {
  std::vector<Collider> colliders;
  bool rod_rod = false;     // contact between any two rods
  bool self = false;        // contact of a rod with itself (near elements where it kinks, docs/contact.md "Self contact")
  Friction friction;        // rod–rod and self, for rods without their own
  // per rod (empty, or one per rod): its own friction (a rod group's key),
  // combined with its partner's as docs/contact.md "Friction of a pair" says;
  // rod_has_friction[r] = 0: rod r takes `friction` against rods and the
  // collider's own against colliders
  std::vector<Friction> rod_friction;
  std::vector<char> rod_has_friction;
  // Ω = h √(k / m_c): how hard contacts are. Larger: less penetration and less
  // restitution (docs/contact.md "The contact law"); > 0.
  double hardness = 4;
  double damping_ratio = 0;  // ζ ≥ 0, added to backward Euler's own damping
  // rod–rod broad phase: the margin each element's list reaches beyond its
  // contact range (m; 0: half its contact radius, docs/contact.md), the
  // candidate capacity per element the lists start with, and the most they
  // grow to: a list that finds more candidates than the capacity grows them
  // all (the same lists, so the same step, as with that capacity from the
  // start); beyond max_capacity, or the machine's memory, it is an error.
  double skin = 0;
  int capacity = 64;
  int max_capacity = 4096;
};

// ---- the batch's contact data (RodBatch::contact; set_contact fills it) ----------
// Kernels read these arrays through plain pointers (kernels/contact.h);
// every array is indexed by slot like the batch's fields.

// A collider as the kernels see it during one step: its lab placement at the
// step's midpoint and the velocity field of its rigid motion over the step,
// v(p) = A (p − c) + u.
template <class T>
struct ColliderFrame {
  int kind = 0;                       // ColliderKind
  T p[3] = {}, q[3] = {}, n[3] = {};  // plane: point p, normal n; sphere: centre p; capsule: p–q
  T radius = 0;
  T R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, c[3] = {};  // body → lab: x = R X + c
  T A[9] = {}, u[3] = {};                          // velocity field
  int moving = 0;                                   // it has a motion (else A = 0, u = 0)
  T mu[4] = {};                                     // static, kinetic, static axial, kinetic axial
  // mesh: the grid in the body frame
  const float* phi = nullptr;
  int nx = 0, ny = 0, nz = 0;
  T origin[3] = {}, spacing = 0;
};

// One contact's impulse at the end of a step's contact solve (docs/contact.md
// "Contact inside the implicit solve"), kept for the next step's sweeps to
// start from where the same contact is found again (a warm start): the
// contact by its element slot k and what it touches — a collider (its
// index), an element k2 of the same rod (self) or an element kb of rod
// `partner` — its point s on the element (0 … 1), its unit normal and its
// impulse p (N·s, on the rod at k).
template <class T>
struct SolveImpulse {
  int k = -1, collider = -1, k2 = -1, kb = -1, partner = -1;
  T s = 0, n[3] = {}, p[3] = {};
};

// A collider contact's anchor in the static solve (friction; docs/model.md
// "Static equilibrium", Friction): rod node slot `node` sticks to the point X
// of collider `collider` (its body frame), pulled back to it tangentially
// up to the friction limit. x: the node where the last solve left it (an
// anchor whose node has moved since, by a step or by the user, is
// dropped: it belongs to another state).
struct StaticAnchor {
  int node = -1, collider = -1;
  double X[3] = {}, x[3] = {};
};

template <class T>
struct ContactData {
  bool on = false;  // set_contact was called
  ContactSpec spec;
  // per slot: include/manyrods/fields.h MANYRODS_CONTACT_VIEW_FIELDS and
  // MANYRODS_CONTACT_OWN_FIELDS (radius and rod, the contact stage's
  // scratch, the broad phase's reference positions and reaches)
#define MANYRODS_CONTACT_VIEW_MEMBER(type, name, view, n, fill, doc) \
  std::conditional_t<n == 1, Array<type>, std::array<Array<type>, n>> name;
#define MANYRODS_CONTACT_OWN_MEMBER(type, name, n, fill, doc) \
  std::conditional_t<n == 1, Array<type>, std::array<Array<type>, n>> name;
  MANYRODS_CONTACT_VIEW_FIELDS(MANYRODS_CONTACT_VIEW_MEMBER)
  MANYRODS_CONTACT_OWN_FIELDS(MANYRODS_CONTACT_OWN_MEMBER)
#undef MANYRODS_CONTACT_VIEW_MEMBER
#undef MANYRODS_CONTACT_OWN_MEMBER
  std::vector<T> rod_mu;  // [4 × rods] the rods' friction against rods; rod_mu_own[r]: set by the rod
  std::vector<int> rod_mu_own;
  std::vector<int> rod_stiff;  // [rods] 1: a stiff rod (RodSpec::stiff_implicit; kernels/contact.h element_side, apply_contact)
  // [2][rods] 1: the implicit solve steps the rod, [0] without and [1] with
  // the Kelvin–Voigt term solved (host/core/step/implicit_plan.h
  // needs_implicit_solve): its collider contacts are in the solve
  std::array<std::vector<int>, 2> rod_in_solve;
  std::vector<int> rod_near;  // [rods] elements |i − j| ≤ this apart touch at the tight-loop chord (kernels/contact.h near_contact_distance)
  // rod–rod broad phase (docs/contact.md "Finding rod–rod contacts")
  Array<int> neighbours;               // [slots × capacity] candidate partner slots of element k, in order
  int capacity = 0;                    // the lists' capacity now (spec.capacity, grown up to spec.max_capacity)
  std::int64_t list_growths = 0;       // times the lists grew
  std::vector<int> cell_start;  // the grid: cell i holds cell_slot[cell_start[i] .. cell_start[i+1])
  std::vector<int> cell_slot;
  double max_radius = 0;  // m: the rods' largest contact radius
  bool built = false;
  std::int64_t rebuilds = 0;
  // rod–rod contacts in the solve (docs/contact.md "Contact inside the
  // implicit solve"): the sweeps through the rods' contacts so far, the
  // steps they ran in, the most one step took, and the steps that ended
  // without converging (their moves stalled)
  std::int64_t solve_sweeps = 0, solve_steps = 0, solve_stalled = 0;
  int solve_sweeps_max = 0;
  // [rods] each rod's contacts' impulses at the end of its last contact
  // solve (empty: none acted; kept only from one step to the next): the
  // sweeps' first guess, not part of the answer (they converge to their
  // tolerance from any guess), but part of the state a checkpoint keeps,
  // so that a continued run goes on bit for bit
  std::vector<std::vector<SolveImpulse<T>>> solve_impulses;
  // [rods] each rod's collider contacts (node, collider) in the last static
  // solve, pressed or just touching, each with the point where it sticks
  // (host/core/analysis/static_colliders.h): the friction's memory, so
  // that a re-solve after a hold moves keeps where the rods rest; matched
  // to colliders by index (set_contact starts them afresh)
  std::vector<std::vector<StaticAnchor>> static_anchors;
};

// Contacts now (recomputed from the state; for outputs, not for the step).
struct ContactStats {
  std::int64_t contacts = 0;     // element–collider and element–element (each pair once) in touch, gap < 0
  double max_penetration = 0;    // m, the deepest overlap (≥ 0)
  int rod = -1, element = -1;    // where it is
  std::int64_t rebuilds = 0;     // rod–rod neighbour-list rebuilds so far
  int list_capacity = 0;         // the lists' capacity now, and how often they grew
  std::int64_t list_growths = 0;
  // rod–rod contacts in the solve: the sweeps through the rods' contacts so
  // far, the steps that ran them, the most in one step, the steps that did
  // not converge (the sweeps stalled)
  std::int64_t solve_sweeps = 0, solve_steps = 0, solve_stalled = 0;
  int solve_sweeps_max = 0;
};

template <class T>
class RodBatch;

// Gives the batch its colliders and contact switches (replacing earlier
// ones). Validates: friction ≥ 0 with kinetic ≤ static, hardness > 0,
// damping ratio ≥ 0, capacity ≥ 1, sphere/capsule radius > 0, a plane's
// normal ≠ 0, a mesh with its grid; no rod may start inside a collider
// (overlapping it by more than 1 % of its radius). InputError names the
// collider, the rod and the node.
template <class T>
void set_contact(RodBatch<T>& b, const ContactSpec& spec);

// Contacts and the deepest penetration of the current state (the colliders
// placed at the batch's time).
template <class T>
ContactStats contact_stats(const RodBatch<T>& b, int rod_begin = 0, int rod_end = -1);

}  // namespace manyrods
