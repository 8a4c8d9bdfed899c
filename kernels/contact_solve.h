// kernels/contact_solve.h — collider and self contacts inside the implicit
// per-rod solve (docs/contact.md "Contact inside the implicit solve").
//
// A rod the implicit solve steps (stiff, or damped with the Kelvin–Voigt
// term solved) meets the colliders through the same linear system as its
// stiff and viscous forces, so that a push on a node moves the element's
// other node and turns its frame as the stiff stretch and shear require,
// instead of straining them (a stage after the solve pushes single nodes:
// the stiff modes then store the push as elastic energy).
//
// The rod's system A u⁺ = y (A = M + hD, plus h²K for a stiff rod; kernels/
// viscous_implicit.h) is factored once; its free solution is u_f. Contact i
// of element k at s (kernels/contact.h collider_touches: gap g, normal n, the
// collider's surface velocity v_p) acts on the velocity of its centreline
// point, v_i = J_i u = (1 − s) v_k + s v_{k+1}, with an impulse p_i there:
//   u⁺ = u_f + A⁻¹ Σ_i J_iᵀ p_i,   v_i = v_{f,i} + Σ_j W_ij p_j,
//   W_ij = J_i A⁻¹ J_jᵀ (3×3 blocks: the rod's Delassus operator; columns
//   from the factors, kernels/viscous_implicit_lanes.h
//   viscous_solve_factored_lanes).
// A self contact (element k at s against element k2 > k of the same rod at
// t, kernels/contact.h pair_geometry; n from the partner's point to k's)
// acts on the relative velocity of its two points,
//   v_i = J_i u = (1 − s) v_k + s v_{k+1} − (1 − t) v_k2 − t v_{k2+1},
// +p on the first, −p on the second, v_p = 0: both sides are in the rod's
// system, so it is solved exactly, as a collider contact is.
// A contact with another rod (element k at s against element kb at t of a
// rod the solve also steps, each side with its own record of the pair) acts
// on the relative velocity of the two rods' points, one impulse, +p on this
// rod and −p on the partner. Each rod's Delassus operator is its own; the
// pair is solved with both sides' blocks and the partner's point velocity
// without this impulse, v_b,rest:
//   v_i − v_b = v_rest − v_b,rest + (W_ii + W_b) p,                        (S4)
// i.e. (S1)–(S3) with v_p = v_b,rest and W_ii + W_b for W_ii (W_b: the
// partner's W_jj at its side of the pair). The Gauss–Seidel sweeps then run
// over all the rods' contacts together (host/core/step/contact_solve.h
// rod_contacts_in_solve): after each update both rods' contact velocities
// follow through their own W, so the partner's motion is the one its
// solve gives, and momentum is kept exactly.
// Each contact obeys the normal law of kernels/contact.h (C1) on the point's
// end-of-step velocity: with b = Ω² + 2ζΩ and a the contact's mass (its
// share of its nodes, 1/a = (1 − s)² c_k/m_k + s² c_{k+1}/m_{k+1}, c_j the
// contacts on node j: the mass splitting of kernels/contact.h),
//   λ = max(0, a (−Ω² g/h − b n·(v⁺ − v_p)))                              (S1)
// and Coulomb friction, exactly: a sticking contact has no tangential slip,
// (I − n nᵀ)(v⁺ − v_p) = 0, while its tangential impulse stays in the static
// cone |P_t| ≤ μ_s λ (elliptic with axial coefficients, kernels/contact.h
// in_elliptic_cone); otherwise it slides with the kinetic impulse
// P_t = −μ_k λ ŝ against its slip ŝ (axial coefficients: the
// maximal-dissipation direction). Sticking, (S1) and the stick condition are
// one symmetric system for the impulse p = λ n + P_t,
//   (W_ii + n nᵀ/(a b)) p = −(v_rest − v_p) − (Ω² g/(h b)) n,              (S2)
// v_rest = v_i − W_ii p_i the point's velocity without its own impulse.
// Sliding gives λ from (S1) with p = λ n + λ d (d the kinetic impulse per
// unit λ, its direction from the stick impulse's, then from the slip):
//   λ = (−Ω² g/(h b) − n·(v_rest − v_p)) / (nᵀ W_ii (n + d) + 1/(a b)).     (S3)
// The contacts of one rod are solved together by projected block
// Gauss–Seidel in this small space (each contact's (S1)–(S3) with the
// others' impulses fixed, in a fixed order, until no contact's velocity
// moves by more than kContactSweepTolerance of their scale), and the rod takes the
// impulses through one more solve with the factors: the implicit response
// of every node and frame. No penalty, no iteration of the rod's solve.
//
// The work. Their work over the step is P·(v_n + v_{n+1})/2 at the point
// (kernels/contact.h apply_contact): the contact work of the energy budget.
//
// reads: the contact (its law), its Delassus block, its point's velocity
// writes: the contact's impulse (contact_local_impulse's result)
#pragma once

#include "kernels/contact.h"

namespace manyrods {

// The sweeps end when none moves its contact point's velocity by more than
// this part of the contacts' velocity scale (their largest approach speed
// plus the normal law's push-out speed Ω² |g|/(h b)), or after
// kMaxContactSweeps: 1e-6 (float 1e-4) is far below the step's first-order
// error in the velocities (a sweep converges linearly, by a factor 0.3–0.5
// per sweep on a stiff hair lying on a head: ~15 sweeps).
template <class T>
inline constexpr T kContactSweepTolerance = sizeof(T) < sizeof(double) ? T(1e-4) : T(1e-6);
inline constexpr int kMaxContactSweeps = 200;
// Sweeps that cycle end too: where the largest move of a sweep has not
// halved in kContactStallSweeps sweeps. Gauss–Seidel on exact Coulomb
// friction need not converge. A sliding contact's direction follows its
// slip, which at slip speeds near zero (a cable settling on a floor: 1e-4 m/s)
// turns with every neighbour's update; and where μ_s > μ_k a contact can have
// no consistent law, its stick impulse needing more than μ_s λ while its
// kinetic one lets the neighbours take up enough that it sticks again. More
// sweeps do not improve such a cycle (a cable pile's rods ran to the cap
// of 200 on a third of their solves, moving 1e-4 to 1e-1 of the scale per
// sweep to the end). The last sweep's impulses stand: each is in its cone
// at its last update, and their work is accounted as any other's. A steady
// linear convergence halves in 20 sweeps at any rate below 0.966 per sweep.
inline constexpr int kContactStallSweeps = 20;

template <class T>
struct SolveContact {
  int k = -1;                  // the element's slot (nodes k, k+1)
  T s = 0;                     // the point on it, 0 … 1
  int k2 = -1;                 // self contact: the partner element's slot (> k, same rod); −1: a collider
  int collider = -1;           // a collider contact: the collider's index
  T t = 0;                     // self contact: the point on the partner, 0 … 1
  T a = 0;                     // kg: the contact's mass (S1); 0: both nodes held (no contact)
  T gap = 0;                   // m: the contact's gap (< 0: overlap)
  vec3<T> n{0, 0, 1};          // unit normal, from the collider (partner point) to the rod's point
  vec3<T> vp{0, 0, 0};         // m/s: the collider's surface velocity (0 for a self contact)
  vec3<T> axis{0, 0, 1};       // the element's unit tangent (axial friction)
  T mu[4] = {0, 0, -1, -1};    // static, kinetic, static axial, kinetic axial (kernels/contact.h pair_mu)
  vec3<T> p{0, 0, 0};          // N·s: its impulse
  vec3<T> v{0, 0, 0};          // m/s: its point's velocity with every impulse so far
  bool in = false;             // in the solve (its Delassus column is known)
  // rod–rod (S4): the partner element's slot (another rod's), its rod, this
  // pair's place in the partner's contacts, this side's share of the
  // contact's compliance (1/a = own + the partner's); and this point's
  // velocity where it is not in the solve (the last response's)
  int kb = -1, partner = -1, twin = -1;
  T own_compliance = 0;
  vec3<T> v_now{0, 0, 0};
};

namespace contact_solve_detail {

template <class T>
MANYRODS_HD inline vec3<T> tangential(vec3<T> v, vec3<T> n) {
  return v - dot(n, v) * n;
}

// The axial unit vector in the tangent plane (kernels/contact.h axial_tangent).
template <class T>
MANYRODS_HD inline vec3<T> axial_direction(const SolveContact<T>& c) {
  return axial_tangent(c.axis, c.n, c.mu);
}

// Whether the tangential impulse p lies in the static cone of λ.
template <class T>
MANYRODS_HD inline bool in_static_cone(const SolveContact<T>& c, vec3<T> p, T lam) {
  const vec3<T> ea = axial_direction(c);
  if (ea.x == T(0) && ea.y == T(0) && ea.z == T(0)) return norm(p) <= c.mu[0] * lam;
  return in_elliptic_cone(dot(p, ea), dot(p, cross(c.n, ea)), c.mu[2], c.mu[0], lam);
}

// The kinetic Coulomb impulse per unit λ against the slip direction `slip`
// (tangential, need not be unit): −μ_k ŝ, or with axial coefficients the
// maximal-dissipation direction −(μ_a² s_a ê_a + μ_t² s_t ê_t)/√(μ_a² s_a² + μ_t² s_t²).
template <class T>
MANYRODS_HD inline vec3<T> kinetic_direction(const SolveContact<T>& c, vec3<T> slip) {
  const vec3<T> zero{T(0), T(0), T(0)};
  const T len = norm(slip);
  if (!(len > T(0))) return zero;
  const vec3<T> ea = axial_direction(c);
  if (ea.x == T(0) && ea.y == T(0) && ea.z == T(0)) return (-c.mu[1] / len) * slip;
  return elliptic_kinetic(slip, ea, cross(c.n, ea), c.mu[3] >= T(0) ? c.mu[3] : c.mu[1], c.mu[1], T(-1));
}

// x = E⁻¹ r for a symmetric 3×3 E (Cholesky); false, x untouched, where E
// is not positive definite (a contact point that cannot slide: on a held
// node, whose W_ii has no tangential part).
template <class T>
MANYRODS_HD inline bool spd3_solve(const mat3<T>& e, vec3<T> r, vec3<T>& x) {
  using std::sqrt;
  const T d0 = e.m[0];
  if (!(d0 > T(0))) return false;
  const T l00 = sqrt(d0);
  const T l10 = e.m[3] / l00, l20 = e.m[6] / l00;
  const T d1 = e.m[4] - l10 * l10;
  if (!(d1 > T(0))) return false;
  const T l11 = sqrt(d1);
  const T l21 = (e.m[7] - l20 * l10) / l11;
  const T d2 = e.m[8] - l20 * l20 - l21 * l21;
  if (!(d2 > T(0))) return false;
  const T l22 = sqrt(d2);
  const T y0 = r.x / l00, y1 = (r.y - l10 * y0) / l11, y2 = (r.z - l20 * y0 - l21 * y1) / l22;
  const T x2 = y2 / l22, x1 = (y1 - l21 * x2) / l11, x0 = (y0 - l10 * x1 - l20 * x2) / l00;
  x = {x0, x1, x2};
  return true;
}

}  // namespace contact_solve_detail

// The velocity of the contact's centreline point, J u = (1 − s) v_k + s v_{k+1};
// of a self contact, relative to the partner's point:
// J u = (1 − s) v_k + s v_{k+1} − (1 − t) v_k2 − t v_{k2+1}.
template <class T>
MANYRODS_HD inline vec3<T> point_velocity(const SolveContact<T>& c, const T* const v[3]) {
  const vec3<T> own = (T(1) - c.s) * load3(v, c.k) + c.s * load3(v, c.k + 1);
  if (c.k2 < 0) return own;
  return own - ((T(1) - c.t) * load3(v, c.k2) + c.t * load3(v, c.k2 + 1));
}

// Whether contact c acts on its own at its point's velocity v, with no
// impulse of its own: (S1) gives λ > 0, g + h (b/Ω²) n·(v − v_p) < 0.
template <class T>
MANYRODS_HD inline bool contact_acts(const SolveContact<T>& c, vec3<T> v, T h, T omega, T zeta) {
  const T b = omega * omega + T(2) * zeta * omega;
  return c.gap + h * (b / (omega * omega)) * dot(c.n, v - c.vp) < T(0);
}

// Contact c's impulse (S1–S3) for the point velocity v_rest without it and
// its Delassus block w (symmetric, W_ii).
template <class T>
MANYRODS_HD inline vec3<T> contact_local_impulse(const SolveContact<T>& c, const mat3<T>& w, vec3<T> v_rest, T h,
                                                 T omega, T zeta) {
  using namespace contact_solve_detail;
  const vec3<T> zero{T(0), T(0), T(0)};
  const T b = omega * omega + T(2) * zeta * omega;
  const T ic = T(1) / (c.a * b);                 // the normal law's compliance 1/(a b)
  const vec3<T> rel = v_rest - c.vp;
  const T rn = -omega * omega * c.gap / (h * b) - dot(c.n, rel);  // (S1) with λ = 0, in velocity
  // frictionless (or the separation test): p = λ n
  const T lam0 = rn / (dot(c.n, mul(w, c.n)) + ic);
  if (!(lam0 > T(0))) return zero;
  if (!(c.mu[0] > T(0) || c.mu[2] > T(0))) return lam0 * c.n;
  // sticking (S2)
  mat3<T> e = w;
  const T n3[3] = {c.n.x, c.n.y, c.n.z};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) e.m[3 * i + j] += ic * n3[i] * n3[j];
  vec3<T> ps;
  if (!spd3_solve(e, (-T(1)) * rel + (rn + dot(c.n, rel)) * c.n, ps)) return lam0 * c.n;  // cannot slide
  const T ls = dot(c.n, ps);
  const vec3<T> pts = tangential(ps, c.n);
  if (ls > T(0) && in_static_cone(c, pts, ls)) return ps;
  // sliding (S3): the kinetic impulse against the slip, its direction first
  // that of the stick impulse's, then the slip's (twice)
  vec3<T> d = kinetic_direction(c, (-T(1)) * pts);
  T lam = lam0;
  for (int it = 0; it < 3; ++it) {
    const T den = dot(c.n, mul(w, c.n + d)) + ic;
    lam = den > T(0) ? rn / den : lam0;
    if (!(lam > T(0))) return zero;
    if (it == 2) break;
    const vec3<T> slip = tangential(rel + mul(w, lam * (c.n + d)), c.n);
    const vec3<T> dn = kinetic_direction(c, slip);
    if (dn.x == T(0) && dn.y == T(0) && dn.z == T(0)) break;
    d = dn;
  }
  return lam * (c.n + d);
}

}  // namespace manyrods
