// Contact (include/manyrods/contact.h, docs/contact.md; docs/validation.md
// "9 Contact"): Coulomb friction on a plane (stick below μ_s m g, the sliding
// kinetic energy above it), the normal law (restitution and resting overlap
// of the derived law, no tunnelling at 1–10 m/s), rod–rod momentum exchange,
// a crossing rod that carries a load, determinism for any thread count, and
// bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "cases.h"
#include "host/core/advanced.h"

using namespace manyrods;

namespace {

constexpr double kG = 9.81;
constexpr double kR = 0.005, kLen = 0.1, kRho = 1000, kE = 1e6;

// A soft rod of radius 5 mm, 10 cm long, lying along `dir` with its
// centreline at `start`.
RodSpec lying_rod(const Vec3& start, const Vec3& dir, int n = 10, double length = kLen) {
  const Vec3 normal = std::abs(dir[2]) > 0.9 ? Vec3{1, 0, 0} : Vec3{0, 0, 1};
  RodSpec s = RodSpec::straight(start, dir, normal, length, n);
  s.name = "rod";
  s.section = Section::circle(kR);
  s.material = {kRho, kE, 0.3};
  return s;
}

template <class T>
double rod_mass(const RodBatch<T>& b, int rod) {
  double m = 0;
  for (int i = 0; i <= b.elements(rod); ++i) m += double(b.model.node_mass[b.node_index(rod, i)]);
  return m;
}
Vec3 momentum(const RodBatch<double>& b, int rod) {
  Vec3 p{0, 0, 0};
  for (int i = 0; i <= b.elements(rod); ++i) {
    const double m = b.model.node_mass[b.node_index(rod, i)];
    const Vec3 v = b.velocity(rod, i);
    for (int d = 0; d < 3; ++d) p[d] += m * v[d];
  }
  return p;
}
Vec3 com(const RodBatch<double>& b, int rod) {
  Vec3 c{0, 0, 0};
  const double m = rod_mass(b, rod);
  for (int i = 0; i <= b.elements(rod); ++i) {
    const double w = b.model.node_mass[b.node_index(rod, i)] / m;
    const Vec3 x = b.position(rod, i);
    for (int d = 0; d < 3; ++d) c[d] += w * x[d];
  }
  return c;
}

Collider floor_plane(double mu_s = 0, double mu_k = 0) {
  Collider c;
  c.name = "floor";
  c.kind = ColliderKind::plane;
  c.point = {0, 0, 0};
  c.normal = {0, 0, 1};
  c.friction.static_coefficient = mu_s;
  c.friction.kinetic_coefficient = mu_k;
  return c;
}

// ---- 9a Coulomb friction: a rod pulled along a plane ------------------------------
// A rod resting on a plane is pulled along its axis by F (each node by F m_i/m,
// so that the rod moves rigidly). It sticks for F ≤ μ_s m g; above, it slides
// with v(t) = t (F − μ_k m g)/m, i.e. kinetic energy t²(F − μ_k m g)²/(2m).
struct Pulled {
  double displacement, velocity, expected_velocity, free_displacement;
};
Pulled pull(double f_over_mus_mg) {
  const double mus = 0.5, muk = 0.3, dt = 1e-4;
  RodBatch<double> b = build_batch<double>({lying_rod({0, 0, kR}, {1, 0, 0})}, {0, 0, -kG});
  ContactSpec spec;
  spec.colliders = {floor_plane(mus, muk)};
  set_contact(b, spec);
  step_n<kCollidersNoKelvinVoigt>(b, dt, 1000);  // settle on the plane (0.1 s)
  const double m = rod_mass(b, 0), f = f_over_mus_mg * mus * m * kG;
  for (int i = 0; i <= b.elements(0); ++i)
    b.set_node_force(0, i, {f * b.model.node_mass[b.node_index(0, i)] / m, 0, 0});
  const Vec3 x0 = com(b, 0);
  const double t = 0.1;
  step_n<kCollidersNoKelvinVoigt>(b, dt, 1000);
  const Vec3 x1 = com(b, 0);
  const double vexp = f > muk * m * kG && f > mus * m * kG ? t * (f - muk * m * kG) / m : 0.0;
  return {x1[0] - x0[0], momentum(b, 0)[0] / m, vexp, 0.5 * f / m * t * t};
}

TEST(Contact, RodPulledOnPlaneSticksBelowStaticFriction) {
  for (double ratio : {0.5, 0.7, 0.8, 0.9, 0.95}) {
    const Pulled p = pull(ratio);
    // Sticking is exact in the law (the impulse that stops the contact point
    // is taken whole while it lies in the cone); what moves is the elastic
    // give of the rod under the friction couple at its surface, a small
    // fraction of the free motion ½ (F/m) t².
    EXPECT_LT(std::abs(p.displacement), 1e-3 * p.free_displacement) << "F = " << ratio << " μs m g";
  }
}

TEST(Contact, RodPulledOnPlaneSlidesWithKineticEnergyOfCoulombLaw) {
  for (double ratio : {1.2, 2.0}) {
    const Pulled p = pull(ratio);
    // Kinetic friction μ_k λ per step with the step's own λ = m g h (the rod
    // has settled): the rigid sliding is exact to round-off; the rod's
    // pitching under the friction couple (elastic, ~ μ r/L of the motion)
    // bounds the difference.
    EXPECT_NEAR(p.velocity, p.expected_velocity, 2e-3 * p.expected_velocity) << "F = " << ratio << " μs m g";
    const double ke = 0.5 * p.velocity * p.velocity, ke_exp = 0.5 * p.expected_velocity * p.expected_velocity;
    EXPECT_NEAR(ke, ke_exp, 4e-3 * ke_exp);
  }
}

// ---- 9a' The energy budget with friction: a rod on an incline ----------------------
// A rod lying along the fall line of a plane tilted by θ, released at rest.
// With μ_s > tan θ it stays; with μ_k < tan θ it slides with
// a = g (sin θ − μ_k cos θ). Budget: K + E + U − W (W the contact
// impulses' work) is constant up to the integrator's error; W is −μ_k m g
// cos θ × the distance slid (Coulomb's work) when sliding, 0 at rest.
struct Incline {
  double budget_drift, work, expected_work, slid, energy_scale;
};
Incline incline(double theta, double mu_s, double mu_k, double h, double duration) {
  const double c = std::cos(theta), sn = std::sin(theta);
  const Vec3 down{c, 0, -sn};  // the fall line
  const Vec3 n{sn, 0, c};      // the plane's normal
  RodBatch<double> b = build_batch<double>({lying_rod({kR * n[0], 0, kR * n[2]}, down)}, {0, 0, -kG});
  Collider plane = floor_plane(mu_s, mu_k);
  plane.normal = n;
  ContactSpec spec;
  spec.colliders = {plane};
  set_contact(b, spec);
  step_n<kCollidersNoKelvinVoigt>(b, h, 10);  // settle into the law's resting overlap (g h²/Ω²)
  const auto budget = [&] {
    const Energies e = energies<kCollidersNoKelvinVoigt>(b);
    return e.kinetic + e.elastic + e.potential - e.contact_work;
  };
  const double b0 = budget(), w0 = energies<kCollidersNoKelvinVoigt>(b).contact_work;
  const Vec3 x0 = com(b, 0);
  double drift = 0;
  const int steps = int(std::lround(duration / h));
  for (int i = 0; i < steps; i += 100) {
    step_n<kCollidersNoKelvinVoigt>(b, h, 100);
    drift = std::max(drift, std::abs(budget() - b0));
  }
  const Vec3 x1 = com(b, 0);
  const double slid = (x1[0] - x0[0]) * down[0] + (x1[2] - x0[2]) * down[2], m = rod_mass(b, 0);
  const double w = energies<kCollidersNoKelvinVoigt>(b).contact_work - w0;
  return {drift, w, -mu_k * m * kG * c * slid, slid, m * kG * kLen};
}

TEST(Contact, ARodRestingOnAnInclineTakesNoWorkAndItsBudgetCloses) {
  // μ_s = 0.5 > tan 15° = 0.27: the rod stays. The impulse that holds it
  // does no work (the node's velocity at the step's start and end are both
  // ~0); the budget stays at its start to round-off of m g L, where a work
  // taken from the kinetic energy after the kick (½ m (v⁺² − v⁻²)) would
  // lose ½ m g² h per second (here 3.9e-5 of m g L a second).
  const Incline r = incline(15 * std::numbers::pi / 180, 0.5, 0.3, 1e-4, 1.0);
  std::printf("resting on an incline: slid %.3g m, work %.3g, budget drift %.3g of m g L\n", r.slid,
              r.work / r.energy_scale, r.budget_drift / r.energy_scale);
  EXPECT_LT(std::abs(r.slid), 1e-6 * kLen);
  EXPECT_LT(std::abs(r.work), 1e-9 * r.energy_scale);
  EXPECT_LT(r.budget_drift, 1e-9 * r.energy_scale);
}

TEST(Contact, ARodSlidingDownAnInclineLosesCoulombsWorkAndItsBudgetCloses) {
  // μ_k = 0.1 < tan 20° = 0.36: it slides ½ a t² with a = g (sin θ − μ_k
  // cos θ) (6 cm in 0.2 s); the friction takes μ_k m g cos θ per metre, so
  // W matches it to the rod's pitching under the friction couple (~ μ r/L,
  // 0.5 %, as in the pulled rod above), and the budget closes to round-off
  // of m g L (the rigid slide is exact in the discrete work; the elastic
  // give is Verlet's O((hω)²) of an energy ~1e-6 of m g L).
  const double theta = 20 * std::numbers::pi / 180, t = 0.2;
  const Incline r = incline(theta, 0.1, 0.1, 1e-4, t);
  std::printf("sliding down an incline: slid %.4g m, work %.4g J (Coulomb %.4g J), budget drift %.3g of m g L\n",
              r.slid, r.work, r.expected_work, r.budget_drift / r.energy_scale);
  const double a = kG * (std::sin(theta) - 0.1 * std::cos(theta)), t0 = 10 * 1e-4;  // (it slid while settling)
  const double slid = 0.5 * a * ((t0 + t) * (t0 + t) - t0 * t0);
  EXPECT_NEAR(r.slid, slid, 5e-3 * slid);
  EXPECT_NEAR(r.work, r.expected_work, 5e-3 * std::abs(r.expected_work));
  EXPECT_LT(r.budget_drift, 1e-6 * r.energy_scale);
}

// ---- 9b The normal law -------------------------------------------------------------
// One contact of effective mass m_c, stepped by Position Verlet with (C1):
// the reference is the same law on a single mass (the flat rod falls as one
// body: every element's contact has m_c = the node mass, docs/contact.md).
double restitution_of_law(double v0, double gap0, double h, double omega) {
  // drift ½h, impulse, drift ½h on (gap, v)
  double g = gap0, v = -v0;
  bool touched = false;
  for (int i = 0; i < 1000000; ++i) {
    g += 0.5 * h * v;
    const double lam = std::max(0.0, -(omega * omega * g / h + omega * omega * v) / (1 + omega * omega));
    if (lam > 0) touched = true;
    v += lam;
    g += 0.5 * h * v;
    if (touched && lam == 0 && v > 0) return v / v0;
  }
  return -1;
}

struct Drop {
  double restitution, max_penetration;
};
Drop drop(double v0, double omega, double h) {
  RodBatch<double> b = build_batch<double>({lying_rod({0, 0, kR + 0.5 * v0 * h}, {1, 0, 0})}, {0, 0, 0});
  for (int i = 0; i <= b.elements(0); ++i) b.set_velocity(0, i, {0, 0, -v0});
  ContactSpec spec;
  spec.colliders = {floor_plane()};
  spec.hardness = omega;
  set_contact(b, spec);
  double deepest = 0;
  for (int i = 0; i < 4000; ++i) {
    step<kCollidersNoKelvinVoigt>(b, h);
    deepest = std::max(deepest, contact_stats(b).max_penetration);
    if (momentum(b, 0)[2] > 0 && contact_stats(b).contacts == 0 && com(b, 0)[2] > kR + 2 * v0 * h) break;
  }
  return {momentum(b, 0)[2] / rod_mass(b, 0) / v0, deepest};
}

TEST(Contact, DroppedRodReboundsWithTheRestitutionOfTheLaw) {
  const double h = 1e-4, omega = 0.2;
  const double e_cont = std::exp(-std::numbers::pi * (omega / 2) / std::sqrt(1 - omega * omega / 4));
  for (double v0 : {1.0, 3.0, 10.0}) {
    const Drop d = drop(v0, omega, h);
    const double e_law = restitution_of_law(v0, 0.5 * v0 * h, h, omega);
    // the flat rod falls as one body: the law's scalar recurrence to round-off
    EXPECT_NEAR(d.restitution, e_law, 1e-9) << "v0 = " << v0;
    // backward Euler's damping c = h k is ζ = Ω/2: the continuous law's
    // e = exp(−πζ/√(1 − ζ²)) up to the O(Ω²) of the discrete phase
    EXPECT_NEAR(e_law, e_cont, omega * omega) << "v0 = " << v0;
    // the spring: depth v0 √(m/k) = v0 h/Ω (less: damped), and never through
    EXPECT_LT(d.max_penetration, v0 * h / omega);
    EXPECT_GT(d.max_penetration, 0.5 * v0 * h / omega);
  }
}

TEST(Contact, FastDropDoesNotTunnelAtDefaultHardness) {
  const double h = 1e-4;
  for (double v0 : {1.0, 10.0, 100.0}) {
    const Drop d = drop(v0, 2.0, h);
    // the impulse acts on the predicted end-of-step gap: the first step that
    // would overlap stops at 1/(1 + Ω²) of the overshoot, at most v0 h/5
    EXPECT_LT(d.max_penetration, v0 * h / 5 + 1e-12) << "v0 = " << v0;
    EXPECT_LT(d.restitution, 0.2);  // hard contacts are nearly inelastic (e ≈ 0.1 for Ω = 2, docs/contact.md)
    EXPECT_GE(d.restitution, 0.0);
  }
}

TEST(Contact, RestingOverlapIsWeightOverStiffness) {
  const double h = 1e-4, omega = 2.0;
  RodBatch<double> b = build_batch<double>({lying_rod({0, 0, kR}, {1, 0, 0})}, {0, 0, -kG});
  ContactSpec spec;
  spec.colliders = {floor_plane()};
  spec.hardness = omega;
  set_contact(b, spec);
  step_n<kCollidersNoKelvinVoigt>(b, h, 3000);
  // at rest λ = m_c g h and λ = h k (−g) with k = Ω² m_c/h²: overlap g h²/Ω²
  const double expect = kG * h * h / (omega * omega);
  EXPECT_NEAR(contact_stats(b).max_penetration, expect, 1e-6 * expect + 1e-15);
  EXPECT_LT(std::abs(momentum(b, 0)[2]), 1e-12);
}

// ---- 9c Rod–rod ---------------------------------------------------------------------
struct Collision {
  Vec3 p0, pa, pb;
  double e0, e_end, work;
  bool touched;
};
Collision collide(double h, double omega) {
  RodBatch<double> b = build_batch<double>(
      {lying_rod({-0.05, 0, 0}, {1, 0, 0}), lying_rod({0.01, -0.05, 2 * kR + 0.002}, {0, 1, 0})}, {0, 0, 0});
  for (int i = 0; i <= b.elements(1); ++i) b.set_velocity(1, i, {0, 0, -1});
  ContactSpec spec;
  spec.rod_rod = true;
  spec.hardness = omega;
  set_contact(b, spec);
  Collision c;
  c.p0 = momentum(b, 1);
  c.e0 = energies<kRodContactNoKelvinVoigt>(b).total();
  c.touched = false;
  const int steps = int(std::lround(0.01 / h));
  for (int i = 0; i < steps; ++i) {
    step<kRodContactNoKelvinVoigt>(b, h);
    c.touched = c.touched || contact_stats(b).contacts > 0;
  }
  c.pa = momentum(b, 0);
  c.pb = momentum(b, 1);
  const Energies e = energies<kRodContactNoKelvinVoigt>(b);
  c.e_end = e.total();
  c.work = e.contact_work;
  return c;
}

TEST(Contact, FrictionlessRodRodCollisionConservesMomentum) {
  const Collision c = collide(1e-4, 0.5);
  ASSERT_TRUE(c.touched);
  EXPECT_LT(c.pa[2], -0.1 * std::abs(c.p0[2]));  // rod 0 was pushed down (the falling rod drapes over it)
  // the two sides of a pair take bit-identical opposite impulses: the total
  // momentum changes only by the round-off of the node sums
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(c.pa[d] + c.pb[d], c.p0[d], 1e-15) << d;
  EXPECT_LT(c.work, 0);
}

// A thin rod (r = 0.5 mm) thrown at v across another thin rod, at the rods'
// own stable step (0.9 stable_dt), both free, no gravity. Per step it moves
// v h, up to several diameters: the broad phase lists partners within the
// step's reach and the law acts on the end-of-step gap, so it must never
// pass through (its centreline stays on its side: z > 0 for every node
// over the crossing).
struct Throw {
  double lowest_z, h, per_step;
  bool touched;
};
Throw throw_across(double v) {
  const double r = 0.5e-3;
  auto thin = [&](const Vec3& start, const Vec3& dir) {
    RodSpec s = lying_rod(start, dir, 20, 0.1);
    s.section = Section::circle(r);
    return s;
  };
  RodSpec target = thin({-0.05, 0, 0}, {1, 0, 0});
  target.clamped_root = target.clamped_tip = true;  // a thin wire held at both ends
  RodBatch<double> b = build_batch<double>({target, thin({0, -0.05, 0.01}, {0, 1, 0})}, {0, 0, 0});
  for (int i = 0; i <= b.elements(1); ++i) b.set_velocity(1, i, {0, 0, -v});
  ContactSpec spec;
  spec.rod_rod = true;
  set_contact(b, spec);
  const double h = 0.9 * stable_dt<kNoKelvinVoigt>(b).elastic;
  Throw t{1e9, h, v * h, false};
  const int steps = int(std::ceil(0.03 / v / h)) + 20;  // to 2 cm below the other rod, unchecked
  for (int i = 0; i < steps; ++i) {
    step<kRodContactNoKelvinVoigt>(b, h);
    t.touched = t.touched || contact_stats(b).contacts > 0;
    // the crossing stays at x = y = 0 (the throw is symmetric): the thrown
    // rod's middle node above the wire's (tunnelling: below it)
    t.lowest_z = std::min(t.lowest_z, b.position(1, 10)[2] - b.position(0, 10)[2]);
  }
  return t;
}

TEST(Contact, AThinFastRodNeverTunnelsThroughAnother) {
  // (at the stable step of this thread, 2.3e-5 s, 30 m/s is 0.7 diameters a
  // step; at 100 m/s, 2.3 diameters a step, it passes through: the limit
  // docs/contact.md states)
  for (double v : {1.0, 10.0, 30.0}) {
    const Throw t = throw_across(v);
    std::printf("thin rod at %g m/s: h = %.3g s, %.2f diameters a step, centrelines at least %.3g m apart\n", v, t.h,
                t.per_step / 1e-3, t.lowest_z);
    EXPECT_TRUE(t.touched) << v;
    // resting-contact distance 2r less the law's impact overlap (≤ v h/(1 + Ω²) = v h/17 at Ω = 4)
    EXPECT_GT(t.lowest_z, 2 * 0.5e-3 - t.per_step / 17 - 1e-9) << "v = " << v << " m/s";
  }
}

TEST(Contact, EnergyBudgetClosesAtFirstOrderThroughContact) {
  // kinetic + elastic − (work of the contact impulses) stays at its start
  // value up to the integrator's error. Contact switches on and off between
  // steps, which makes that error first order in h (a smooth force would
  // leave Verlet's second order): halving h halves it.
  const Collision a = collide(1e-4, 0.5), b = collide(5e-5, 0.5);
  const double ea = a.e_end - a.work - a.e0, eb = b.e_end - b.work - b.e0;
  EXPECT_LT(std::abs(ea), 0.05 * a.e0);
  EXPECT_GT(std::abs(eb / ea), 0.35);
  EXPECT_LT(std::abs(eb / ea), 0.65);
}

TEST(Contact, RodOnTwoCrossingRodsCarriesItsWeight) {
  const double h = 1e-4;
  std::vector<RodSpec> rods = {lying_rod({-0.05, -0.03, kR}, {1, 0, 0}), lying_rod({-0.05, 0.03, kR}, {1, 0, 0}),
                               lying_rod({0.005, -0.05, 3 * kR}, {0, 1, 0})};
  for (RodSpec& r : rods) r.damping = Damping::shear_extension(0.01, 0.01);  // to come to rest
  RodBatch<double> b = build_batch<double>(rods, {0, 0, -kG});
  ContactSpec spec;
  spec.colliders = {floor_plane()};
  spec.rod_rod = true;
  set_contact(b, spec);
  step_n<kAllContact>(b, h, 5000);
  // the top rod rests on the two others: its supports 2r above their centrelines
  EXPECT_GT(b.position(2, 2)[2], 3 * kR - 0.02 * kR);
  EXPECT_GT(b.position(2, 8)[2], 3 * kR - 0.02 * kR);
  // and the rod–rod impulses on it carry its weight: Σ p = m g h per step
  // (at rest to the decay of its vibration, e^{−t/τ} after 0.5 s); the
  // damped rods meet each other in their solve (elem_q0, q1)
  double pz = 0, pz_stage = 0;
  for (int e = 0; e < b.elements(2); ++e) {
    const int k = b.elem_index(2, e);
    pz += b.contact.elem_q0[2][k] + b.contact.elem_q1[2][k];
    pz_stage += b.contact.elem_p0[2][k] + b.contact.elem_p1[2][k];
  }
  EXPECT_EQ(pz_stage, 0.0);
  EXPECT_NEAR(pz / h, rod_mass(b, 2) * kG, 1e-3 * rod_mass(b, 2) * kG);
}

// ---- 9f Capstan -----------------------------------------------------------------------
// A flexible rope over a fixed horizontal cylinder (a capsule), wrapped by
// θ = π, held by T₁ at one end and pulled by T₂ at the other, no gravity:
// Coulomb friction holds it while T₂/T₁ ≤ e^{μθ} (Euler–Eytelwein) and it
// slips above. Bending stiffness raises the threshold by about EI/(T R²)
// (here 4e-4, the rope stiffened in stretch, not in bending); the polygon of
// 14 elements on the half turn changes it by O(μ²Δθ²) ≈ 5e-3. The brackets
// 0.9 and 1.1 e^{μθ} lie well outside both.
double capstan_slip(double ratio) {
  const double R = 0.02, r = 0.001, L = 0.3, mu = 0.3, T1 = 1.0;
  const int n = 60;
  const double rc = R + r, arc = std::numbers::pi * rc, leg = 0.5 * (L - arc);
  // nodes on the arc a little outside, so that the chords between them clear the drum
  const double rn = rc / std::cos(0.5 * L / n / rc) + 1e-6;
  std::vector<Vec3> nodes;
  for (int j = 0; j <= n; ++j) {
    const double s = L * j / n;
    if (s < leg) nodes.push_back({-rn, 0, -(leg - s)});
    else if (s < leg + arc) {
      const double a = std::numbers::pi * (1 - (s - leg) / arc);
      nodes.push_back({rn * std::cos(a), 0, rn * std::sin(a)});
    } else {
      nodes.push_back({rn, 0, -(s - leg - arc)});
    }
  }
  RodSpec rope = RodSpec::polyline(nodes, RodSpec::parallel_transport_frames(nodes, {0, 1, 0}));
  rope.name = "rope";
  rope.section = Section::circle(r);
  rope.material = {1000, 1e6, 0.3};
  rope.shear_stretch_scale = 100;  // EA = 314 N: 1 % stretch at T = 3 N
  rope.stiff_implicit = true;
  rope.damping = Damping::shear_extension(2e-3, 2e-3);
  RodBatch<double> b = build_batch<double>({rope}, {0, 0, 0});
  Collider drum;
  drum.name = "drum";
  drum.kind = ColliderKind::capsule;
  drum.a = {0, -0.05, 0};
  drum.b = {0, 0.05, 0};
  drum.radius = R;
  drum.friction = {mu, mu};
  ContactSpec spec;
  spec.colliders = {drum};
  set_contact(b, spec);
  const double T2 = ratio * std::exp(mu * std::numbers::pi) * T1;
  // the loads ramp up over 0.05 s (no jerk), then hold
  const double h = 2e-5;
  for (int i = 0; i < 5000; ++i) {
    const double ramp = std::min(1.0, (i + 1) * h / 0.05);
    b.set_node_force(0, 0, {0, 0, -ramp * T1});
    b.set_node_force(0, n, {0, 0, -ramp * T2});
    step<kColliders>(b, h);
  }
  const double z0 = b.position(0, n)[2];
  step_n<kColliders>(b, h, 2500);
  return z0 - b.position(0, n)[2];  // how far the pulled end went down in 0.05 s
}

TEST(Contact, CapstanHoldsBelowEulerEytelweinAndSlipsAbove) {
  const double held = capstan_slip(0.9), slipped = capstan_slip(1.1);
  std::printf("capstan: end moved %.3g m at 0.9 e^{μθ}, %.3g m at 1.1 e^{μθ}\n", held, slipped);
  // held: the end moves only by the elastic give of the pulled leg, less than
  // its whole static stretch T₂ l_leg/EA = 2.3 N × 0.117 m / 314 N = 0.86 mm;
  // slipping: the net 0.1 e^{μθ} T₁ = 0.26 N accelerates the 0.9 g rope, far
  EXPECT_LT(std::abs(held), 0.86e-3);
  EXPECT_GT(slipped, 5e-3);
}

// The head the stiff hair (cases::hair, root at the origin along +x) swings
// onto: a sphere of radius 0.097 m centred 0.1 m along and `below` under
// its root, `aside` across, friction 0.4 / 0.3.
Collider hair_head(double below = 0.1, double aside = 0) {
  Collider head;
  head.kind = ColliderKind::sphere;
  head.center = {0.1, aside, -below};
  head.radius = 0.097;
  head.friction = {0.4, 0.3};
  return head;
}

// The solve takes its lane groups' collider contacts right after each
// group's factorization; where it does not (here: with self contact on, the
// contacts wait for the broad phase and every rod is solved again in the
// stage after the solve), the stage takes them. Both run the same kept
// solve and the same contact solve on each rod, in its lane: the same bits,
// for rods with a clamped root and rods with a driven one (solved relative
// to its motion, which goes back before the contacts). A regression
// reference of the fused path against the stage's, exact.
TEST(Contact, TheSolvesFusedCollidersGiveTheStagesResultBitForBit) {
  auto run = [](bool stage, int threads) {
    std::vector<RodSpec> rods;
    for (int i = 0; i < 11; ++i) {  // a group of 8 lanes and one of 3 (AVX-512 double)
      RodSpec s = cases::hair(32, true, Damping::shear_extension(1e-3, 1e-3));
      for (Vec3& x : s.nodes) x[1] += 0.002 * i;
      if (i % 3 == 1) {  // the root sliding at (5, 0, −2) cm/s
        auto slide = std::make_shared<KeyframedMotion>();
        slide->times = {0, 100};
        slide->translations = {{0, 0, 0}, {5, 0, -2}};
        s.root_motion = slide;
      }
      rods.push_back(s);
    }
    RodBatch<double> b = build_batch<double>(rods, {0, 0, -kG});
    ContactSpec spec;
    spec.colliders = {hair_head(0.1, 0.01)};
    spec.self = stage;  // (straight hairs on a head never meet themselves)
    set_contact(b, spec);
    std::int64_t touching = 0;
    for (int i = 0; i < 40; ++i) {
      if (stage) step_n<kAllContact>(b, 3e-4, 25, Exec{threads});
      else step_n<kColliders>(b, 3e-4, 25, Exec{threads});
      touching += contact_stats(b).contacts;
    }
    EXPECT_GT(touching, 0);
    return state_hash(b);
  };
  const std::uint64_t fused = run(false, 1);
  EXPECT_EQ(fused, run(true, 1));
  EXPECT_EQ(fused, run(false, 2));
  EXPECT_EQ(fused, run(true, 2));
}

// ---- 9g Contact does not shrink the step ----------------------------------------------
// Stiff hair at a frame-rate step, swinging down onto a head below it: the
// step the scene takes without contact (3e-4 s, about half the flexural
// stable_dt) stays stable, and the hair stays outside to within the law's
// bound on one step's overshoot, |v| h/(1 + Ω²) < 35 µm for a tip at
// 2 m/s (less than the hair's radius, 40 µm).
TEST(Contact, StiffHairAtFrameRateStepOnAHead) {
  RodBatch<double> b =
      build_batch<double>({cases::hair(32, true, Damping::shear_extension(1e-3, 1e-3))}, {0, 0, -kG});
  ContactSpec spec;
  spec.colliders = {hair_head()};
  set_contact(b, spec);
  double deepest = 0;
  std::int64_t touching = 0;
  for (int i = 0; i < 100; ++i) {
    advance<kColliders>(b, 3e-4, 30);  // throws NonFiniteError if it went unstable
    const ContactStats cs = contact_stats(b);
    deepest = std::max(deepest, cs.max_penetration);
    touching += cs.contacts;
  }
  EXPECT_GT(touching, 0);
  EXPECT_LT(deepest, 40e-6);
  const Energies e = energies<kColliders>(b);
  EXPECT_LT(e.contact_work, 0);
}

// The mechanical energy K + E + U of a stiff, damped hair at its frame-rate
// step never rises above where it started beyond the integrator's error,
// whatever it hits: nothing drives it, and the solve and the contact law
// only take energy. Sampled every step; returns the highest rise.
template <class T>
double highest_energy_rise(RodBatch<T>& b, T h, int steps) {
  auto mech = [&] {
    const Energies e = energies<kColliders>(b);
    return e.kinetic + e.elastic + e.potential;
  };
  const double e0 = mech();
  double rise = 0;
  for (int i = 0; i < steps; ++i) {
    step<kColliders>(b, h);
    rise = std::max(rise, mech() - e0);
  }
  return rise;
}

TEST(Contact, AStiffHairSwungOntoAHeadOrDroppedOnAFloorNeverGainsEnergy) {
  auto swing = [&](bool head_on, double h) {
    RodBatch<double> b =
        build_batch<double>({cases::hair(32, true, Damping::shear_extension(1e-3, 1e-3))}, {0, 0, -kG});
    ContactSpec spec;
    spec.colliders = {hair_head(head_on ? 0.1 : 10.0)};
    set_contact(b, spec);
    const double fall = rod_mass(b, 0) * kG * 0.1;  // m g × the fall of its middle, a scale
    return highest_energy_rise(b, h, int(0.9 / h)) / fall;
  };
  // swung from the horizontal onto a head (clamped at the root), at the
  // frame-rate step (3e-4 s, about half the flexural stable_dt) and half it
  const double free = swing(false, 3e-4), onto = swing(true, 3e-4), onto_half = swing(true, 1.5e-4);
  // a hair 20 cm long, clamped, falling flat at 1 m/s onto a floor (friction 0.4)
  RodSpec flat = cases::hair(32, true, Damping::shear_extension(1e-3, 1e-3));
  const RodSpec line = RodSpec::straight({0, 0, 0.002}, {1, 0, 0}, {0, 0, 1}, cases::kHairL, 32);
  flat.nodes = line.nodes;
  flat.frames = line.frames;
  flat.clamped_root = false;
  RodBatch<double> b = build_batch<double>({flat}, {0, 0, -kG});
  for (int i = 0; i <= 32; ++i) b.set_velocity(0, i, {0, 0, -1.0});
  ContactSpec spec;
  spec.colliders = {floor_plane(0.4, 0.3)};
  set_contact(b, spec);
  const double k0 = energies<kColliders>(b).kinetic;
  const double dropped = highest_energy_rise(b, 3e-4, 2000) / k0;
  std::printf("highest rise of K + E + U: swinging freely %.3g, onto a head %.3g (%.3g at h/2) of m g × 0.1 m; "
              "dropped flat %.3g of K0\n", free, onto, onto_half, dropped);
  // Onto the head: the rise is Position Verlet's error in the bending modes
  // the impact excites (self-convergence: at least second order, the
  // integrator's, so halving h cuts it at least 4×; measured 0.48 → 0.097
  // → 0 at h/4), and below the energy of the fall (with contact after the
  // solve the elastic energy rose to ~14× it).
  EXPECT_LE(onto_half, 0.25 * onto + 1e-12);
  EXPECT_LT(onto, 1.0);
  // Dropped flat: the impulses are uniform, nothing bends, and K + E + U
  // falls through the impact (round-off: 1e-9 of K0).
  EXPECT_LE(dropped, 1e-9);
}

// A damped stiff hair clamped with its root node just inside a floor
// (0.1 µm), rising 2 mm over its length, falling onto the floor: the
// contact at the held root (s = 0) acts but cannot move, its W_ii is zero
// and the sticking system is singular there (every step: the solve takes
// the normal impulse alone, which moves nothing, and must not divide by
// the zero pivot). The hair comes to rest on the
// floor: a finite state, its tip on the floor within its radius, and K + E
// + U never above its start by the energy of the fall (the swing above
// gives the scale of the bending error: 0.48 of it at this step).
TEST(Contact, AHairClampedWithItsRootOnAFloorFallsOntoIt) {
  const double r = 40e-6, rise_over_l = 0.002 / cases::kHairL;
  RodSpec hair = cases::hair(32, true, Damping::shear_extension(1e-3, 1e-3));
  const double len = std::sqrt(1 + rise_over_l * rise_over_l);
  const RodSpec line = RodSpec::straight({0, 0, r - 1e-7}, {1 / len, 0, rise_over_l / len}, {0, 0, 1},
                                         cases::kHairL, 32);
  hair.nodes = line.nodes;
  hair.frames = line.frames;
  RodBatch<double> b = build_batch<double>({hair}, {0, 0, -kG});
  ContactSpec spec;
  spec.colliders = {floor_plane(0.4, 0.3)};
  set_contact(b, spec);
  const double fall = rod_mass(b, 0) * kG * 0.001;  // m g × the fall of its middle
  const double rise = highest_energy_rise(b, 3e-4, 2000);
  std::printf("hair clamped on a floor: rise %.3g of its fall's energy, tip at %.3g m\n", rise / fall,
              b.position(0, 32)[2]);
  for (int i = 0; i <= 32; ++i) ASSERT_TRUE(std::isfinite(b.position(0, i)[2]));
  EXPECT_GT(contact_stats(b).contacts, 1);
  EXPECT_GT(b.position(0, 32)[2], 0.0);      // on the floor, not through it
  EXPECT_LT(b.position(0, 32)[2], 2 * r);    // and down on it
  EXPECT_LT(rise, fall);
}

// Eight of those hairs side by side in a float batch: their stiff solve
// and its contacts run in double (a lane group of 8), the state in float.
// The same bounds as in double: no energy beyond the fall's scale (double
// gives 0.48 of it; float's rounding of K + E + U is ~1e-7 of m g z, far
// below), and the contacts keep every hair outside the head (the law's
// resting overlap is ~1e-6 m; 4 µm = 0.1 r).
TEST(Contact, StiffHairsInAFloatBatchMeetAHeadInTheirDoubleSolve) {
  std::vector<RodSpec> hairs;
  for (int i = 0; i < 8; ++i) {
    RodSpec hair = cases::hair(32, true, Damping::shear_extension(1e-3, 1e-3));
    for (Vec3& x : hair.nodes) x[1] += 0.002 * i;
    hairs.push_back(hair);
  }
  RodBatch<float> b = build_batch<float>(hairs, {0, 0, -kG});
  ContactSpec spec;
  spec.colliders = {hair_head(0.1, 0.007)};
  set_contact(b, spec);
  double fall = 0;
  for (int r = 0; r < 8; ++r) fall += rod_mass(b, r) * kG * 0.1;
  const float h = 3e-4f;
  const double rise = highest_energy_rise(b, h, int(0.3 / h)) / fall;
  double deepest = 0;
  int touching = 0;
  for (int i = 0; i < 20; ++i) {
    advance<kColliders>(b, h, 100);
    deepest = std::max(deepest, double(contact_stats(b).max_penetration));
    touching += contact_stats(b).contacts;
  }
  std::printf("float batch of 8 stiff hairs onto a head: rise %.3g of m g × 0.1 m, deepest overlap %.3g m\n", rise,
              deepest);
  EXPECT_GT(touching, 0);
  EXPECT_LT(rise, 1.0);
  EXPECT_LT(deepest, 4e-6);
}

// The seed cantilever bending sideways under gravity onto a wall, at 0.9 ×
// its stable_dt: stable, and the tip stays outside the wall.
TEST(Contact, SeedCantileverOntoAPlaneAtItsStableStep) {
  RodBatch<double> b =
      build_batch<double>({cases::seed_cantilever(50, Damping::shear_extension(0.02, 0.02))}, {-kG, 0, 0});
  const double dt = 0.9 * stable_dt<kAllTerms>(b).elastic;
  Collider wall;
  wall.kind = ColliderKind::plane;
  wall.point = {-0.1, 0, 0};
  wall.normal = {1, 0, 0};
  ContactSpec spec;
  spec.colliders = {wall};
  set_contact(b, spec);
  const int steps = int(1.0 / dt);
  double deepest = 0;
  for (int i = 0; i < 50; ++i) {
    advance<kColliders>(b, dt, steps / 50);
    deepest = std::max(deepest, contact_stats(b).max_penetration);
  }
  EXPECT_GT(contact_stats(b).contacts, 0);            // it leans on the wall
  EXPECT_LT(deepest, 0.01 * 0.5 * std::sqrt(2.0) * 0.01);  // 1 % of its contact radius
  EXPECT_GT(b.position(0, 50)[0], -0.1);
}

// ---- 9j An overhand knot pulled tight -------------------------------------------------
// A trefoil x = a (sin t + 2 sin 2t, cos t − 2 cos 2t, −sin 3t), cut at its
// outermost point t₀ = π/3 (a short arc ±0.15 removed), its ends led out
// radially by 12 mm and then apart along the knot's tangent there: an open
// overhand knot, 3 diameters clear of itself. Clamped at one end, pulled at
// the other, with self contact and friction.
std::vector<Vec3> overhand_knot(double a, double step) {
  auto knot = [a](double t) {
    return Vec3{a * (std::sin(t) + 2 * std::sin(2 * t)), a * (std::cos(t) - 2 * std::cos(2 * t)), -a * std::sin(3 * t)};
  };
  const double t0 = std::numbers::pi / 3, cut = 0.15, out = 0.012, tail = 0.1;
  const Vec3 radial{std::sin(t0), std::cos(t0), 0};  // the point's direction in the plane
  const Vec3 along{-radial[1], radial[0], 0};         // the tangent there, in the plane
  auto at = [](const Vec3& p, const Vec3& d, double s) { return Vec3{p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2]}; };
  std::vector<Vec3> nodes;
  auto line = [&](const Vec3& p, const Vec3& q) {  // p excluded, q included
    const double len = std::sqrt((q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) + (q[2] - p[2]) * (q[2] - p[2]));
    const int n = std::max(1, int(std::ceil(len / step)));
    for (int i = 1; i <= n; ++i) nodes.push_back(at(p, {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, double(i) / n));
  };
  const Vec3 k0 = knot(t0 + cut), k1 = knot(t0 + 2 * std::numbers::pi - cut);
  const Vec3 corner0 = at(k0, radial, out), start = at(corner0, along, tail);
  nodes.push_back(start);
  line(start, corner0);
  line(corner0, k0);
  const int m = int(std::ceil(27.6 * a / step));  // the knot's points, ~step apart (it is 27.6 a long)
  for (int i = 1; i <= m; ++i) nodes.push_back(knot(t0 + cut + (2 * std::numbers::pi - 2 * cut) * i / m));
  const Vec3 corner1 = at(k1, radial, out);
  line(k1, corner1);
  line(corner1, at(corner1, along, -tail));
  return nodes;
}

TEST(Contact, OverhandKnotPulledTightHoldsAndNeverPassesThroughItself) {
  const double r = 0.001, D = 2 * r;
  const std::vector<Vec3> nodes = overhand_knot(0.005, 0.002);
  RodSpec s = RodSpec::polyline(nodes, RodSpec::parallel_transport_frames(nodes, {0, 0, 1}));
  s.name = "rope";
  s.section = Section::circle(r);
  s.material = {kRho, kE, 0.3};
  s.damping = Damping::shear_extension(2e-3, 2e-3);
  s.clamped_root = true;
  RodBatch<double> b = build_batch<double>({s}, {0, 0, 0});
  const int n = b.elements(0);
  double length = 0;
  for (int e = 0; e < n; ++e) length += b.model.elem_rest_length[b.elem_index(0, e)];
  auto span = [&] {
    const Vec3 p = b.position(0, 0), q = b.position(0, n);
    return std::sqrt((q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) + (q[2] - p[2]) * (q[2] - p[2]));
  };
  ContactSpec spec;
  spec.self = true;
  spec.friction = {0.3, 0.3};
  set_contact(b, spec);  // also: the knot starts clear of itself
  const double deficit0 = length - span();
  const double F = 0.05;  // N, pulling the free end away from the clamped one, along the tails
  const double t0 = std::numbers::pi / 3;
  b.set_node_force(0, n, {F * std::cos(t0), -F * std::sin(t0), 0});
  const double dt = 0.5 * stable_dt<kAllTerms>(b).elastic;
  // overlaps sampled every 4th step (a node moves < 0.4 mm = 0.2 D in 4
  // steps here); the slack's range over the last half of the run
  double deepest = 0, late_min = 1e9, late_max = -1e9, mean[2] = {0, 0};
  int samples[2] = {0, 0};
  const int steps = int(0.6 / dt);
  for (int i = 0; i < steps; ++i) {
    step<kRodContact>(b, dt);
    if (i % 4 == 0) deepest = std::max(deepest, contact_stats(b).max_penetration);
    if (b.state.time >= 0.3) {
      const double slack = length - span();
      late_min = std::min(late_min, slack);
      late_max = std::max(late_max, slack);
      const int half = b.state.time < 0.45 ? 0 : 1;
      mean[half] += slack;
      ++samples[half];
    }
  }
  const double deficit = length - span();
  std::printf("knot: %d elements, L = %.4f m, slack %.1f D -> %.1f D (%.1f..%.1f D after 0.3 s, means %.2f, %.2f D), "
              "deepest overlap %.3g m\n",
              n, length, deficit0 / D, deficit / D, late_min / D, late_max / D, mean[0] / samples[0] / D,
              mean[1] / samples[1] / D, deepest);
  // Passing through itself needs two centrelines to meet (an overlap of D);
  // the law keeps the overlap to a small fraction of r (the tension F over
  // the contact stiffness Ω² m_c/h² is ~1 µm, impacts add |v| h/(1 + Ω²)).
  EXPECT_LT(deepest, 0.25 * r);
  // Pulled tight: the loose knot gave up most of its slack (78.6 D)...
  EXPECT_LT(deficit, 0.5 * deficit0);
  // ...and holds: a strand still wrapped once around another (diameter D)
  // keeps a loop of centreline radius ≥ D, 2π D of rope over a span of
  // about 2 D, so the ends stay at least (2π − 2) D ≈ 4.3 D short of the
  // rope's length; an untied rope would straighten to its full length.
  EXPECT_GT(late_min, (2 * std::numbers::pi - 2) * D);
  // It has stopped slipping: over the last 0.3 s the slack only breathes
  // with the tails' vibration (here 11.5–14.2 D), with periods near
  // 2π/(π c / 2 L_tail) ≈ 14 ms (c = √(E/ρ)), so its means over 0.30–0.45 s
  // and 0.45–0.60 s (~10 periods each) agree to a fraction of that range;
  // a knot sliding undone under F would lose slack at the tail's speed,
  // tens of D in 0.15 s.
  mean[0] /= samples[0];
  mean[1] /= samples[1];
  EXPECT_LT(std::abs(mean[1] - mean[0]), 1.0 * D);
}

// ---- 9d Determinism and what contact costs when it is off -----------------------------
std::vector<RodSpec> tuft(int count) {
  std::vector<RodSpec> rods;
  for (int i = 0; i < count; ++i) {
    const double a = 2 * std::numbers::pi * i / count;
    RodSpec s = lying_rod({0.006 * std::cos(a), 0.006 * std::sin(a), 0.06}, {0, 0, 1}, 12, 0.05);
    s.name = "strand " + std::to_string(i);
    s.section = Section::circle(0.0015);
    s.clamped_root = true;
    s.damping = Damping::shear_extension(1e-3, 1e-3);
    rods.push_back(s);
  }
  return rods;
}

// (capacity: the lists' first capacity; growths: how often they grew, and to what)
std::uint64_t tuft_hash(int threads, std::int64_t* contacts = nullptr, double skin = 0, std::int64_t* rebuilds = nullptr,
                        int capacity = 256, std::pair<std::int64_t, int>* growths = nullptr) {
  RodBatch<double> b = build_batch<double>(tuft(12), {0, 0, -kG});
  ContactSpec spec;
  Collider head;
  head.kind = ColliderKind::sphere;
  head.center = {0.0, 0.0, 0.05};
  head.radius = 0.008;
  head.friction = {0.4, 0.3};
  spec.colliders = {head};
  spec.rod_rod = spec.self = true;
  spec.friction = {0.3, 0.2};
  spec.skin = skin;
  spec.capacity = capacity;  // 256: room for every pair at the widest skin
  set_contact(b, spec);
  // one strand flung sideways: its elements reach far (the broad phase's
  // "wide" elements, docs/contact.md)
  for (int e = 0; e <= 12; ++e) b.set_velocity(3, e, {-2.0 * e / 12, 0, 0});
  const Exec ex{threads};
  std::int64_t seen = 0;
  for (int i = 0; i < 30; ++i) {
    step_n<kAllContact>(b, 1e-4, 20, ex);
    seen += contact_stats(b).contacts;
  }
  if (contacts) *contacts = seen;
  if (rebuilds) *rebuilds = contact_stats(b).rebuilds;
  if (growths) *growths = {b.contact.list_growths, b.contact.capacity};
  return state_hash(b);
}

TEST(Contact, GroomWithRodRodContactIsBitIdenticalForAnyThreadCount) {
  std::int64_t contacts = 0;
  const std::uint64_t one = tuft_hash(1, &contacts);
  EXPECT_GT(contacts, 0);  // the strands touch the head and each other
  EXPECT_EQ(one, tuft_hash(2));
  EXPECT_EQ(one, tuft_hash(3));
}

// The candidate lists are supersets of the pairs in range, each in slot
// order: how wide they reach and when they are rebuilt cannot change a bit.
TEST(Contact, TheBroadPhaseNeverChangesTheResult) {
  std::int64_t tight = 0, loose = 0, medium = 0;
  const std::uint64_t automatic = tuft_hash(2, nullptr, 0, &tight);
  EXPECT_EQ(automatic, tuft_hash(2, nullptr, 0.02, &loose));  // every pair listed
  EXPECT_EQ(automatic, tuft_hash(1, nullptr, 0.002, &medium));
  EXPECT_GT(tight, medium);
  EXPECT_GT(medium, loose);
}

TEST(Contact, CollidersKeepTemporalBlocking) {
  auto run = [](bool blocked) {
    RodBatch<double> b = build_batch<double>(tuft(12), {0, 0, -kG});
    ContactSpec spec;
    spec.colliders = {floor_plane(0.5, 0.4)};
    spec.colliders[0].point = {0, 0, 0.03};
    set_contact(b, spec);
    if (blocked) step_n<kColliders>(b, 1e-4, 600, Exec{2});
    else
      for (int i = 0; i < 600; ++i) step<kColliders>(b, 1e-4);
    return state_hash(b);
  };
  EXPECT_EQ(run(true), run(false));
}

TEST(Contact, EmptyContactChangesNothing) {
  RodBatch<double> a = build_batch<double>(tuft(4), {0, 0, -kG});
  RodBatch<double> b = build_batch<double>(tuft(4), {0, 0, -kG});
  set_contact(b, ContactSpec{});
  step_n<kAllTerms>(a, 1e-4, 200);
  step_n<kColliders>(b, 1e-4, 200);
  EXPECT_EQ(state_hash(a), state_hash(b));
}

// ---- 9e Bad input ------------------------------------------------------------------
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(Contact, BadInputIsNamed) {
  RodBatch<double> b = build_batch<double>({lying_rod({0, 0, kR}, {1, 0, 0})}, {0, 0, -kG});
  ContactSpec spec;
  spec.colliders = {floor_plane(-0.1, 0)};
  EXPECT_NE(error_of([&] { set_contact(b, spec); }).find("collider 0 ('floor'), plane: friction static"),
            std::string::npos);
  spec.colliders = {floor_plane(0.2, 0.3)};
  EXPECT_NE(error_of([&] { set_contact(b, spec); }).find("exceeds the static"), std::string::npos);
  spec.colliders = {floor_plane()};
  spec.colliders[0].point = {0, 0, 0.003};
  const std::string inside = error_of([&] { set_contact(b, spec); });
  EXPECT_NE(inside.find("rod 0 ('rod') node"), std::string::npos) << inside;
  EXPECT_NE(inside.find("starts inside collider 0 ('floor')"), std::string::npos) << inside;
  spec.colliders[0].point = {0, 0, 0};
  spec.hardness = 0;
  EXPECT_NE(error_of([&] { set_contact(b, spec); }).find("hardness"), std::string::npos);
  spec.hardness = 2;
  set_contact(b, spec);
  EXPECT_NE(error_of([&] { step_pefrl<kColliders>(b, 1e-4); }).find("Position Verlet only"), std::string::npos);
  // two rods that start overlapping each other
  RodBatch<double> two =
      build_batch<double>({lying_rod({0, 0, 0.1}, {1, 0, 0}), lying_rod({0.05, -0.05, 0.1 + kR}, {0, 1, 0})}, {0, 0, -kG});
  ContactSpec rods;
  rods.rod_rod = true;
  const std::string overlap = error_of([&] { set_contact(two, rods); });
  EXPECT_NE(overlap.find("rod 0 ('rod') element 4 starts overlapping rod 1 ('rod') element 4"), std::string::npos)
      << overlap;
  RodBatch<double> none = build_batch<double>({lying_rod({0, 0, kR}, {1, 0, 0})}, {0, 0, -kG});
  EXPECT_NE(error_of([&] { step<kColliders>(none, 1e-4); }).find("set_contact"), std::string::npos);
}

TEST(Contact, NeighbourListsGrowToTheSameStepAndStopAtTheirLimitWithAnError) {
  // Lists that start at one candidate grow (doubling, or to the longest
  // list) whenever one overflows, and are gathered again: the lists, so the
  // step, are those of a capacity that never overflows (the reference:
  // capacity 256, bit for bit), for any thread count.
  const std::uint64_t roomy = tuft_hash(1);
  std::pair<std::int64_t, int> grown{0, 0};
  EXPECT_EQ(tuft_hash(1, nullptr, 0, nullptr, 1, &grown), roomy);
  EXPECT_GE(grown.first, 1);
  EXPECT_GT(grown.second, 1);
  EXPECT_EQ(tuft_hash(2, nullptr, 0, nullptr, 1), roomy);
  // beyond max_capacity: an error naming the element, its count and the key
  RodBatch<double> b = build_batch<double>(tuft(12), {0, 0, -kG});
  ContactSpec spec;
  spec.rod_rod = true;
  spec.capacity = 1;
  spec.max_capacity = 1;
  spec.skin = 0.01;
  const std::string e = error_of([&] { set_contact(b, spec); });  // the first lists are built here
  EXPECT_NE(e.find("rod-rod candidates"), std::string::npos) << e;
  EXPECT_NE(e.find("more than max_capacity = 1"), std::string::npos) << e;
  EXPECT_NE(e.find("[contact] max_capacity"), std::string::npos) << e;
  spec.max_capacity = 0;
  EXPECT_NE(error_of([&] { set_contact(b, spec); }).find("max_capacity (0) must be >= capacity (1)"),
            std::string::npos);
}

}  // namespace

// A damped cable (r = 5 mm, 25 elements, 0.5 m, E = 50 MPa: the cable pile's)
// dropped crosswise at 1 and 5 m/s onto another held at both ends, under
// gravity, at its scene step (0.9 stable_dt), τ = 0.005 and 0.05 s (h τ ω²
// ≫ 1 at the element scale: the rods the implicit solve steps, their
// contact with each other a stage after it). Energy: Kelvin–Voigt, the
// contact law (backward Euler) and friction only remove energy, so
// K + E + U never rises above its start but by round-off (1e-9 of K0, as
// the stiff hair dropped on a floor). No pass-through: the thrown cable's
// crossing point (the middle of its element 12, over the other's) stays
// above the other's. The overlap is reported against r (measured 0.27 mm =
// 0.05 r at 5 m/s, τ = 0.05 s; 0.21 mm undamped: the cable's momentum
// reaches the contact through its elastic forces over several steps, beyond
// the single contact's v h/17) and bounded by r/4, as the plectoneme's.
// A damped cable (a soft polymer jacket: radius r, 0.5 m in 25 elements,
// E = 50 MPa, τ for shear and extension) lying from `start` along `dir`.
namespace {
RodSpec damped_cable(const Vec3& start, const Vec3& dir, double r, double tau) {
  RodSpec s = lying_rod(start, dir, 25, 0.5);
  s.section = Section::circle(r);
  s.material = {1400, 5e7, 0.45};
  s.damping = Damping::shear_extension(tau, tau);
  return s;
}
}  // namespace

TEST(Contact, ADampedCableDroppedOnAnotherNeverGainsEnergyNorPassesThrough) {
  for (double v : {1.0, 5.0})
    for (double tau : {0.005, 0.05, -0.05}) {
      // (τ < 0: τ = 0.05 s, the lower cable's root driven by a motion that
      // stands still: a rod with prescribed velocities, the solve's
      // scalar path)
      const bool driven = tau < 0;
      tau = std::abs(tau);
      const double r = 5e-3;
      auto cable = [&](const Vec3& start, const Vec3& dir) { return damped_cable(start, dir, r, tau); };
      RodSpec bottom = cable({-0.25, 0, 0}, {1, 0, 0});
      bottom.clamped_root = bottom.clamped_tip = true;
      if (driven) {
        auto still = std::make_shared<KeyframedMotion>();
        still->times = {0, 100};
        still->translations = {{0, 0, 0}, {0, 0, 0}};
        bottom.root_motion = still;
      }
      RodBatch<double> b = build_batch<double>({bottom, cable({0, -0.25, 0.02}, {0, 1, 0})}, {0, 0, -kG});
      for (int i = 0; i <= b.elements(1); ++i) b.set_velocity(1, i, {0, 0, -v});
      ContactSpec spec;
      spec.rod_rod = true;
      spec.friction = {0.4, 0.3};
      set_contact(b, spec);
      const double h = 0.9 * stable_dt<kRodContact>(b).elastic;
      auto mech = [&] {
        const Energies e = energies<kRodContact>(b);
        return e.kinetic + e.elastic + e.potential;
      };
      const double e0 = mech(), k0 = energies<kRodContact>(b).kinetic;
      double rise = 0, lowest = 1e9, deepest = 0;
      bool touched = false;
      for (int i = 0; i < int(0.2 / h); ++i) {
        step<kRodContact>(b, h);
        rise = std::max(rise, mech() - e0);
        lowest = std::min(lowest, 0.5 * (b.position(1, 12)[2] + b.position(1, 13)[2] - b.position(0, 12)[2] -
                                         b.position(0, 13)[2]));
        const ContactStats cs = contact_stats(b);
        touched = touched || cs.contacts > 0;
        deepest = std::max(deepest, cs.max_penetration);
      }
      std::printf("damped cable (tau %g s) dropped at %g m/s on another: highest rise of K + E + U %.3g of K0, "
                  "crossing centrelines %.4g m apart at the closest (2r = %.3g), deepest overlap %.3g m\n",
                  tau, v, rise / k0, lowest, 2 * r, deepest);
      EXPECT_TRUE(touched);
      EXPECT_LE(rise, 1e-9 * k0) << "tau " << tau << " v " << v;
      EXPECT_GT(lowest, 0.0) << "tau " << tau << " v " << v;
      EXPECT_LT(deepest, 0.25 * r) << "tau " << tau << " v " << v;
    }
}

// ---- Rod–rod contacts in the solve ----------------------------------------------------
// The stiff hair of the swing above, onto another stiff hair clamped at
// both ends across its path (5 cm below its root, at x = 15 cm) instead of
// a head: both are stepped by the implicit solve, so they meet each other
// inside it, each predicting the other's motion and the iterations between
// them making the pair consistent (docs/contact.md). The bounds are those of
// the head (the same hair, the same integrator error: at most the energy of
// the fall at this step, at least 4× less at h/2; a rigid capsule in the
// other hair's place gives 0.215 and 0); a stage after the solve gained
// 260× that energy here (161× with the crossing 2 cm below). Both sides'
// impulses are opposite to the bit (their mean): the total is round-off.
// (The sweeps stall on ~5 % of the steps: exact Coulomb friction, as
// docs/contact.md says; frictionless they converge, next test.)
template <class T>
double stiff_hair_onto_another(double h) {
  {
    RodSpec a = cases::hair(32, true, Damping::shear_extension(1e-3, 1e-3));
    RodSpec across = cases::hair(32, true, Damping::shear_extension(1e-3, 1e-3));
    const RodSpec line = RodSpec::straight({0.15, -0.1, -0.05}, {0, 1, 0}, {0, 0, 1}, cases::kHairL, 32);
    across.nodes = line.nodes;
    across.frames = line.frames;
    across.clamped_tip = true;
    RodBatch<T> b = build_batch<T>({a, across}, {0, 0, -kG});
    ContactSpec spec;
    spec.rod_rod = true;
    spec.friction = {0.4, 0.3};
    set_contact(b, spec);
    auto mech = [&] {
      const Energies e = energies<kRodContact>(b);
      return e.kinetic + e.elastic + e.potential;
    };
    const double e0 = mech();
    double rise = 0, sum = 0, imbalance = 0;
    for (int i = 0; i < int(0.6 / h); ++i) {
      step<kRodContact>(b, T(h));
      rise = std::max(rise, mech() - e0);
      Vec3 q[2] = {{0, 0, 0}, {0, 0, 0}};
      for (int r = 0; r < 2; ++r)
        for (int e = 0; e < 32; ++e)
          for (int d = 0; d < 3; ++d) {
            const int k = b.elem_index(r, e);
            q[r][d] += b.contact.elem_q0[d][k] + b.contact.elem_q1[d][k];
          }
      for (int d = 0; d < 3; ++d) {
        sum += std::abs(q[0][d]);
        imbalance = std::max(imbalance, std::abs(q[0][d] + q[1][d]));
      }
    }
    const ContactStats cs = contact_stats(b);
    std::printf("stiff hair onto a stiff hair (%s) at h = %g: highest rise of K + E + U %.3g of m g × 0.1 m; "
                "sweeps %.3g a step on average, at most %d, %lld of %lld steps stalled; "
                "impulse imbalance %.3g of their sum\n",
                sizeof(T) == 4 ? "float" : "double", h, rise / (rod_mass(b, 0) * kG * 0.1), double(cs.solve_sweeps) / double(std::max<std::int64_t>(cs.solve_steps, 1)),
                cs.solve_sweeps_max, (long long)cs.solve_stalled, (long long)cs.solve_steps, imbalance / sum);
    EXPECT_GT(sum, 0.0);  // they touched
    // opposite impulses (round-off of the node sums; float: its rounding)
    EXPECT_LE(imbalance, (sizeof(T) == 4 ? 1e-5 : 1e-12) * sum);
    return rise / (rod_mass(b, 0) * kG * 0.1);
  }
}

TEST(Contact, AStiffHairSwungOntoAnotherNeverGainsEnergy) {
  const double onto = stiff_hair_onto_another<double>(3e-4), onto_half = stiff_hair_onto_another<double>(1.5e-4);
  EXPECT_LT(onto, 1.0);
  EXPECT_LE(onto_half, 0.25 * onto + 1e-12);
  // in a float batch (their stiff solves and contacts in double, the state
  // in float): the same bound; float's rounding of K + E + U is ~1e-7 of
  // m g z, far below it
  EXPECT_LT(stiff_hair_onto_another<float>(3e-4), 1.0);
}

// Two damped rods meeting obliquely in their solve, no gravity, with and
// without friction: each pair has one impulse, +p on one rod and −p on the
// other, so the total momentum changes only by the round-off of the sums
// (10⁻¹² of the moving rod's momentum), and the contacts take work.
// Frictionless, the sweeps solve a positive definite problem (W of the two
// rods plus the law's compliance) and converge on every step.
TEST(Contact, RodsMeetingInTheirSolveKeepTheirMomentum) {
  for (const bool friction : {false, true}) {
  std::vector<RodSpec> rods = {lying_rod({-0.05, 0, 0}, {1, 0, 0}), lying_rod({0.01, -0.05, 2 * kR + 0.002}, {0, 1, 0})};
  for (RodSpec& r : rods) r.damping = Damping::shear_extension(0.01, 0.01);
  RodBatch<double> b = build_batch<double>(rods, {0, 0, 0});
  for (int i = 0; i <= b.elements(1); ++i) b.set_velocity(1, i, {0.3, 0.2, -1});
  ContactSpec spec;
  spec.rod_rod = true;
  if (friction) spec.friction = {0.4, 0.3};
  set_contact(b, spec);
  const Vec3 p0 = momentum(b, 1);
  bool touched = false;
  for (int i = 0; i < 100; ++i) {
    step<kRodContact>(b, 1e-4);
    touched = touched || contact_stats(b).contacts > 0;
  }
  ASSERT_TRUE(touched);
  const Vec3 pa = momentum(b, 0), pb = momentum(b, 1);
  EXPECT_LT(pa[2], -0.1 * std::abs(p0[2]));  // rod 0 was pushed down
  EXPECT_GT(contact_stats(b).solve_steps, 0);  // in the solve
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(pa[d] + pb[d], p0[d], 1e-12 * std::abs(p0[2])) << d;
  EXPECT_LT(energies<kRodContact>(b).contact_work, 0);
  if (!friction) {
    EXPECT_EQ(contact_stats(b).solve_stalled, 0);
  }
  }
}

// ---- Sweeps that start from the last step's impulses ----------------------------------
// A damped cable (τ = 0.05 s) lying across another, clamped at both ends,
// and a third lying on a floor, with friction: at rest their contacts'
// impulses carry the weight and do not change from one step to the next,
// so sweeps started from the last step's impulses (ContactData::
// solve_impulses) find them solved: the first sweep moves no contact
// velocity by more than the tolerance (the counter counts the sweeps after
// the first: 0). From zero the same steps take ~20 sweeps (the floor
// cable's 26 contacts converge by ~0.5 a sweep to the tolerance 1e-6).
// From the same state a step with them and a step without solve the same
// problem: both stop where no update moves a contact velocity by more than
// tol·scale (scale ≈ g h at rest, the free solve's approach speed), each
// within tol·scale·ρ/(1−ρ) ≤ tol·scale of the solution per contact at ρ ≤
// 0.5, so the nodes' velocities differ by at most the 28 contacts' sum of
// it twice, < 100 tol·g h (independent of the guess: a self-consistency).
TEST(Contact, SweepsStartFromTheLastStepsImpulses) {
  const double r = 5e-3, tau = 0.05;
  auto cable = [&](const Vec3& start, const Vec3& dir) { return damped_cable(start, dir, r, tau); };
  RodSpec bottom = cable({-0.25, 0, 0.1}, {1, 0, 0});
  bottom.clamped_root = bottom.clamped_tip = true;
  RodBatch<double> b =
      build_batch<double>({bottom, cable({0, -0.25, 0.1 + 2 * r}, {0, 1, 0}), cable({-0.25, 0.3, r}, {1, 0, 0})},
                          {0, 0, -kG});
  ContactSpec spec;
  spec.rod_rod = true;
  spec.colliders = {floor_plane()};
  spec.friction = {0.4, 0.3};
  set_contact(b, spec);
  const double h = 0.9 * stable_dt<kAllContact>(b).elastic;
  for (int i = 0; i < int(0.5 / h); ++i) step<kAllContact>(b, h);
  auto sweeps_over = [&](RodBatch<double>& c, int n, bool cold) {
    const std::int64_t s0 = contact_stats(c).solve_sweeps, t0 = contact_stats(c).solve_steps;
    for (int i = 0; i < n; ++i) {
      if (cold)
        for (auto& l : c.contact.solve_impulses) l.clear();
      step<kAllContact>(c, h);
    }
    return double(contact_stats(c).solve_sweeps - s0) / double(contact_stats(c).solve_steps - t0);
  };
  RodBatch<double> warm = b, cold = b;
  const double sw = sweeps_over(warm, 100, false), sc = sweeps_over(cold, 100, true);
  RodBatch<double> one_warm = b, one_cold = b;
  for (auto& l : one_cold.contact.solve_impulses) l.clear();
  step<kAllContact>(one_warm, h);
  step<kAllContact>(one_cold, h);
  double dv = 0;
  for (int k = 0; k < b.slots(); ++k)
    for (int d = 0; d < 3; ++d)
      dv = std::max(dv, std::abs(one_warm.state.node_v[d][k] - one_cold.state.node_v[d][k]));
  std::size_t kept = 0;
  for (const auto& l : b.contact.solve_impulses) kept += l.size();
  std::printf("cables at rest: %zu contact impulses kept; sweeps a step after the first: %.3g from them, %.3g "
              "from zero; one step from both: velocities %.3g m/s apart (g h = %.3g m/s)\n",
              kept, sw, sc, dv, kG * h);
  EXPECT_EQ(kept, 28u);  // the crossing (one on each side) and the floor cable's 26 nodes
  EXPECT_LT(sw, 0.1);
  EXPECT_GT(sc, 10.0);
  EXPECT_LT(dv, 100 * kContactSweepTolerance<double> * kG * h);
}

// A batch with colliders stepped with Terms that have rod–rod contact but
// no colliders meets no collider (the Terms choose the physics): a rod over
// a floor falls through it, and with the colliders' Terms it stays above.
TEST(Contact, TermsWithoutCollidersMeetNoCollider) {
  for (const bool colliders : {false, true}) {
    std::vector<RodSpec> rods = {lying_rod({-0.05, 0, 0.01}, {1, 0, 0}), lying_rod({-0.05, 0.05, 0.01}, {1, 0, 0})};
    for (RodSpec& r : rods) r.damping = Damping::shear_extension(0.01, 0.01);
    RodBatch<double> b = build_batch<double>(rods, {0, 0, -kG});
    ContactSpec spec;
    spec.rod_rod = true;
    spec.colliders = {floor_plane()};
    set_contact(b, spec);
    for (int i = 0; i < 1000; ++i) colliders ? step<kAllContact>(b, 1e-4) : step<kRodContact>(b, 1e-4);
    // 0.1 s of free fall from 1 cm: 4.9 cm down without the floor
    if (colliders) EXPECT_GT(b.position(0, 5)[2], 0.0);
    else EXPECT_LT(b.position(0, 5)[2], -0.03);
  }
}

