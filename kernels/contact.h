// kernels/contact.h — the contact kernels: where an element touches a
// collider or another element, and the impulse of each contact (docs/contact.md).
//
// Geometry. Element k is the segment x_k → x_{k+1} swept by its radius r_k
// (a circle's radius; other sections: the circumscribed radius). A contact
// is the point of the centreline q = (1 − s) x_k + s x_{k+1} closest to the
// partner, the unit normal n from the partner towards the rod, and the gap
// g = distance − radii (< 0: overlap):
//   plane (point P, normal n): one contact at each end, g_i = n·(x_i − P) − r
//     (an element lying on it is a line contact carried by both nodes; a
//     single point weighted between the ends left a tilted end's overlap
//     unresisted);
//   sphere (c, R): s from projecting c on the segment, g = |q − c| − R − r;
//   capsule (a–b, R) and another element: the closest points of two segments
//     (closest_segments), g = |q − q'| − R − r;
//   mesh (grid φ): one contact at each end, and one at s = ½ where it is
//     deeper than both, g = φ(q) − r, n = ∇φ/|∇φ|.
//
// The contact law (docs/contact.md "The contact law"). With the contact's
// effective mass m_c (below), the step h, the hardness Ω and the damping
// ratio ζ, the spring k = Ω² m_c/h² and dashpot c = 2ζΩ m_c/h act on the gap
// at the END of the step, g + h v_n⁺ (backward Euler), v_n = n·(v_rod − v_partner)
// at the contact point. The normal impulse λ = h·(−k (g + h v_n⁺) − c v_n⁺)
// with v_n⁺ = v_n + λ/m_c, solved in closed form:
//   λ = max(0, −m_c (Ω² g/h + (Ω² + 2ζΩ) v_n) / (1 + Ω² + 2ζΩ)).        (C1)
// It is zero unless the end-of-step gap would be negative (a contact that
// approaches within one step is caught before it overlaps: no tunnelling at
// any speed through a collider thicker than the radius).
//
// Friction, exact Coulomb on the same step's λ. The impulse P that stops the
// contact point's tangential slip v_t solves C P = −v_t in the tangent plane,
// C the contact point's compliance (3×3: translation and, through the lever
// ρ = −r n from the centreline to the surface, rotation of the element
// about its axis: rolling, see element_side). It
// is taken if it lies in the cone, |P| ≤ μ_s λ (elliptic with axial
// coefficients: (P_a/μ_sa)² + (P_t/μ_st)² ≤ λ²); otherwise the contact
// slides with P = −μ_k λ v̂_t (elliptic: −λ (μ_a² v_a ê_a + μ_t² v_t ê_t) /
// √(μ_a² v_a² + μ_t² v_t²), the maximal-dissipation direction). P acts at the
// surface point: the nodes get (1 − s)P and sP, the element the component
// of the couple ρ × P about its axis d3.
//
// Effective mass and mass splitting (Jacobi). Every contact is solved with
// the partners frozen at the stage's start, and all impulses are applied
// together. A node touched by c contacts lends each 1/c of its mass
// (c = the contacts in range of its two elements that act on it: those at
// s < 1 of element k and at s > 0 of element k−1), an element 1/c of its
// inertia; then the impulses of contacts sharing a node add up to what one
// contact with the whole mass would give (a rod lying flat stops exactly):
//   1/m_c = Σ_sides [(1 − s)² c_k/m_k + s² c_{k+1}/m_{k+1}].
//
// Pairs of elements are computed in a canonical order (lower slot first) and
// the other side takes −P: the two sides of a pair get bit-identical,
// opposite impulses (momentum is conserved to round-off). Everything is
// gathered: element k writes only its own accumulators, node k only itself.
//
// reads: model (masses, inertia), state (x, v, Q, ω), contact data
// writes: contact.elem_count (contact_count), contact.elem_p0, elem_p1,
//   elem_l (contact_impulses), state.node_v,
//   elem_w and contact.work (apply_contact), contact.v_start, w_start
//   (save_start_velocities)
#pragma once

#include "kernels/views.h"
#include "manyrods/contact.h"

namespace manyrods {

// The kernels' view of RodBatch::contact (include/manyrods/contact.h).
template <class T>
struct ContactView {
  const ColliderFrame<T>* colliders = nullptr;
  int collider_count = 0;
  const T* elem_radius = nullptr;
  const int* elem_rod = nullptr;
  const int* rod_near = nullptr;  // [rods] ContactData::rod_near
  const T* rod_mu = nullptr;  // [4 × rods]
  const int* rod_mu_own = nullptr;
  const int* rod_stiff = nullptr;  // [rods] ContactData::rod_stiff
  // [rods] 1: the rod meets the colliders inside the implicit solve
  // (kernels/contact_solve.h): ContactData::rod_in_solve of the step's solve
  const int* rod_in_solve = nullptr;
  MANYRODS_HD bool colliders_in_solve(int rod) const { return rod_in_solve[rod] != 0; }
  // 1: the step has self contact (Terms::rod_contact, ContactSpec::self), and
  // the rods the solve steps meet themselves there too, not in the stage
  int self_in_solve = 0;
  MANYRODS_HD bool self_solved(int rod) const { return self_in_solve != 0 && rod_in_solve[rod] != 0; }
  // 1: the step has rod–rod contact (Terms::rod_contact, ContactSpec::rod_rod),
  // and two rods the solve steps meet each other there (kernels/
  // contact_solve.h, the partner's motion predicted), not in the stage
  int rods_in_solve = 0;
  MANYRODS_HD bool pair_solved(int ra, int rb) const {
    return rods_in_solve != 0 && ra != rb && rod_in_solve[ra] != 0 && rod_in_solve[rb] != 0;
  }
  // the pair of elements of rods ra, rb that the solve meets (self or two rods)
  MANYRODS_HD bool met_in_solve(int ra, int rb) const { return ra == rb ? self_solved(ra) : pair_solved(ra, rb); }
  int* elem_count = nullptr;
  int* elem_count_lo = nullptr;  // of them on node k (s < 1)
  int* elem_count_hi = nullptr;  // on node k+1 (s > 0)
  int* elem_push = nullptr;      // its rod–rod pairs in range that can push within the step (pass 2 visits them)
  T* p0[3] = {};
  T* p1[3] = {};
  T* l[3] = {};
  T* q0[3] = {};  // the impulses of the contacts met in the implicit solve (kernels/contact_solve.h)
  T* q1[3] = {};
  T* work = nullptr;
  T* v_start[3] = {};  // the velocities at the step's start (save_start_velocities)
  T* w_start[3] = {};
  T* v_solve[3] = {};  // the velocities before the implicit solve (kernels/contact_solve.h)
  T* w_solve[3] = {};
  const int* neighbours = nullptr;
  const int* neighbour_count = nullptr;
  int capacity = 0;
  T hardness = 4, damping_ratio = 0;
};

template <class T>
struct Touch {
  T s = 0;            // point on the element, 0 … 1
  T gap = T(1e30);    // m, < 0: overlap
  vec3<T> n{0, 0, 1};  // unit, from the partner to the rod
};

namespace contact_detail {

template <class T>
MANYRODS_HD inline T clamp01(T v) {
  return v < T(0) ? T(0) : (v > T(1) ? T(1) : v);
}
template <class T>
MANYRODS_HD inline vec3<T> v3(const T* a) {
  return {a[0], a[1], a[2]};
}
template <class T>
MANYRODS_HD inline vec3<T> unit_or(vec3<T> d, T len, vec3<T> fallback) {
  return len > T(0) ? (T(1) / len) * d : fallback;
}
// A unit vector orthogonal to e (for a normal through the centreline).
template <class T>
MANYRODS_HD inline vec3<T> any_orthogonal(vec3<T> e) {
  const vec3<T> a = (e.x * e.x < e.y * e.y) ? vec3<T>{T(1), T(0), T(0)} : vec3<T>{T(0), T(1), T(0)};
  const vec3<T> o = cross(e, a);
  return unit_or(o, norm(o), vec3<T>{T(0), T(0), T(1)});
}

}  // namespace contact_detail

// Closest points p0 + s d1 and q0 + t d2 of two segments (s, t ∈ [0, 1]).
// Parallel segments (|d1 × d2|² ≤ 1e-6 |d1|²|d2|²) take the middle of their
// overlap, so that rods lying side by side touch at the middle, not an end.
template <class T>
MANYRODS_HD inline void closest_segments(vec3<T> p0, vec3<T> d1, vec3<T> q0, vec3<T> d2, T& s, T& t) {
  using contact_detail::clamp01;
  const vec3<T> r = p0 - q0;
  const T a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
  if (a <= T(0) && e <= T(0)) {
    s = t = T(0);
    return;
  }
  if (a <= T(0)) {
    s = T(0);
    t = clamp01(f / e);
    return;
  }
  const T c = dot(d1, r);
  if (e <= T(0)) {
    t = T(0);
    s = clamp01(-c / a);
    return;
  }
  const T bb = dot(d1, d2), den = a * e - bb * bb;
  if (den <= T(1e-6) * a * e) {
    const T s0 = clamp01(-c / a), s1 = clamp01((bb - c) / a);  // q0 and q0 + d2 projected on segment 1
    s = T(0.5) * (s0 + s1);
    t = clamp01((bb * s + f) / e);
    return;
  }
  s = clamp01((bb * f - c * e) / den);
  t = (bb * s + f) / e;
  if (t < T(0)) {
    t = T(0);
    s = clamp01(-c / a);
  } else if (t > T(1)) {
    t = T(1);
    s = clamp01((bb - c) / a);
  }
}

// φ and ∇φ of a collider's distance grid at body-frame point X (trilinear;
// outside the grid: a large positive φ, no contact).
template <class T>
MANYRODS_HD inline T grid_distance(const ColliderFrame<T>& c, vec3<T> X, vec3<T>& grad) {
  const T inv = T(1) / c.spacing;
  const T u[3] = {(X.x - c.origin[0]) * inv, (X.y - c.origin[1]) * inv, (X.z - c.origin[2]) * inv};
  const int nn[3] = {c.nx, c.ny, c.nz};
  int i[3];
  T f[3];
  for (int d = 0; d < 3; ++d) {
    if (!(u[d] >= T(0) && u[d] <= T(nn[d] - 1))) {
      grad = {T(0), T(0), T(1)};
      return T(1e30);
    }
    int id = int(u[d]);
    if (id > nn[d] - 2) id = nn[d] - 2;
    i[d] = id;
    f[d] = u[d] - T(id);
  }
  auto at = [&](int a, int b, int cc) {
    return T(c.phi[(std::size_t(i[2] + cc) * std::size_t(c.ny) + std::size_t(i[1] + b)) * std::size_t(c.nx) +
                   std::size_t(i[0] + a)]);
  };
  T v[2][2][2];
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int cc = 0; cc < 2; ++cc) v[a][b][cc] = at(a, b, cc);
  auto lerp = [](T p, T q, T w) { return p + w * (q - p); };
  // along x first
  T yz[2][2], dyz[2][2];
  for (int b = 0; b < 2; ++b)
    for (int cc = 0; cc < 2; ++cc) {
      yz[b][cc] = lerp(v[0][b][cc], v[1][b][cc], f[0]);
      dyz[b][cc] = v[1][b][cc] - v[0][b][cc];
    }
  const T z0 = lerp(yz[0][0], yz[1][0], f[1]), z1 = lerp(yz[0][1], yz[1][1], f[1]);
  const T phi = lerp(z0, z1, f[2]);
  const T gx = lerp(lerp(dyz[0][0], dyz[1][0], f[1]), lerp(dyz[0][1], dyz[1][1], f[1]), f[2]);
  const T gy = lerp(yz[1][0] - yz[0][0], yz[1][1] - yz[0][1], f[2]);
  const T gz = z1 - z0;
  grad = {gx * inv, gy * inv, gz * inv};
  return phi;
}

// Where the element x0 → x1 (radius r) touches collider c: up to 3 contacts
// into out[], their number returned.
//   plane: one at each end (s = 0, 1): an element lying on the plane is a
//     line contact, carried by its two nodes;
//   sphere, capsule: the closest point;
//   mesh: one at each end, and the middle when it is deeper than both (a
//     bump of the surface between the nodes).
template <class T>
MANYRODS_HD inline int collider_touches(const ColliderFrame<T>& c, vec3<T> x0, vec3<T> x1, T r, Touch<T> out[3]) {
  using namespace contact_detail;
  const vec3<T> e = x1 - x0;
  if (c.kind == int(ColliderKind::plane)) {
    const vec3<T> n = v3(c.n), p = v3(c.p);
    out[0].s = T(0);
    out[0].gap = dot(n, x0 - p) - r;
    out[0].n = n;
    out[1].s = T(1);
    out[1].gap = dot(n, x1 - p) - r;
    out[1].n = n;
    return 2;
  }
  if (c.kind == int(ColliderKind::sphere)) {
    const vec3<T> p = v3(c.p);
    const T ee = dot(e, e);
    out[0].s = ee > T(0) ? clamp01(dot(p - x0, e) / ee) : T(0);
    const vec3<T> d = x0 + out[0].s * e - p;
    const T len = norm(d);
    out[0].gap = len - c.radius - r;
    out[0].n = unit_or(d, len, any_orthogonal(e));
    return 1;
  }
  if (c.kind == int(ColliderKind::capsule)) {
    const vec3<T> a = v3(c.p), ab = v3(c.q) - a;
    T s, t;
    closest_segments(x0, e, a, ab, s, t);
    const vec3<T> d = (x0 + s * e) - (a + t * ab);
    const T len = norm(d);
    out[0].s = s;
    out[0].gap = len - c.radius - r;
    out[0].n = unit_or(d, len, any_orthogonal(e));
    return 1;
  }
  const mat3<T> R = {{c.R[0], c.R[1], c.R[2], c.R[3], c.R[4], c.R[5], c.R[6], c.R[7], c.R[8]}};
  const vec3<T> cc = v3(c.c);
  Touch<T> t[3];
  for (int i = 0; i < 3; ++i) {
    const T s = i == 2 ? T(0.5) : T(i);
    vec3<T> g;
    const T phi = grid_distance(c, mul_transpose(R, x0 + s * e - cc), g);
    const vec3<T> gl = mul(R, g);
    t[i].s = s;
    t[i].gap = phi - r;
    t[i].n = unit_or(gl, norm(gl), vec3<T>{T(0), T(0), T(1)});
  }
  out[0] = t[0];
  out[1] = t[1];
  if (t[2].gap < t[0].gap && t[2].gap < t[1].gap) {
    out[2] = t[2];
    return 3;
  }
  return 2;
}

// The deepest of them (for checks and statistics).
template <class T>
MANYRODS_HD inline Touch<T> deepest_touch(const ColliderFrame<T>& c, vec3<T> x0, vec3<T> x1, T r) {
  Touch<T> t[3];
  const int n = collider_touches(c, x0, x1, r, t);
  Touch<T> best = t[0];
  for (int i = 1; i < n; ++i)
    if (t[i].gap < best.gap) best = t[i];
  return best;
}

// The velocity of collider c's body at lab point p.
template <class T>
MANYRODS_HD inline vec3<T> collider_velocity(const ColliderFrame<T>& c, vec3<T> p) {
  const mat3<T> A = {{c.A[0], c.A[1], c.A[2], c.A[3], c.A[4], c.A[5], c.A[6], c.A[7], c.A[8]}};
  return mul(A, p - contact_detail::v3(c.c)) + contact_detail::v3(c.u);
}

// The contact range of element x0 → x1 (radius r, fastest node va) against
// collider c (element_contacts): reach (va + vb) + ½ r, vb the collider's
// fastest body velocity at the element's ends.
template <class T>
MANYRODS_HD inline T collider_range(const ColliderFrame<T>& c, vec3<T> x0, vec3<T> x1, T r, T va, T reach) {
  T vb = T(0);
  if (c.moving) {
    const T vb0 = norm(collider_velocity(c, x0)), vb1 = norm(collider_velocity(c, x1));
    vb = vb0 > vb1 ? vb0 : vb1;
  }
  return reach * (va + vb) + T(0.5) * r;
}

// Each touch of collider c within element x0 → x1's contact range
// (collider_touches, collider_range), passed to take(touch): the element's
// contacts with c, for the stage and for the contact solve alike.
template <class T, class Take>
MANYRODS_HD inline void touches_in_range(const ColliderFrame<T>& c, vec3<T> x0, vec3<T> x1, T r, T va, T reach,
                                         Take&& take) {
  const T delta = collider_range(c, x0, x1, r, va, reach);
  Touch<T> touch[3];
  const int nt = collider_touches(c, x0, x1, r, touch);
  for (int j = 0; j < nt; ++j)
    if (touch[j].gap < delta) take(touch[j]);
}

// One side of a contact that is an element: its slot, point, lever and what
// its nodes and frame lend the contact.
template <class T>
struct ContactSide {
  int k = -1;
  T s = 0;
  vec3<T> rho{0, 0, 0};  // lever: surface point − centreline point (lab)
  vec3<T> v{0, 0, 0};    // velocity of the surface point (lab)
  T w = 0;               // translational compliance (1 − s)² c_k/m_k + s² c_{k+1}/m_{k+1}
  T crot[6] = {};        // rotational compliance (lab, symmetric: xx xy xz yy yz zz), see element_side
  vec3<T> d3{0, 0, 1};   // the element's axis (lab)
};

// The translational compliance of the contact at s on an element whose
// nodes have inverse masses im0, im1 and lend c0, c1 contacts each (a
// count of 0 counts as 1): (1 − s)² c0/m0 + s² c1/m1, at least ¼ of the
// free node's where one node is held (see element_side).
template <class T>
MANYRODS_HD inline T contact_compliance(T s, T im0, T im1, T c0, T c1) {
  const T w0 = im0 * (c0 > T(0) ? c0 : T(1)), w1 = im1 * (c1 > T(0) ? c1 : T(1));
  T w = (T(1) - s) * (T(1) - s) * w0 + s * s * w1;
  if ((w0 == T(0)) != (w1 == T(0))) {
    const T wmid = T(0.25) * (w0 + w1);
    w = w > wmid ? w : wmid;
  }
  return w;
}

template <class T>
MANYRODS_HD inline ContactSide<T> element_side(int k, T s, vec3<T> rho, const ModelView<T>& m,
                                               const ConstStateView<T>& st, const ContactView<T>& cv) {
  ContactSide<T> o;
  o.k = k;
  o.s = s;
  o.rho = rho;
  // the contacts on node k: element k−1's on its far node, element k's on its near one
  const T c0 = T(cv.elem_count_hi[k - 1] + cv.elem_count_lo[k]), c1 = T(cv.elem_count_hi[k] + cv.elem_count_lo[k + 1]);
  const T ce = T(cv.elem_count[k] > 0 ? cv.elem_count[k] : 1);
  // A held node (clamped, driven: w = 0) would make the element a lever
  // about it: a contact at s → 0 would throw the free node at 1/s times
  // the velocity the contact needs. Such an element lends a contact at
  // most the stiffness it lends one at its middle (w ≥ ¼ w_free): the
  // held end takes the rest (docs/contact.md "Effective mass and mass splitting").
  o.w = contact_compliance(s, m.node_inv_mass[k], m.node_inv_mass[k + 1], c0, c1);
  const mat3<T> Q = load_frame(st.elem_Q, k);
  const vec3<T> wl = mul_transpose(Q, load3(st.elem_w, k));  // lab angular velocity
  o.v = (T(1) - s) * load3(st.node_v, k) + s * load3(st.node_v, k + 1) + cross(wl, rho);
  // The element turns about its axis d3 only (rolling, twisting): a turn
  // about d1 or d2 with the centreline held is shear, which the stiff shear
  // resists (the rigid-section limit; an explicit shear mode driven through
  // the contact would be unstable). With b = d3 × ρ, a couple impulse
  // d3 (d3 · (ρ × P)) moves the surface point by J₃⁻¹ (P · b) b:
  // C_rot = c_k J₃⁻¹ b bᵀ. A stiff rod does not roll (C_rot = 0, and no
  // couple, element_contacts): its twist is stiff, the twist wave crosses
  // the rod within a step, so the axial inertia a contact meets is the
  // whole rod's, ≥ n times one element's (its rolling compliance ≤ 1/n of
  // this); one element's would spin it at v/r, h|ω| of order 1, and the
  // drift's exact rotation then shears it.
  o.d3 = {Q.m[6], Q.m[7], Q.m[8]};
  const vec3<T> bb = cross(o.d3, rho);
  const T j3 = cv.rod_stiff[cv.elem_rod[k]] ? T(0) : ce * m.elem_inv_inertia[2][k];
  o.crot[0] = j3 * bb.x * bb.x;
  o.crot[1] = j3 * bb.x * bb.y;
  o.crot[2] = j3 * bb.x * bb.z;
  o.crot[3] = j3 * bb.y * bb.y;
  o.crot[4] = j3 * bb.y * bb.z;
  o.crot[5] = j3 * bb.z * bb.z;
  return o;
}

// Normal impulse (C1).
template <class T>
MANYRODS_HD inline T normal_impulse(T gap, T vn, T mc, T h, T omega, T zeta) {
  const T a = omega * omega, b = a + T(2) * zeta * omega;
  const T lam = -mc * (a * gap / h + b * vn) / (T(1) + b);
  return lam > T(0) ? lam : T(0);
}

// Whether the tangential impulse (p_a along the axis, p_t across) lies in
// the elliptic cone (p_a/μ_a)² + (p_t/μ_t)² ≤ λ² (a zero coefficient
// admits no impulse along its direction).
template <class T>
MANYRODS_HD inline bool in_elliptic_cone(T pa, T pt, T mu_a, T mu_t, T lam) {
  const T qa = mu_a > T(0) ? pa / mu_a : (pa != T(0) ? T(1e30) : T(0));
  const T qt = mu_t > T(0) ? pt / mu_t : (pt != T(0) ? T(1e30) : T(0));
  return qa * qa + qt * qt <= lam * lam;
}

// The unit axial direction ê_a in the plane ⟂ n (the element's unit tangent
// `axis` projected), or zero where the friction is isotropic (mu[2] < 0) or
// the axis is along n: the frame of axial friction, ê_t = n × ê_a.
template <class T>
MANYRODS_HD inline vec3<T> axial_tangent(vec3<T> axis, vec3<T> n, const T mu[4]) {
  const vec3<T> zero{T(0), T(0), T(0)};
  if (mu[2] < T(0)) return zero;
  const vec3<T> ea = axis - dot(axis, n) * n;
  const T len = norm(ea);
  return len > T(1e-6) ? (T(1) / len) * ea : zero;
}

// Axial friction's kinetic impulse against the slip vt (in the plane ⟂ n),
// scaled by s (−λ: the impulse; −1: per unit λ): the maximal-dissipation
// direction on the elliptic cone,
//   s (μ_a² v_a ê_a + μ_t² v_t ê_t) / √(μ_a² v_a² + μ_t² v_t²),
// μ_a, μ_t the kinetic coefficients along ê_a, ê_t; zero without slip.
template <class T>
MANYRODS_HD inline vec3<T> elliptic_kinetic(vec3<T> vt, vec3<T> ea, vec3<T> et, T mka, T mkt, T s) {
  const T va = dot(vt, ea), vv = dot(vt, et);
  const T nrm = norm(vec3<T>{mka * va, mkt * vv, T(0)});
  if (!(nrm > T(0))) return vec3<T>{T(0), T(0), T(0)};
  return (s / nrm) * (mka * mka * va * ea + mkt * mkt * vv * et);
}

// The Coulomb impulse (see the header) for slip velocity vt in the plane ⟂ n,
// compliance C (symmetric 3×3: xx xy xz yy yz zz), normal impulse lam,
// coefficients mu = {static, kinetic, static axial, kinetic axial} (axial < 0:
// isotropic) and the rod's unit tangent `axis`.
template <class T>
MANYRODS_HD inline vec3<T> coulomb_impulse(vec3<T> n, vec3<T> vt, const T C[6], T lam, const T mu[4], vec3<T> axis) {
  const vec3<T> zero{T(0), T(0), T(0)};
  const T speed = norm(vt);
  if (!(lam > T(0)) || !(speed > T(0)) || (mu[0] <= T(0) && mu[2] <= T(0))) return zero;
  const vec3<T> t1 = (T(1) / speed) * vt, t2 = cross(n, t1);
  auto cmul = [&](vec3<T> x) {
    return vec3<T>{C[0] * x.x + C[1] * x.y + C[2] * x.z, C[1] * x.x + C[3] * x.y + C[4] * x.z,
                   C[2] * x.x + C[4] * x.y + C[5] * x.z};
  };
  const vec3<T> c1 = cmul(t1), c2 = cmul(t2);
  const T a11 = dot(t1, c1), a12 = dot(t1, c2), a22 = dot(t2, c2);
  const T det = a11 * a22 - a12 * a12;
  if (!(det > T(0))) return zero;
  // C_t x = (−|v_t|, 0)
  const T x1 = -speed * a22 / det, x2 = speed * a12 / det;
  const vec3<T> stick = x1 * t1 + x2 * t2;
  const T stick_len = norm(stick);
  const vec3<T> ea = axial_tangent(axis, n, mu);
  if (ea.x != T(0) || ea.y != T(0) || ea.z != T(0)) {
    const vec3<T> et = cross(n, ea);
    if (in_elliptic_cone(dot(stick, ea), dot(stick, et), mu[2], mu[0], lam)) return stick;
    const vec3<T> slip = elliptic_kinetic(vt, ea, et, mu[3] >= T(0) ? mu[3] : mu[1], mu[1], -lam);
    return norm(slip) > stick_len ? stick : slip;
  }
  if (stick_len <= mu[0] * lam) return stick;
  const T slip = mu[1] * lam;
  return slip > stick_len ? stick : (-slip) * t1;
}

// The impulse of one contact on side a (an element) from a partner that is
// side b (an element, b.k ≥ 0) or a collider moving with velocity vb (b.k < 0).
// Returns λ n + P_t on a; `lam` gets λ.
template <class T>
MANYRODS_HD inline vec3<T> contact_impulse(const ContactSide<T>& a, const ContactSide<T>& b, vec3<T> n, T gap,
                                           const T mu[4], vec3<T> axis, T h, T omega, T zeta, T& lam,
                                           vec3<T>& pt) {
  const vec3<T> vrel = a.v - b.v;
  const T w = a.w + b.w;
  lam = T(0);
  pt = {T(0), T(0), T(0)};
  if (!(w > T(0))) return pt;
  const T vn = dot(n, vrel);
  lam = normal_impulse(gap, vn, T(1) / w, h, omega, zeta);
  if (!(lam > T(0))) return pt;
  T C[6];
  for (int i = 0; i < 6; ++i) C[i] = a.crot[i] + b.crot[i];
  C[0] += w;
  C[3] += w;
  C[5] += w;
  pt = coulomb_impulse(n, vrel - vn * n, C, lam, mu, axis);
  return lam * n + pt;
}

// Friction coefficients of a pair: each coefficient the geometric mean of
// the two sides' (docs/contact.md "Friction of a pair"); a rod side without
// its own (own = false) takes the partner's. Axial coefficients: a side
// without them uses its isotropic ones; −1 (isotropic) when neither has them.
template <class T>
MANYRODS_HD inline void pair_mu(const T* a, bool a_own, const T* b, bool b_own, T out[4]) {
  using std::sqrt;
  for (int i = 0; i < 4; ++i) {
    const bool axial = i >= 2;
    if (axial && a[i] < T(0) && b[i] < T(0)) {
      out[i] = T(-1);
      continue;
    }
    const T x = axial && a[i] < T(0) ? a[i - 2] : a[i];
    const T y = axial && b[i] < T(0) ? b[i - 2] : b[i];
    out[i] = !a_own ? y : (!b_own ? x : sqrt(x * y));
  }
}

// Whether elements ka (rod ra) and kb (rod rb) may touch: other rods with
// rod_rod, the same rod with self unless they share a node (|i − j| = 1).
MANYRODS_HD inline bool rod_pair_allowed(int ka, int ra, int kb, int rb, bool rod_rod, bool self) {
  if (ka == kb) return false;
  if (ra != rb) return rod_rod;
  if (!self) return false;
  const int d = ka > kb ? ka - kb : kb - ka;
  return d > 1;
}

// The contact distance of two elements of one rod near each other along it
// (docs/contact.md "Self contact"). The tightest loop a tube of radius r
// can make without overlapping itself has a centreline radius r; on it,
// points an arc length a < π r apart lie 2r sin(a/2r) apart, less than 2r.
// Elements that close along the rod therefore touch only when the rod bends
// tighter than that loop (a kink): their contact distance is the chord
// 2r sin(a/2r) instead of 2r, with a the current arc length between the
// closest points s (on lo) and t (on hi). A straight or gently bent rod is
// never in contact with itself (the chord is shorter than the arc), and
// from a = π r on the distance is 2r, continuous with the law between far
// elements.
template <class T>
MANYRODS_HD inline T near_contact_distance(int lo, int hi, T s, T t, const T* const x[3], T r) {
  using std::sin;
  T arc = (T(1) - s) * norm(load3(x, lo + 1) - load3(x, lo)) + t * norm(load3(x, hi + 1) - load3(x, hi));
  for (int e = lo + 1; e < hi; ++e) arc += norm(load3(x, e + 1) - load3(x, e));
  const T half = arc / (T(2) * r);
  return half < T(1.5707963267948966) ? T(2) * r * sin(half) : T(2) * r;
}

// Elements lo < hi as a pair, always in this order (so that both sides of
// a pair compute bit-identical values): the closest points s (on lo) and t
// (on hi), d = q_lo − q_hi, its length and the gap |d| − r_lo − r_hi, or,
// for elements of one rod at most `near` apart (hi − lo ≤ near), |d| minus
// their near_contact_distance. near = 0: every pair at r_lo + r_hi.
template <class T>
struct PairGeometry {
  T s, t, len, gap;
  vec3<T> d, e_lo;
};
template <class T>
MANYRODS_HD inline PairGeometry<T> pair_geometry(int lo, int hi, const T* const x[3], const T* radius, int near = 0) {
  PairGeometry<T> g;
  const vec3<T> a0 = load3(x, lo), b0 = load3(x, hi);
  g.e_lo = load3(x, lo + 1) - a0;
  const vec3<T> be = load3(x, hi + 1) - b0;
  closest_segments(a0, g.e_lo, b0, be, g.s, g.t);
  g.d = (a0 + g.s * g.e_lo) - (b0 + g.t * be);
  g.len = norm(g.d);
  g.gap = hi - lo <= near ? g.len - near_contact_distance(lo, hi, g.s, g.t, x, T(0.5) * (radius[lo] + radius[hi]))
                          : g.len - radius[lo] - radius[hi];
  return g;
}

// `near` of pair_geometry for elements ka, kb: the rod's near span for two
// elements of one rod, 0 for two rods.
MANYRODS_HD inline int pair_near(int ka, int kb, const int* elem_rod, const int* rod_near) {
  return elem_rod[ka] == elem_rod[kb] ? rod_near[elem_rod[ka]] : 0;
}

// The margin of the contact range of listed elements lo < hi (`near` as
// pair_geometry's): ½ (r_lo + r_hi), but none for near elements of one rod,
// so that the many always close to their contact distance (a ~straight rod)
// are counted only when they can act within the step (the counts split the
// node masses).
template <class T>
MANYRODS_HD inline T pair_margin(int lo, int hi, int near, const T* radius) {
  return hi - lo <= near ? T(0) : T(0.5) * (radius[lo] + radius[hi]);
}

// The friction of elements of rods ra and rb (rod–rod and self contact):
// pair_mu of the two rods' coefficients, isotropic.
template <class T>
MANYRODS_HD inline void rod_pair_mu(const ContactView<T>& cv, int ra, int rb, T out[4]) {
  pair_mu(cv.rod_mu + 4 * ra, true, cv.rod_mu + 4 * rb, true, out);
  out[2] = out[3] = T(-1);
}

namespace contact_detail {
template <class T>
MANYRODS_HD inline T max_speed(const ConstStateView<T>& st, int k) {
  const T a = norm(load3(st.node_v, k)), b = norm(load3(st.node_v, k + 1));
  return a > b ? a : b;
}
template <class T>
struct Accumulator {
  vec3<T> p0{T(0), T(0), T(0)}, p1{T(0), T(0), T(0)}, l{T(0), T(0), T(0)};
  int count = 0, count_lo = 0, count_hi = 0;  // count_lo/hi: of them on node k / k+1
  MANYRODS_HD void count_in(T s) {
    ++count;
    if (s < T(1)) ++count_lo;
    if (s > T(0)) ++count_hi;
  }
  MANYRODS_HD void add(T s, vec3<T> p, vec3<T> rho, vec3<T> d3, vec3<T> pt) {
    p0 = p0 + (T(1) - s) * p;
    p1 = p1 + s * p;
    l = l + dot(d3, cross(rho, pt)) * d3;  // about the axis only (element_side)
  }
};
}  // namespace contact_detail

// Element k's contacts with the colliders (kColliders) and with its listed
// partner elements (kRods). kImpulse = false: only counts those in range,
// into elem_count (pass 1, for the mass splitting); true: the impulses
// (pass 2, after every count is known), into elem_p0, elem_p1, elem_l.
// The contact range: a contact can push within the step only if its gap
// is below h (1 + 2ζ/Ω) |v_rel| (C1), so
//   δ = h (1 + 2ζ/Ω)(v_max,a + v_max,b) + ½ (r_a + r_b)
// with each side's fastest node (a collider: its body velocity at the
// element's ends, exact for a rigid motion), the ½ r a margin.
template <bool kColliders, bool kRods, bool kImpulse, class T>
MANYRODS_HD inline void element_contacts(int k, T h, const ModelView<T>& m, const ConstStateView<T>& st,
                                         const ContactView<T>& cv) {
  using namespace contact_detail;
  Accumulator<T> acc;
  int push = 0;  // pass 1: its rod–rod pairs in range that can push
  const int rod = cv.elem_rod[k];
  // pass 2 visits only the elements the count found something for
  if (rod >= 0 && (!kImpulse || cv.elem_count[k] > 0)) {
    const vec3<T> x0 = load3(st.node_x, k), x1 = load3(st.node_x, k + 1), e = x1 - x0;
    const T r = cv.elem_radius[k], el = norm(e);
    const vec3<T> axis = unit_or(e, el, vec3<T>{T(0), T(0), T(1)});
    const T reach = h * (T(1) + T(2) * cv.damping_ratio / cv.hardness);
    const T va = max_speed(st, k);
    if constexpr (kColliders) {
      // (a rod the implicit solve steps met them there)
      for (int i = 0; i < (cv.colliders_in_solve(rod) ? 0 : cv.collider_count); ++i) {
        const ColliderFrame<T>& c = cv.colliders[i];
        touches_in_range(c, x0, x1, r, va, reach, [&](const Touch<T>& t) {
          acc.count_in(t.s);
          if constexpr (kImpulse) {
            const vec3<T> rho = (-r) * t.n;
            const ContactSide<T> a = element_side(k, t.s, rho, m, st, cv);
            ContactSide<T> b;
            b.v = collider_velocity(c, x0 + t.s * e + rho);
            T mu[4];
            pair_mu(cv.rod_mu + 4 * rod, cv.rod_mu_own[rod] != 0, c.mu, true, mu);
            T lam;
            vec3<T> pt;
            const vec3<T> p =
                contact_impulse(a, b, t.n, t.gap, mu, axis, h, cv.hardness, cv.damping_ratio, lam, pt);
            acc.add(t.s, p, rho, a.d3, pt);
          }
        });
      }
    }
    if constexpr (kRods) {
      const int nc = kImpulse && cv.elem_push[k] == 0 ? 0 : cv.neighbour_count[k];
      for (int j = 0; j < nc; ++j) {
        const int kb = cv.neighbours[std::size_t(k) * std::size_t(cv.capacity) + std::size_t(j)];
        if (cv.met_in_solve(rod, cv.elem_rod[kb])) continue;  // met in their solve (kernels/contact_solve.h)
        const int lo = k < kb ? k : kb, hi = k < kb ? kb : k;
        const int near = pair_near(lo, hi, cv.elem_rod, cv.rod_near);
        const T ra = cv.elem_radius[lo], rb = cv.elem_radius[hi];
        const T margin = pair_margin(lo, hi, near, cv.elem_radius);
        const T delta = reach * (max_speed(st, lo) + max_speed(st, hi)) + margin;
        const PairGeometry<T> g = pair_geometry(lo, hi, st.node_x, cv.elem_radius, near);
        if (!(g.gap < delta)) continue;
        acc.count_in(k == lo ? g.s : g.t);
        // A pair in range beyond h (1 + 2ζ/Ω)(v_a + v_b), δ without its
        // margin, cannot push within the step ((C1): λ > 0 needs
        // g < −h (1 + 2ζ/Ω) v_n, and |v_n| ≤ v_a + v_b): no impulse, no
        // friction. Pass 2 skips the pairs of an element with none that can
        // (the sums are bit for bit those without the skip: it adds zeros;
        // the guard, 10⁻³ of the radii, covers the law's rounding). A tight
        // bundle of fibres 0.3 r apart has ~12 pairs in range an element,
        // all at rest.
        if (!kImpulse && g.gap < delta - margin + T(1e-3) * (ra + rb)) ++push;
        if constexpr (kImpulse) {
          const vec3<T> n = unit_or(g.d, g.len, any_orthogonal(g.e_lo));
          const ContactSide<T> sa = element_side(lo, g.s, (-ra) * n, m, st, cv);
          const ContactSide<T> sb = element_side(hi, g.t, rb * n, m, st, cv);
          T mu[4];
          rod_pair_mu(cv, cv.elem_rod[lo], cv.elem_rod[hi], mu);
          T lam;
          vec3<T> pt;
          const vec3<T> p = contact_impulse(sa, sb, n, g.gap, mu, axis, h, cv.hardness, cv.damping_ratio, lam, pt);
          if (k == lo) acc.add(g.s, p, sa.rho, sa.d3, pt);
          else acc.add(g.t, -p, sb.rho, sb.d3, -pt);
        }
      }
    }
  }
  if constexpr (!kImpulse) {
    cv.elem_count[k] = acc.count;
    cv.elem_count_lo[k] = acc.count_lo;
    cv.elem_count_hi[k] = acc.count_hi;
    cv.elem_push[k] = push;
  } else {
    store3(cv.p0, k, acc.p0);
    store3(cv.p1, k, acc.p1);
    store3(cv.l, k, rod >= 0 && cv.rod_stiff[rod] ? vec3<T>{T(0), T(0), T(0)} : acc.l);  // (a stiff rod does not roll)
  }
}

// Slot k at the step's start: its node's and element's velocities, for the
// work of the step's contact impulses (apply_contact).
// reads: state.node_v, elem_w  writes: contact.v_start, w_start
template <class T>
MANYRODS_HD inline void save_start_velocities(int k, const ConstStateView<T>& st, const ContactView<T>& cv) {
  store3(cv.v_start, k, load3(st.node_v, k));
  store3(cv.w_start, k, load3(st.elem_w, k));
}

// Slot k: node k takes the impulses of its two elements' contacts, element k
// its couple; the work they do goes to contact.work[k]. The work of an
// impulse P over the step is P·(v_n + v_{n+1})/2, v_n the velocity at the
// step's start and v_{n+1} at its end: Position Verlet moves the node by
// x_{n+1} − x_n = h (v_n + v_{n+1})/2, so this is the work of the force P/h
// over the step's displacement, and the kinetic energy's change over the
// step is exactly the sum of such terms of every force of the kick (gravity's
// is −ΔU exactly; the elastic forces' −ΔE to the integrator's error). A node
// resting on a plane (v_n = v_{n+1} = 0) takes no work; a sliding one loses
// μ λ |v̄| to friction. Rotation likewise: (J Δω)·(ω_n + ω_{n+1})/2 in the
// material frame.
template <class T>
MANYRODS_HD inline void apply_contact(int k, const ModelView<T>& m, const StateView<T>& st, const ContactView<T>& cv) {
  // nothing gathered for node k or element k (a ghost node, inverse mass 0,
  // is not asked about element k − 1, which may lie in another segment)
  if (cv.elem_count[k] == 0 && (m.node_inv_mass[k] == T(0) || cv.elem_count[k - 1] == 0)) return;
  T dw = T(0);
  const T im = m.node_inv_mass[k];
  if (im > T(0)) {
    const vec3<T> p = load3(cv.p1, k - 1) + load3(cv.p0, k);
    const vec3<T> v1 = load3(st.node_v, k) + im * p;
    store3(st.node_v, k, v1);
    dw += T(0.5) * dot(p, load3(cv.v_start, k) + v1);
  }
  const vec3<T> l = load3(cv.l, k);
  if (l.x != T(0) || l.y != T(0) || l.z != T(0)) {
    const vec3<T> w0 = load3(st.elem_w, k);
    const vec3<T> w1 = w0 + hadamard(load3(m.elem_inv_inertia, k), mul(load_frame(st.elem_Q, k), l));
    store3(st.elem_w, k, w1);
    // (Δω as w1 − w0: the update above keeps its one rounding, the state its bits)
    dw += T(0.5) * dot(hadamard(load3(m.elem_inertia, k), w1 - w0), load3(cv.w_start, k) + w1);
  }
  cv.work[k] += dw;
}

}  // namespace manyrods
