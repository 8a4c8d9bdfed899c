// docs/validation.md "9k Plectonemes keep their linking number" — a rod
// clamped at both ends and twisted by ten turns coils up, its twist going
// over into writhe. The linking number of the centreline with a ribbon
// drawn on it (the curve x + ε d1) can change only by turning a clamp or by
// the rod passing through itself (a jump of ±2): with self contact it stays
// at −10 and Călugăreanu's Lk = Tw + Wr holds throughout; without, the
// same rod untwists through itself.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <Eigen/Dense>

#include "host/core/advanced.h"

using namespace manyrods;

namespace {

constexpr double kPi = std::numbers::pi;
using V = Eigen::Vector3d;

// Gauss linking integral of the polygon segments a→b and c→d, exactly (the
// solid angle the pair subtends, Klenin & Langowski, Biopolymers 54, 2000,
// "method 1"), over 4π.
double gauss_pair(const V& a, const V& b, const V& c, const V& d) {
  const V r13 = c - a, r14 = d - a, r23 = c - b, r24 = d - b;
  V n[4] = {r13.cross(r14), r14.cross(r24), r24.cross(r23), r23.cross(r13)};
  for (V& x : n) {
    const double l = x.norm();
    if (!(l > 0)) return 0;  // the segments meet or are collinear: no solid angle
    x /= l;
  }
  auto as = [](double x) { return std::asin(std::clamp(x, -1.0, 1.0)); };
  const double omega = as(n[0].dot(n[1])) + as(n[1].dot(n[2])) + as(n[2].dot(n[3])) + as(n[3].dot(n[0]));
  const double sign = (d - c).cross(b - a).dot(r13) > 0 ? 1 : -1;
  return sign * omega / (4 * kPi);
}

double linking(const std::vector<V>& p, const std::vector<V>& q) {
  double lk = 0;
  for (std::size_t i = 0; i + 1 < p.size(); ++i)
    for (std::size_t j = 0; j + 1 < q.size(); ++j) lk += gauss_pair(p[i], p[i + 1], q[j], q[j + 1]);
  return lk;
}

double writhe(const std::vector<V>& p) {
  double wr = 0;
  for (std::size_t i = 0; i + 1 < p.size(); ++i)
    for (std::size_t j = i + 2; j + 1 < p.size(); ++j) wr += 2 * gauss_pair(p[i], p[i + 1], p[j], p[j + 1]);
  return wr;
}

struct Topology {
  double lk = 0, tw = 0, wr = 0;
};

// The rod's centreline and its ribbon, each continued far (Λ = 10⁴ L) along
// the clamps' common axis e3 beyond both ends (the closure of open rods used
// for plectonemes, e.g. PyElastica's "next tangent" extension), so that
// their linking integral differs from that of closed curves by O(ε/Λ).
// Ribbon: x + ε d1 at the clamps and the element midpoints, ε = r/2 (inside
// the tube: no other strand comes nearer than ~2r − overlap). Twist: the
// turn of d1 (projected normal to the segment) against its parallel
// transport from segment to segment, clamps included; writhe: the Gauss
// double integral of the extended centreline.
Topology topology(const RodBatch<double>& b, double eps, double ext) {
  const int n = b.elements(0), o = b.rods[0].offset;
  auto x = [&](int j) {
    const Vec3 p = b.position(0, j);
    return V(p[0], p[1], p[2]);
  };
  auto d1 = [&](int slot) { return V(b.state.elem_Q[0][slot], b.state.elem_Q[1][slot], b.state.elem_Q[2][slot]); };
  const V axis(0, 0, 1);
  std::vector<V> c, r, t;
  std::vector<V> u;
  c.push_back(x(0) - ext * axis);
  r.push_back(x(0) + eps * d1(o) - ext * axis);
  t.push_back(axis);
  u.push_back(d1(o));  // root clamp (ghost element o)
  for (int j = 0; j <= n; ++j) c.push_back(x(j));
  r.push_back(x(0) + eps * d1(o));
  for (int e = 0; e < n; ++e) {
    r.push_back(0.5 * (x(e) + x(e + 1)) + eps * d1(o + 1 + e));
    t.push_back((x(e + 1) - x(e)).normalized());
    u.push_back(d1(o + 1 + e));
  }
  r.push_back(x(n) + eps * d1(o + n + 1));
  c.push_back(x(n) + ext * axis);
  r.push_back(x(n) + eps * d1(o + n + 1) + ext * axis);
  t.push_back(axis);
  u.push_back(d1(o + n + 1));  // tip clamp (ghost element o + n + 1)
  Topology out;
  out.lk = linking(c, r);
  out.wr = writhe(c);
  double turn = 0;
  for (std::size_t i = 0; i + 1 < t.size(); ++i) {
    const V ta = t[i], tb = t[i + 1];
    const V ua = (u[i] - u[i].dot(ta) * ta).normalized(), ub = (u[i + 1] - u[i + 1].dot(tb) * tb).normalized();
    // parallel transport ta → tb: the rotation about ta × tb
    const V k = ta.cross(tb);
    const V pu = ua + k.cross(ua) + k.cross(k.cross(ua)) / (1 + ta.dot(tb));
    turn += std::atan2(pu.cross(ub).dot(tb), pu.dot(ub));
  }
  out.tw = turn / (2 * kPi);
  return out;
}

struct TwistRun {
  double max_lk_error = 0;   // |Lk − Lk₀| over the samples
  double max_calugareanu = 0;  // |Lk − Tw − Wr|
  double final_lk = 0, final_tw = 0, final_wr = 0, max_wr = 0;
  double deepest = 0;
  std::int64_t final_contacts = 0;
  double lk_jump = 0;  // the largest change of Lk between two samples
};

// Rod: L = 1 m, r = 2.5 cm, E = 1 MPa, ν = 0.5, ρ = 1000, 100 elements (the
// plectoneme case of PyElastica's examples at its radius and modulus),
// clamped at both ends 0.55 m apart. It starts as the first clamped–clamped
// buckling shape of its length (tangent angle θ(s) = θ₀ sin(2πs/L) in the
// x–z plane, which puts the tip on the axis; θ₀ found for 45 % slack)
// twisted by N = 10 turns (d1 turned by −2πN s/L about the tangent), at
// rest; its rest shape is straight and untwisted. Released, it coils up;
// light Kelvin–Voigt damping (τ = 2 ms, implicit: bending ζ₁ ≈ 0.01, the
// element-scale modes overdamped) lets it settle within the 4 s run.
TwistRun plectoneme(bool self_contact, double tau = 2e-3) {
  const int n = 100;
  const double L = 1, r = 0.025, slack = 0.45, turns = 10, duration = 4;
  // the S shape with tangent angle θ₀ sin(2πs/L) whose ends are (1 − slack) L apart
  auto shape = [&](double theta0) {
    std::vector<Vec3> x(n + 1);
    V p(0, 0, 0);
    for (int j = 0; j <= n; ++j) {
      x[j] = {p.x(), p.y(), p.z()};
      const double th = theta0 * std::sin(2 * kPi * (j + 0.5) / n);
      p += (L / n) * V(std::sin(th), 0, std::cos(th));
    }
    x[n][0] = 0;  // on the axis up to round-off; exactly
    return x;
  };
  double lo = 0, hi = 2.4;  // the span falls monotonically with θ₀ on [0, 2.4] (J₀'s first zero)
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (shape(mid)[n][2] > (1 - slack) * L ? lo : hi) = mid;
  }
  const std::vector<Vec3> nodes = shape(0.5 * (lo + hi));
  std::vector<Mat3> frames = RodSpec::parallel_transport_frames(nodes, {0, 1, 0});
  for (int e = 0; e < n; ++e) {  // rows d1, d2 turned about d3 by α
    const double a = -2 * kPi * turns * (e + 0.5) / n, c = std::cos(a), sn = std::sin(a);
    Mat3& q = frames[e];
    for (int i = 0; i < 3; ++i) {
      const double d1 = q[i], d2 = q[3 + i];
      q[i] = c * d1 + sn * d2;
      q[3 + i] = -sn * d1 + c * d2;
    }
  }
  RodSpec s = RodSpec::polyline(nodes, frames);
  s.name = "twisted rod";
  s.section = Section::circle(r);
  s.material = {1000, 1e6, 0.5};
  s.damping = Damping::shear_extension(tau, tau);
  s.rest_curvature.assign(n - 1, Vec3{0, 0, 0});
  // clamp frames along the axis (d1 = e2, d2 = −e1, d3 = e3); the clamp
  // joints take their rest curvature from this starting geometry
  const Mat3 axial{0, 1, 0, -1, 0, 0, 0, 0, 1};
  s.clamped_root = true;
  s.root_frame = axial;
  s.clamped_tip = true;
  s.tip_frame = axial;
  RodBatch<double> b = build_batch<double>({s}, {0, 0, 0});
  ContactSpec spec;
  spec.self = self_contact;
  spec.capacity = 128;  // r = 2.5 l: a strand lying on another lists ~4r/l of its elements, and more at the loops
  set_contact(b, spec);
  const double dt = 0.9 * stable_dt<kRodContact>(b).elastic;
  const double eps = 0.5 * r, ext = 1e4 * L;
  const Topology t0 = topology(b, eps, ext);
  TwistRun out;
  double prev = 0;
  const int every = int(std::ceil(0.01 / dt));  // samples every ~10 ms
  const int steps = int(duration / dt);
  for (int i = 1; i <= steps; ++i) {
    step<kRodContact>(b, dt);
    if (self_contact && i % 4 == 0) out.deepest = std::max(out.deepest, contact_stats(b).max_penetration);
    if (i % every != 0 && i != steps) continue;
    const Topology t = topology(b, eps, ext);
    const double dev = t.lk - t0.lk;
    out.max_lk_error = std::max(out.max_lk_error, std::abs(dev));
    out.lk_jump = std::max(out.lk_jump, std::abs(dev - prev));
    out.max_calugareanu = std::max(out.max_calugareanu, std::abs(t.lk - t.tw - t.wr));
    out.max_wr = std::max(out.max_wr, std::abs(t.wr));
    out.final_lk = t.lk;
    out.final_tw = t.tw;
    out.final_wr = t.wr;
  }
  if (self_contact) out.final_contacts = contact_stats(b).contacts;
  std::printf("plectoneme (self contact %s, tau %g s): %d steps of %.3g s; Lk %.4f = Tw %.4f + Wr %.4f at the end; "
              "max |Lk - Lk0| %.3g, largest jump %.3g, max |Lk - Tw - Wr| %.3g, max |Wr| %.3f, deepest %.3g m\n",
              self_contact ? "on" : "off", tau, steps, dt, out.final_lk, out.final_tw, out.final_wr, out.max_lk_error,
              out.lk_jump, out.max_calugareanu, out.max_wr, out.deepest);
  return out;
}

}  // namespace

TEST(Plectoneme, WithoutSelfContactTheRodPassesThroughItself) {
  // The control: the same rod without self contact lets its twist out by
  // passing through itself, each passage changing Lk by 2 (it ends near 0).
  const TwistRun without = plectoneme(false);
  EXPECT_GT(without.max_lk_error, 1.99);
}

TEST(Plectoneme, TwistedRodCoilsAndKeepsItsLinkingNumber) {
  const TwistRun with = plectoneme(true);
  // Lk of the centreline and its ribbon is topological: with the clamps
  // still it changes only when the ribbon crosses the centreline (a strand
  // passing through another: ±2; a ribbon cutting its own centreline at a
  // kink tighter than ε: ±1). What is left is round-off of ~10⁴ solid
  // angles and the far ends (their pairs subtend O(ε/Λ) = 1e-6).
  EXPECT_LT(with.max_lk_error, 1e-4);
  EXPECT_NEAR(with.final_lk, -10.0, 1e-4);
  // Călugăreanu–White for the framed, extended polygon: Lk = Tw + Wr (Tw by
  // parallel transport across the joints, Wr the polygon's exact Gauss
  // integral; the ribbon at the element midpoints is the vertex ribbon
  // deformed without crossing the centreline, the frames turning by < π per
  // element). Exact up to the same round-off and far-end terms.
  EXPECT_LT(with.max_calugareanu, 1e-4);
  // It coiled: more than one of the ten turns went over into writhe (the
  // planar starting arch has Wr = 0; measured −2.5 at the end), its strands
  // pressed on each other at the end...
  EXPECT_GT(std::abs(with.final_wr), 1.0);
  EXPECT_GT(with.final_contacts, 0);
  // ...without passing: overlaps stay a small fraction of r (the law's
  // overlap under the strands' pressure, docs/contact.md).
  EXPECT_LT(with.deepest, 0.25 * 0.025);
}

TEST(Plectoneme, HeavilyDampedRodKeepsItsLinkingNumber) {
  // The same rod at τ = 0.05 s: h τ ω² ≫ 1 at the element scale, so an
  // impulse on a node after the solve would be spread along the rod by the
  // next solve (a stage after the solve let its strands pass). Its self
  // contacts are solved inside its implicit solve, through the rod's own
  // factored system: Lk is kept exactly as at τ = 2 ms (the same topological
  // round-off bound), and the strands never overlap by more than the law's
  // share of r.
  const TwistRun with = plectoneme(true, 0.05);
  EXPECT_LT(with.max_lk_error, 1e-4);
  EXPECT_NEAR(with.final_lk, -10.0, 1e-4);
  EXPECT_LT(with.max_calugareanu, 1e-4);
  EXPECT_GT(with.final_contacts, 0);
  EXPECT_LT(with.deepest, 0.25 * 0.025);
}
