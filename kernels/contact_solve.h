// kernels/contact_solve.h — collider contacts inside the implicit per-rod
// solve (docs/contact.md "Contact inside the implicit solve").
//
// A rod the implicit solve steps (stiff, or damped with the Kelvin–Voigt
// term solved) meets the colliders in the same linear system as its stiff
// and viscous forces, so that a push on a node moves the element's other
// node and turns its frame as the stiff stretch and shear require, instead
// of straining them (a stage after the solve pushes single nodes: the stiff
// modes then store the push as elastic energy).
//
// The contacts. Every contact of element k at s (kernels/contact.h
// collider_touches: its gap g, normal n, the collider's velocity v_p at the
// surface point) acts on the velocity of its centreline point,
// v_c = (1 − s) v_k + s v_{k+1} (J = [(1 − s) I, s I]): its block K enters
// the system as JᵀKJ, (1 − s)² K and s² K on the nodes' diagonal blocks and
// s (1 − s) K between them, which the block-tridiagonal system already has
// (node k's row, node k+1's column). Its mass a is the contact's share of
// its nodes, 1/a = (1 − s)² c_k/m_k + s² c_{k+1}/m_{k+1} with c_j the
// contacts on node j (the mass splitting of kernels/contact.h; a held node
// lends at most what the element's middle would). The contact's rotation
// (rolling) is not in the system: a rod the solve steps does not roll at a
// collider.
//
// The normal law is that of kernels/contact.h (C1), on the node's velocity
// at the end of the step: with b = Ω² + 2ζΩ, the impulse
//   λ = a (−Ω² g/h − b n·(v⁺ − v_p))                                     (S1)
// enters the node's row of (M + hD) u⁺ = M u⁻ + Σ P as the block a b n nᵀ
// on the left and a (−Ω² g/h + b n·v_p) n on the right. A contact is active
// while λ ≥ 0; it is switched on when g + h (b/Ω²) n·(v⁺ − v_p) < 0 and
// off when λ < 0, and the rod solved again (an active-set iteration).
//
// Friction, Coulomb. A sticking contact adds the tangential penalty
// a β (I − n nᵀ) with the carried impulse f_t on the right:
//   P_t = f_t − a β (I − n nᵀ)(v⁺ − v_p)                                (S2)
// and f_t ← P_t after each solve (an augmented Lagrangian: the slip left
// falls by ~1/(1 + β) per solve, β = kStickPenalty). When P_t leaves the
// static cone (|P_t| > μ_s λ, elliptic with axial coefficients), the
// contact slides, and its friction is a tangential damper whose force is
// the kinetic Coulomb force of the last solve's λ and slip v_t:
//   P_t = −C v_t⁺,  C = μ_k λ/|v_t| (I − n nᵀ)                           (S3)
// (with axial coefficients C = λ (μ_a² ê_a ê_aᵀ + μ_t² ê_t ê_tᵀ)/√(μ_a² v_a² + μ_t² v_t²),
// the maximal-dissipation direction), capped at the sticking penalty a β
// (a slip that small is a stick). The projection onto the cone is lagged
// one solve, as IPC's lagged friction, but a damper never reverses the
// slip it resists: a sliding contact only takes energy, whatever the
// iterate. C starts from the stick's a β scaled by μ_k λ/|P_t|, and is
// updated after each solve. A contact that let go and came back in one
// step's iteration stays on for the rest of it (against cycling: the
// pull it may then give is small, and in its work). The iteration ends when no
// contact changed its state and the next solve would move their impulses
// by less than a tolerance of their size (kSlideTolerance,
// kStickTolerance), or after kMaxContactSolves solves.
//
// The work. The impulses of the last solve are those the rod took; their
// work over the step is P·(v_n + v_{n+1})/2 (kernels/contact.h
// apply_contact): the contact work of the energy budget.
//
// reads: the contact (its law and state), its point's velocity after a
// solve  writes: the contact's state (solve_contact_update), its block and
// right-hand side (solve_contact_terms)
#pragma once

#include "kernels/contact.h"

namespace manyrods {

enum class ContactMode : int { off = 0, stick = 1, slide = 2 };

// The tangential penalty β of a sticking contact, in units of its mass per
// step (S2): 1e6 in double (the slip left is ~1e-6 of the step's, after
// one solve), 1e2 in float (whose 24 bits a larger β would take), and the
// iteration's limit.
template <class T>
inline constexpr T kStickPenalty = sizeof(T) < sizeof(double) ? T(1e2) : T(1e6);
// The iteration ends when a solve would move a sliding contact's impulse by
// less than this part of it (the lagged λ and slip direction converge
// slowly: 1e-3 is well inside the step's first-order error) and a sticking
// one's by less than 1e-5 (float: 1e-2, 1e-3).
template <class T>
inline constexpr T kSlideTolerance = sizeof(T) < sizeof(double) ? T(1e-2) : T(1e-3);
template <class T>
inline constexpr T kStickTolerance = sizeof(T) < sizeof(double) ? T(1e-3) : T(1e-5);
inline constexpr int kMaxContactSolves = 32;

template <class T>
struct SolveContact {
  int k = -1;                  // the element's slot (nodes k, k+1)
  T s = 0;                     // the point on it, 0 … 1
  ContactMode mode = ContactMode::off;
  T a = 0;                     // kg: the contact's mass (S1)
  T gap = 0;                   // m: the contact's gap (< 0: overlap)
  vec3<T> n{0, 0, 1};          // unit normal, from the collider to the rod
  vec3<T> vp{0, 0, 0};         // m/s: the collider's surface velocity (in the solve's frame)
  vec3<T> axis{0, 0, 1};       // the element's unit tangent (axial friction)
  T mu[4] = {0, 0, -1, -1};    // static, kinetic, static axial, kinetic axial (kernels/contact.h pair_mu)
  vec3<T> ft{0, 0, 0};         // N·s: the carried tangential impulse (S2)
  T lam = 0;                   // N·s: the normal impulse of the last solve
  vec3<T> p{0, 0, 0};          // N·s: the whole impulse of the last solve (λ n + P_t)
  T ca = 0, ct = 0;            // kg: a sliding contact's damper C (S3), along ê_a and across (isotropic: equal)
  bool released = false;       // let go once in this step's iteration (if it comes back, it stays)
};

namespace contact_solve_detail {

template <class T>
MANYRODS_HD inline vec3<T> tangential(vec3<T> v, vec3<T> n) {
  return v - dot(n, v) * n;
}

// The axial unit vector in the tangent plane, or zero when the contact is
// isotropic (mu[2] < 0) or the axis is along n.
template <class T>
MANYRODS_HD inline vec3<T> axial_direction(const SolveContact<T>& c) {
  const vec3<T> zero{T(0), T(0), T(0)};
  if (c.mu[2] < T(0)) return zero;
  const vec3<T> ea = tangential(c.axis, c.n);
  const T len = norm(ea);
  return len > T(1e-6) ? (T(1) / len) * ea : zero;
}

// Whether the tangential impulse p lies in the static cone of λ.
template <class T>
MANYRODS_HD inline bool in_static_cone(const SolveContact<T>& c, vec3<T> p, T lam) {
  const vec3<T> ea = axial_direction(c);
  if (ea.x == T(0) && ea.y == T(0) && ea.z == T(0)) return norm(p) <= c.mu[0] * lam;
  return in_elliptic_cone(dot(p, ea), dot(p, cross(c.n, ea)), c.mu[2], c.mu[0], lam);
}

// The kinetic Coulomb impulse of λ against the slip direction `slip`
// (tangential, need not be unit): −μ_k λ ŝ, or with axial coefficients the
// maximal-dissipation direction −λ (μ_a² s_a ê_a + μ_t² s_t ê_t)/√(μ_a² s_a² + μ_t² s_t²).
template <class T>
MANYRODS_HD inline vec3<T> kinetic_impulse(const SolveContact<T>& c, vec3<T> slip, T lam) {
  const vec3<T> zero{T(0), T(0), T(0)};
  const T len = norm(slip);
  if (!(len > T(0)) || !(lam > T(0))) return zero;
  const vec3<T> ea = axial_direction(c);
  if (ea.x == T(0) && ea.y == T(0) && ea.z == T(0)) return (-c.mu[1] * lam / len) * slip;
  const vec3<T> et = cross(c.n, ea);
  const T mka = c.mu[3] >= T(0) ? c.mu[3] : c.mu[1], mkt = c.mu[1];
  const T sa = dot(slip, ea), st = dot(slip, et);
  const T d = norm(vec3<T>{mka * sa, mkt * st, T(0)});
  if (!(d > T(0))) return zero;
  return (-lam / d) * (mka * mka * sa * ea + mkt * mkt * st * et);
}

}  // namespace contact_solve_detail

// The velocity of the contact's centreline point, (1 − s) v_k + s v_{k+1}.
template <class T>
MANYRODS_HD inline vec3<T> point_velocity(const SolveContact<T>& c, const T* const v[3]) {
  return (T(1) - c.s) * load3(v, c.k) + c.s * load3(v, c.k + 1);
}

template <class T>
MANYRODS_HD inline T abs_diff(T x, T y) {
  return x > y ? x - y : y - x;
}

// Whether the contact has friction at all (else it never sticks).
template <class T>
MANYRODS_HD inline bool has_friction(const SolveContact<T>& c) {
  return c.mu[0] > T(0) || c.mu[2] > T(0);
}

// The contact's block K (symmetric: xx xy xz yy yz zz) and right-hand side r
// for its point's velocity, added to k6 and r3 (S1, S2).
template <class T>
MANYRODS_HD inline void solve_contact_terms(const SolveContact<T>& c, T h, T omega, T zeta, T k6[6], T r3[3]) {
  if (c.mode == ContactMode::off) return;
  const T b = omega * omega + T(2) * zeta * omega;
  const vec3<T> n = c.n;
  const T kn = c.a * b;
  const vec3<T> rn = (c.a * (-omega * omega * c.gap / h + b * dot(n, c.vp))) * n;
  // the tangential block: c_a ê_a ê_aᵀ + c_t (I − n nᵀ − ê_a ê_aᵀ)
  T ka = T(0), kt = T(0);
  vec3<T> rt{T(0), T(0), T(0)};
  if (c.mode == ContactMode::stick) {
    ka = kt = c.a * kStickPenalty<T>;
    rt = c.ft;
  } else if (c.mode == ContactMode::slide) {
    ka = c.ca;
    kt = c.ct;
  }
  const vec3<T> ea = contact_solve_detail::axial_direction(c);
  const vec3<T> vpt = contact_solve_detail::tangential(c.vp, n);
  rt = rt + kt * vpt + ((ka - kt) * dot(ea, vpt)) * ea;
  const T nn[6] = {n.x * n.x, n.x * n.y, n.x * n.z, n.y * n.y, n.y * n.z, n.z * n.z};
  const T aa[6] = {ea.x * ea.x, ea.x * ea.y, ea.x * ea.z, ea.y * ea.y, ea.y * ea.z, ea.z * ea.z};
  const T id[6] = {T(1), T(0), T(0), T(1), T(0), T(1)};
  for (int i = 0; i < 6; ++i) k6[i] += kn * nn[i] + kt * (id[i] - nn[i]) + (ka - kt) * aa[i];
  r3[0] += rn.x + rt.x;
  r3[1] += rn.y + rt.y;
  r3[2] += rn.z + rt.z;
}

// After a solve that gave the contact point the velocity v (the solve's frame): the
// impulse the contact gave (S1, S2) into c.lam and c.p, and its next state.
// Returns whether it changed state or the next solve would move its
// impulse by more than the tolerance (the iteration goes on).
template <class T>
MANYRODS_HD inline bool solve_contact_update(SolveContact<T>& c, vec3<T> v, T h, T omega, T zeta) {
  using namespace contact_solve_detail;
  const T b = omega * omega + T(2) * zeta * omega;
  const vec3<T> rel = v - c.vp;
  const T vn = dot(c.n, rel);
  const vec3<T> vt = tangential(rel, c.n);
  const vec3<T> zero{T(0), T(0), T(0)};
  if (c.mode == ContactMode::off) {
    c.lam = T(0);
    c.p = zero;
    if (!(c.gap + h * (b / (omega * omega)) * vn < T(0))) return false;
    c.mode = has_friction(c) ? ContactMode::stick : ContactMode::slide;
    c.ft = zero;
    return true;
  }
  c.lam = c.a * (-omega * omega * c.gap / h - b * vn);
  const vec3<T> ea = axial_direction(c);
  vec3<T> pt = c.ft;
  if (c.mode == ContactMode::stick) pt = pt - (c.a * kStickPenalty<T>) * vt;
  if (c.mode == ContactMode::slide) pt = (-c.ct) * vt + ((c.ct - c.ca) * dot(ea, vt)) * ea;
  c.p = c.lam * c.n + pt;
  // pulling: the contact lets go, unless it did so before in this step's
  // iteration and came back (against cycling: it then stays on, its small
  // pull recorded in its work)
  if (c.lam < T(0) && !c.released) {
    c.mode = ContactMode::off;
    c.ft = zero;
    c.released = true;
    return true;
  }
  if (!has_friction(c)) return false;  // frictionless: slides with C = 0
  const T cap = c.a * kStickPenalty<T>;
  if (c.mode == ContactMode::stick) {
    if (!in_static_cone(c, pt, c.lam)) {
      // slides: the stick's damping scaled to the kinetic impulse
      c.mode = ContactMode::slide;
      const T f = norm(kinetic_impulse(c, -pt, c.lam)), p = norm(pt);
      c.ca = c.ct = p > T(0) ? cap * f / p : cap;
      c.ft = zero;
      return true;
    }
    // the next solve would move the carried impulse by ~|P_t − f_t|/β
    const bool moved = norm(pt - c.ft) > kStickPenalty<T> * kStickTolerance<T> * (norm(pt) + c.mu[0] * c.lam);
    c.ft = pt;
    return moved;
  }
  // sliding: the damper of this slip and λ (S3)
  T ca = cap, ct = cap;
  const T va = dot(ea, vt), vv = norm(vt - va * ea);
  const T mka = c.mu[3] >= T(0) ? c.mu[3] : c.mu[1], mkt = c.mu[1];
  const bool axial = ea.x != T(0) || ea.y != T(0) || ea.z != T(0);
  const T d = axial ? norm(vec3<T>{mka * va, mkt * vv, T(0)}) : mkt * norm(vt);
  if (!(c.lam > T(0))) {
    ca = ct = T(0);  // (a contact that stays on while it pulls has no friction)
  } else if (d > T(0)) {
    ct = mkt * mkt * c.lam / d;
    ca = axial ? mka * mka * c.lam / d : ct;
  }
  ca = ca < cap ? ca : cap;
  ct = ct < cap ? ct : cap;
  const bool moved = abs_diff(ca, c.ca) > kSlideTolerance<T> * (ca + c.ca) ||
                     abs_diff(ct, c.ct) > kSlideTolerance<T> * (ct + c.ct);
  c.ca = ca;
  c.ct = ct;
  return moved;
}

}  // namespace manyrods
