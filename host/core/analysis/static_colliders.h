// host/core/analysis/static_colliders.h — the colliders' push and friction in the static solve.
//
//   each_collider_push   every touch's push on a rod's nodes, node by node
//   collider_push        their sum and the anchored nodes' friction, added to f
//   update_anchors       after a converged load increment: anchors made where
//                        a node touches (within δ), moved where it slips,
//                        dropped where it no longer touches
//   drop_stale_anchors   at a solve's start: anchors of nodes moved since
//
// Push. Each touch (kernels/contact.h collider_touches) of element k (nodes
// k, k + 1, radius r) with a collider, gap g < 0, pushes along its normal n:
//   p(g) = k_e g²/(2δ)        −δ < g < 0
//        = k_e (−g − δ/2)     g ≤ −δ
// shared by the nodes as (1 − s, s); k_e = EA/ℓ of the element, δ = 0.1 r:
// once differentiable at the surface, so that Newton's Jacobian does not
// jump where a contact starts. A load F is carried at an overlap √(2δF/k_e)
// (below k_e δ/2; a micrometre for a 1 cm rod's weight on a floor).
//
// Friction (Coulomb, the static coefficients of kernels/contact.h pair_mu:
// μ across the rod, μa along it). A node that a collider pushes (P: the
// sum of its shares of that collider's touches, p = |P|, n = P/p) sticks to
// an anchor, a point X of the collider's body (R X + c in the lab, so that
// it moves with a driven collider):
//   u = (I − n nᵀ)(x_k − (R X + c))             the slip from the anchor
//   f = −p (μa (u·a) a + μ (u − (u·a) a)) / max(|u|, ε)
// a = the rod's axis at the node in the tangent plane, ε = 0.01 × the
// contact radius (kStickLength): within ε of its anchor the node sticks
// (a spring of stiffness μp/ε, the cone's inside), beyond it slips with
// the force on the (elliptic) cone |(f·a/μa, f_⊥/μ)| = p. ε bounds the
// creep of a stuck node (5 µm on a 1 mm cable, against a push's overlap
// of micrometres) and keeps the law's corner many finite-difference steps
// (1e-6 L) wide, so that Newton's Jacobian sees it: with a spring as stiff
// as the push (EA/ℓ) the stick zone μp/k was nanometres, below the
// difference step, and Newton cycled. The force is continuous (not smooth)
// at |u| = ε and vanishes with p (a contact that starts holds nothing until
// it is pressed).
//
// Anchors change only between load increments (update_anchors), and at a
// solve's start: a node that touches (gap below δ, pressed or not yet)
// with no anchor gets one where it is (its first contact point: the touches
// of an increment in which a node arrived act on it without friction); a
// slipping one moves along u to |u| = ε (its force unchanged, so the
// equilibrium holds: a return map along the load path); one not pressed
// follows its node; an anchor whose node no longer touches goes. Statics
// has no speeds: slip is resisted by the static coefficients, the kinetic
// ones play no role.
//
// Reads: state.node_x, model.elem_stiffness[2], model.elem_rest_length,
// contact.rod_mu, contact.rod_mu_own, contact.static_anchors. Writes: f
// (collider_push), contact.static_anchors (update_anchors,
// drop_stale_anchors).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "kernels/contact.h"
#include "manyrods/batch.h"

namespace manyrods::detail {

// Each touch's push on rod r's nodes: visit(node slot, collider index,
// the node's share of the touch, the push's share on the node, the gap g,
// the law's width δ), for the touches with gap below δ (a touch not yet
// pressed, g ≥ 0, pushes zero: it is near enough for friction to hold it
// where it touches).
template <class Visit>
void each_collider_push(const RodBatch<double>& b, int r, const std::vector<ColliderFrame<double>>& frames, Visit&& visit) {
  const RodInfo& rod = b.rods[std::size_t(r)];
  const ConstStateView<double> s = b.state_view();
  for (int e = 0; e < rod.elements; ++e) {
    const int k = rod.offset + 1 + e;  // element k joins nodes k and k + 1
    const double radius = rod.element_radius(e), delta = 0.1 * radius;
    const double stiff = b.model.elem_stiffness[2][k] / b.model.elem_rest_length[k];
    const vec3<double> x0 = load3(s.node_x, k), x1 = load3(s.node_x, k + 1);
    for (std::size_t ci = 0; ci < frames.size(); ++ci) {
      Touch<double> t[3];
      const int count = collider_touches(frames[ci], x0, x1, radius, t);
      for (int i = 0; i < count; ++i) {
        const double g = t[i].gap;
        if (!(g < delta)) continue;
        const double p = g >= 0 ? 0.0 : g > -delta ? stiff * g * g / (2 * delta) : stiff * (-g - delta / 2);
        visit(k, int(ci), 1 - t[i].s, ((1 - t[i].s) * p) * t[i].n, g, delta);
        visit(k + 1, int(ci), t[i].s, (t[i].s * p) * t[i].n, g, delta);
      }
    }
  }
}

// The stick length ε of the friction law (above), in contact radii.
inline constexpr double kStickLength = 0.01;

// Whether any collider has friction (pair_mu of a collider with μ = 0 is 0
// for every rod): without, the static solve keeps no anchors.
inline bool static_friction(const std::vector<ColliderFrame<double>>& frames) {
  for (const ColliderFrame<double>& c : frames)
    if (c.mu[0] > 0 || c.mu[2] > 0) return true;
  return false;
}

// The static coefficients of rod r against collider c: across (mu) and
// along the rod (axial).
inline void static_mu(const RodBatch<double>& b, int r, const ColliderFrame<double>& c, double& mu, double& axial) {
  double m[4] = {c.mu[0], c.mu[1], c.mu[2], c.mu[3]};
  if (b.contact.rod_mu.size() >= 4 * std::size_t(r + 1))
    pair_mu(b.contact.rod_mu.data() + 4 * r, b.contact.rod_mu_own[std::size_t(r)] != 0, c.mu, true, m);
  mu = m[0];
  axial = m[2] < 0 ? m[0] : m[2];
}

// The pushes on rod r's nodes, per collider: P[(k − first) C + ci].
struct NodePushes {
  int first = 0, colliders = 0;
  std::vector<vec3<double>> P;
  std::vector<char> near;  // the node has a share of a touch within δ
  vec3<double>& at(int k, int ci) { return P[std::size_t((k - first) * colliders + ci)]; }
};

// The collider's rotation body → lab (x = R X + c).
inline mat3<double> collider_rotation(const ColliderFrame<double>& c) {
  return {{c.R[0], c.R[1], c.R[2], c.R[3], c.R[4], c.R[5], c.R[6], c.R[7], c.R[8]}};
}

// The friction of anchor a on its node (pushed by P): the force f, the
// anchor in the lab, the slip u from it, the stick length ε, and whether
// the node slips (|u| > ε).
struct AnchorForce {
  vec3<double> f{0, 0, 0}, anchor{0, 0, 0}, u{0, 0, 0};
  double eps = 0;
  bool slip = false;
};
inline AnchorForce anchor_force(const RodBatch<double>& b, int r, const StaticAnchor& a, const ColliderFrame<double>& c,
                                vec3<double> P) {
  AnchorForce out;
  const RodInfo& rod = b.rods[std::size_t(r)];
  const ConstStateView<double> s = b.state_view();
  const int k = a.node, lo = rod.offset + 1, hi = rod.offset + 1 + rod.elements;
  const vec3<double> x = load3(s.node_x, k);
  out.anchor = mul(collider_rotation(c), vec3<double>{a.X[0], a.X[1], a.X[2]}) + vec3<double>{c.c[0], c.c[1], c.c[2]};
  const double p = norm(P);
  if (!(p > 0)) {  // near, not pressed: no friction, and the anchor follows the node
    out.u = x - out.anchor;
    out.slip = norm(out.u) > 0;
    return out;
  }
  double mu, axial;
  static_mu(b, r, c, mu, axial);
  const vec3<double> n = (1 / p) * P, d = x - out.anchor;
  out.u = d - dot(d, n) * n;
  int ne = 0;
  for (int e : {k - 1, k})
    if (e >= lo && e < hi) out.eps += rod.element_radius(e - lo), ++ne;
  out.eps *= kStickLength / std::max(ne, 1);
  // along the rod (the chord through the node's neighbours, in the tangent
  // plane) and across it
  vec3<double> t = load3(s.node_x, std::min(k + 1, hi)) - load3(s.node_x, std::max(k - 1, lo));
  t = t - dot(t, n) * n;
  const double tl = norm(t), ul = norm(out.u);
  const vec3<double> ax = tl > 0 ? (1 / tl) * t : vec3<double>{0, 0, 0};
  const double ua = dot(out.u, ax);
  out.slip = ul > out.eps * (1 - 1e-9);  // (an anchor moved to |u| = ε last time is still at the limit, round-off aside)
  out.f = (-p / std::max(ul, out.eps)) * ((axial * ua) * ax + mu * (out.u - ua * ax));
  return out;
}

// Rod r's pushes per node and collider, into np (its storage reused).
inline void node_pushes(const RodBatch<double>& b, int r, const std::vector<ColliderFrame<double>>& frames, NodePushes& np) {
  const RodInfo& rod = b.rods[std::size_t(r)];
  np.first = rod.offset + 1, np.colliders = int(frames.size());
  np.P.assign(std::size_t((rod.elements + 1) * np.colliders), vec3<double>{0, 0, 0});
  np.near.assign(np.P.size(), 0);
  each_collider_push(b, r, frames, [&](int k, int ci, double w, vec3<double> v, double, double) {
    np.at(k, ci) = np.at(k, ci) + v;
    if (w > 0) np.near[std::size_t((k - np.first) * np.colliders + ci)] = 1;
  });
}

// The anchor's node is where the solve that placed it left it.
inline bool anchor_current(const RodBatch<double>& b, const StaticAnchor& a) {
  for (int i = 0; i < 3; ++i)
    if (b.state.node_x[i][a.node] != a.x[i]) return false;
  return true;
}

// The colliders' push and friction on rod r's nodes, added to f (the static
// residual's contact part). current_only: only anchors whose node is where
// their solve left it (hold reactions of a state that may have moved since).
inline void collider_push(const RodBatch<double>& b, int r, const std::vector<ColliderFrame<double>>& frames,
                          std::array<Array<double>, 3>& f, bool current_only = false) {
  const std::vector<StaticAnchor>* anchors =
      std::size_t(r) < b.contact.static_anchors.size() ? &b.contact.static_anchors[std::size_t(r)] : nullptr;
  if (!anchors || anchors->empty()) {
    each_collider_push(b, r, frames, [&](int k, int, double, vec3<double> v, double, double) {
      f[0][k] += v.x, f[1][k] += v.y, f[2][k] += v.z;
    });
    return;
  }
  thread_local NodePushes np;  // (a residual's scratch: the Jacobian takes 60 residuals)
  node_pushes(b, r, frames, np);
  for (std::size_t i = 0; i < np.P.size(); ++i) {
    const int k = np.first + int(i) / np.colliders;
    f[0][k] += np.P[i].x, f[1][k] += np.P[i].y, f[2][k] += np.P[i].z;
  }
  for (const StaticAnchor& a : *anchors) {
    if (a.collider >= int(frames.size()) || (current_only && !anchor_current(b, a))) continue;
    const vec3<double> fr = anchor_force(b, r, a, frames[std::size_t(a.collider)], np.at(a.node, a.collider)).f;
    f[0][a.node] += fr.x, f[1][a.node] += fr.y, f[2][a.node] += fr.z;
  }
}

// Stick and slip at the end of a solve (update_anchors counts them).
struct AnchorCount {
  int stick = 0, slip = 0;
};

// After a converged load increment: rod r's anchors made, moved or dropped
// (above). Returns the contacts that stick and those at the cone.
inline AnchorCount update_anchors(RodBatch<double>& b, int r, const std::vector<ColliderFrame<double>>& frames) {
  AnchorCount out;
  std::vector<StaticAnchor>& old = b.contact.static_anchors[std::size_t(r)];
  NodePushes np;
  node_pushes(b, r, frames, np);
  std::vector<StaticAnchor> now;
  std::size_t o = 0;
  for (std::size_t i = 0; i < np.P.size(); ++i) {
    const int k = np.first + int(i) / np.colliders, ci = int(i) % np.colliders;
    while (o < old.size() && (old[o].node < k || (old[o].node == k && old[o].collider < ci))) ++o;
    const bool had = o < old.size() && old[o].node == k && old[o].collider == ci;
    const ColliderFrame<double>& c = frames[std::size_t(ci)];
    double mu, axial;
    static_mu(b, r, c, mu, axial);
    if (!np.near[i] || (mu <= 0 && axial <= 0)) continue;
    StaticAnchor a;
    a.node = k, a.collider = ci;
    const vec3<double> x = load3(b.state_view().node_x, k);
    const bool pressed = norm(np.P[i]) > 0;
    const AnchorForce af = had ? anchor_force(b, r, old[o], c, np.P[i]) : AnchorForce{};
    if (had && !af.slip) {  // sticking: the anchor stays
      a = old[o];
      out.stick += pressed;
    } else {
      // new, or not pressed: where the node is; slipping: moved along the
      // slip u to |u| = ε (its force unchanged)
      vec3<double> at = x;
      if (had && pressed) {
        at = af.anchor + (1 - af.eps / norm(af.u)) * af.u;
        ++out.slip;
      } else {
        out.stick += pressed;
      }
      const vec3<double> X = mul_transpose(collider_rotation(c), at - vec3<double>{c.c[0], c.c[1], c.c[2]});
      a.X[0] = X.x, a.X[1] = X.y, a.X[2] = X.z;
    }
    a.x[0] = x.x, a.x[1] = x.y, a.x[2] = x.z;
    now.push_back(a);
  }
  old = std::move(now);
  return out;
}

// At a solve's start: the anchors kept for its rods sized to them, and the
// anchors whose node has moved since their solve (a step, the user) or
// whose collider is gone dropped.
inline void drop_stale_anchors(RodBatch<double>& b, int colliders) {
  std::vector<std::vector<StaticAnchor>>& all = b.contact.static_anchors;
  if (all.size() != std::size_t(b.rod_count())) all.assign(std::size_t(b.rod_count()), {});
  for (std::vector<StaticAnchor>& v : all)
    std::erase_if(v, [&](const StaticAnchor& a) { return a.collider >= colliders || !anchor_current(b, a); });
}

}  // namespace manyrods::detail
