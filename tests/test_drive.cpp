// Driven roots (include/manyrods/drive.h; docs/validation.md "6a Galilean
// invariance and rigid spin" to "6c Base excitation against
// Euler–Bernoulli"): a clamped root that follows a prescribed rigid motion.
// Exact identities (Galilean invariance, a rod spun about its own axis), the
// order of the time error, and base excitation of the seed cantilever
// against Euler–Bernoulli theory.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <vector>

#include "cases.h"

using namespace manyrods;

namespace {

using cases::distance;
using cases::hair;
using cases::kHairL;
using cases::kL;
using cases::max_distance;
using cases::seed_cantilever;

constexpr double kEps = std::numeric_limits<double>::epsilon();

// A constant velocity v of the root from t = 0 (keys at 0 and 100 s).
std::shared_ptr<KeyframedMotion> constant_velocity(const Vec3& v) {
  auto m = std::make_shared<KeyframedMotion>();
  m->times = {0, 100};
  m->translations = {{0, 0, 0}, {100 * v[0], 100 * v[1], 100 * v[2]}};
  return m;
}

struct GalileanCase {
  const char* name;
  RodSpec rod;
  Vec3 gravity;
  bool explicit_rate;
  double duration;
};

// The rod with every velocity shifted by v and its root moving at v.
RodSpec moving(RodSpec s, const Vec3& v) {
  s.velocities.assign(s.nodes.size(), v);
  s.root_motion = constant_velocity(v);
  return s;
}

template <Viscous kV>
void check_galilean(const GalileanCase& c, double dt, std::int64_t steps) {
  const Vec3 v = {0.3, -0.2, 0.5};
  // Three batches: still root alone, moving root alone (scalar solve), both
  // in one batch (one lane group of the rod-per-lane solve).
  auto still = build_batch<double>({c.rod}, c.gravity);
  auto alone = build_batch<double>({moving(c.rod, v)}, c.gravity);
  auto both = build_batch<double>({c.rod, moving(c.rod, v)}, c.gravity);
  advance<kAllTerms, kV>(still, dt, steps);
  advance<kAllTerms, kV>(alone, dt, steps);
  advance<kAllTerms, kV>(both, dt, steps);
  const double t = still.state.time, L = distance(c.rod.nodes.front(), c.rod.nodes.back());
  // In exact arithmetic x_moving(t) = x_still(t) + v t for every node: the
  // drifts add h v to every node (the root's mean velocity is v), the kicks
  // see the same strains, and the strain rates in the implicit solve are the
  // same only if the root's prescribed velocity enters it (a solve that took
  // the root at rest would damp the whole rod towards rest). What is left is
  // the round-off of positions of size L + |v| t: up to 100 ulps per step
  // (the stiff rods' direct-form solve rounds relative to the pre-solve
  // velocities of the stiff modes, far larger than the motion's).
  const double tol = 100 * double(steps) * kEps * (L + std::hypot(v[0], v[1], v[2]) * t);
  double worst = 0, worst_both = 0, moved = 0;
  for (int j = 0; j <= c.rod.elements(); ++j) {
    const Vec3 xs = still.position(0, j);
    const Vec3 shifted = {xs[0] + v[0] * t, xs[1] + v[1] * t, xs[2] + v[2] * t};
    worst = std::max(worst, distance(alone.position(0, j), shifted));
    worst_both = std::max(worst_both, distance(both.position(1, j), shifted));
    moved = std::max(moved, distance(xs, c.rod.nodes[j]));
  }
  std::printf("%s: %lld steps, the still rod moved %.3e m; |x_moving - x_still - v t| = %.3e (alone), %.3e (lanes), bound %.3e\n",
              c.name, (long long)steps, moved, worst, worst_both, tol);
  EXPECT_GT(moved, 1e-3 * L) << "the case must move";
  EXPECT_LT(worst, tol);
  EXPECT_LT(worst_both, tol);
  // and the driven rod carries no spurious strain rate: its velocities are
  // the still rod's plus v
  for (int j = 1; j <= c.rod.elements(); ++j) {
    const Vec3 vs = still.velocity(0, j), vm = alone.velocity(0, j);
    EXPECT_LT(distance(vm, {vs[0] + v[0], vs[1] + v[1], vs[2] + v[2]}), 1e3 * tol / dt) << "node " << j;
  }
}

}  // namespace

TEST(DrivenRoot, GalileanInvarianceImplicitKelvinVoigt) {
  // The seed cantilever with τ = 0.02 s, gravity sideways: it swings and is
  // damped; the implicit solve carries the root's velocity.
  const GalileanCase c{"seed cantilever, implicit KV", seed_cantilever(20, Damping::shear_bulk(0.02, 0.02)),
                       {-9.81, 0, 0}, false, 0.05};
  const double dt = 0.5 * stable_dt(build_batch<double>({c.rod})).elastic;
  check_galilean<Viscous::implicit>(c, dt, std::llround(c.duration / dt));
}

TEST(DrivenRoot, GalileanInvarianceExplicitKelvinVoigt) {
  const GalileanCase c{"seed cantilever, explicit KV", seed_cantilever(20, Damping::shear_bulk(0.002, 0.002)),
                       {-9.81, 0, 0}, true, 0.02};
  const StableDt s = stable_dt(build_batch<double>({c.rod}));
  const double dt = 0.5 * std::min(s.elastic, s.explicit_viscous);
  check_galilean<Viscous::explicit_rate>(c, dt, std::llround(c.duration / dt));
}

TEST(DrivenRoot, GalileanInvarianceStiffHair) {
  // Stiff rods: the root's velocity also enters the implicit shear/stretch/
  // twist stiffness (backward Euler on x + h u⁺ includes the root's h v).
  const GalileanCase c{"stiff hair with KV", hair(32, true, Damping::shear_bulk(1e-3, 1e-3)), {0, 0, -9.81},
                       false, 0.2};
  check_galilean<Viscous::implicit>(c, 1e-4, 2000);
}

namespace {

// Rotation about `axis` (unit) by angle a, as rows of a row-major Mat3.
Eigen::Matrix3d rot(const Eigen::Vector3d& axis, double a) { return Eigen::AngleAxisd(a, axis).toRotationMatrix(); }

void check_spin(RodSpec rod, const Eigen::Vector3d& axis, double rate, double dt, std::int64_t steps) {
  // Root turning at `rate` about the rod's own axis (through its root); the
  // rod starts spinning with it. Rotation about the symmetry axis of a
  // section with I1 = I2 strains nothing and (Jω)×ω = 0, so every frame turns
  // rigidly, Q(t) = Q₀ R(t)ᵀ, and the nodes stay put. The clamp frame's
  // angular velocity must reach the implicit twist damping (a solve that took
  // the clamp at rest would damp the spin at the root).
  struct Spin : RootMotion {
    Eigen::Vector3d axis, pivot;
    double rate = 0;
    Pose at(double t) const override {
      const Eigen::Matrix3d r = rot(axis, rate * t);
      const Eigen::Vector3d c = pivot - r * pivot;
      Pose p;
      for (int i = 0; i < 9; ++i) p.rotation[i] = r(i / 3, i % 3);
      p.translation = {c[0], c[1], c[2]};
      return p;
    }
  };
  auto m = std::make_shared<Spin>();
  m->axis = axis;
  m->pivot = {rod.nodes[0][0], rod.nodes[0][1], rod.nodes[0][2]};
  m->rate = rate;
  rod.root_motion = m;
  rod.angular_velocities.assign(rod.frames.size(), {0, 0, rate});  // material: about d3
  auto b = build_batch<double>({rod, rod});                         // a lane group and …
  auto single = build_batch<double>({rod});                         // … the scalar solve
  advance(b, dt, steps);
  advance(single, dt, steps);
  const Eigen::Matrix3d R = rot(axis, rate * b.state.time);
  double worst = 0, drift = 0;
  for (int e = 0; e < rod.elements(); ++e) {
    Eigen::Matrix3d q0, q, qs;
    const Mat3 a = b.frame(1, e), s = single.frame(0, e);
    for (int i = 0; i < 9; ++i) {
      q0(i / 3, i % 3) = rod.frames[e][i];
      q(i / 3, i % 3) = a[i];
      qs(i / 3, i % 3) = s[i];
    }
    const Eigen::Matrix3d expect = q0 * R.transpose();
    worst = std::max({worst, (q - expect).norm(), (qs - expect).norm()});
  }
  for (int j = 0; j <= rod.elements(); ++j) drift = std::max(drift, distance(b.position(1, j), rod.nodes[j]));
  // Round-off: the frames are turned by exp(−hω) twice a step, a few ulps
  // each (measured: ~15 ulps in all over 2,000–4,000 steps).
  const double tol = 10 * double(steps) * kEps;
  std::printf("%s spun %.2f rad in %lld steps: max |Q - Q0 R^T| = %.3e, node drift %.3e m (bound %.3e)\n",
              rod.name.c_str(), rate * b.state.time, (long long)steps, worst, drift, tol);
  EXPECT_LT(worst, tol);
  EXPECT_LT(drift, tol * kL);
}

}  // namespace

TEST(DrivenRoot, SpinningRootTurnsTheRodRigidly) {
  check_spin(seed_cantilever(20, Damping::shear_bulk(0.02, 0.02)), Eigen::Vector3d::UnitZ(), 10,
             0.5 * stable_dt(build_batch<double>({seed_cantilever(20)})).elastic, 4000);
  check_spin(hair(32, true, Damping::shear_bulk(1e-3, 1e-3)), Eigen::Vector3d::UnitX(), 10, 1e-4, 2000);
}

namespace {

// A shake that starts smoothly (velocity and acceleration zero at t = 0, so
// no mode is kicked by the start): translation a (1 − cos ωt)² along e1,
// and rotation by θ (1 − cos ωt)² about e2 through the root.
struct SmoothShake : RootMotion {
  double a = 0.01, theta = 0.2, omega = 2 * std::numbers::pi * 4;
  Pose at(double t) const override {
    const double s = (1 - std::cos(omega * t)) * (1 - std::cos(omega * t));
    const Eigen::Matrix3d r = rot(Eigen::Vector3d::UnitY(), theta * s);
    Pose p;
    for (int i = 0; i < 9; ++i) p.rotation[i] = r(i / 3, i % 3);
    p.translation = {a * s, 0, 0};
    return p;
  }
};

template <Integrator kI = Integrator::position_verlet>
std::vector<Vec3> shaken(double dt, double T, int frames) {
  RodSpec rod = seed_cantilever(20);
  rod.root_motion = std::make_shared<SmoothShake>();
  auto b = build_batch<double>({rod});
  const std::int64_t per = std::llround(T / frames / dt);
  std::vector<Vec3> out;
  for (int f = 0; f < frames; ++f) {
    advance<kAllTerms, Viscous::implicit, kI>(b, dt, per);
    for (int j = 0; j <= 20; j += 5) out.push_back(b.position(0, j));
  }
  return out;
}

}  // namespace

TEST(DrivenRoot, PositionVerletStaysSecondOrder) {
  // Node positions (every 5th node, 10 frames over 0.25 s) of the undamped
  // cantilever under a smooth shake and nod of its root, at h, h/2, h/4
  // against h/32. Position Verlet is second order; the driven root keeps it
  // second order only if the root's mean velocity and the clamp's constant
  // angular velocity carry it exactly to the pose at t + h (a root set to
  // the pose of the step's end, or given the velocity at t, is first order).
  const double h = 0.5 * stable_dt(build_batch<double>({seed_cantilever(20)})).elastic;
  const double T = 0.25;
  const int frames = 10;
  // h rounded so that every frame is a whole number of steps at all four
  const double h0 = T / frames / std::ceil(T / frames / h);
  const std::vector<Vec3> ref = shaken(h0 / 32, T, frames);
  double err[3];
  for (int i = 0; i < 3; ++i) {
    err[i] = max_distance(shaken(h0 / (1 << i), T, frames), ref);
  }
  for (int i = 0; i + 1 < 3; ++i) {
    const double order = std::log2(err[i] / err[i + 1]);
    std::printf("shaken cantilever: error %.3e m at h/%d, %.3e m at h/%d: order %.2f\n", err[i], 1 << i,
                err[i + 1], 2 << i, order);
    // the reference's own error is 1/1024 of err[0] (second order), so it
    // shifts the measured orders by < 0.01
    EXPECT_NEAR(order, 2.0, 0.15);
  }
}

namespace {

// Euler–Bernoulli cantilever whose base moves as Y sin Ωt along e1: the
// steady state is w(s, t) = Y φ(s) sin Ωt with φ⁗ = β⁴ φ, β⁴ = ρAΩ²/EI,
// φ(0) = 1, φ′(0) = 0, φ″(L) = φ‴(L) = 0 (no moment, no shear force at the
// free end); φ = a ch βs + b sh βs + c cos βs + d sin βs.
struct BaseExcited {
  double beta;
  Eigen::Vector4d k;
  explicit BaseExcited(double beta_l) : beta(beta_l / kL) {
    const double x = beta_l, ch = std::cosh(x), sh = std::sinh(x), c = std::cos(x), s = std::sin(x);
    Eigen::Matrix4d a;
    a << 1, 0, 1, 0,    //
        0, 1, 0, 1,     //
        ch, sh, -c, -s,  //
        sh, ch, s, -c;
    k = a.colPivHouseholderQr().solve(Eigen::Vector4d(1, 0, 0, 0));
  }
  double phi(double s) const {
    const double x = beta * s;
    return k[0] * std::cosh(x) + k[1] * std::sinh(x) + k[2] * std::cos(x) + k[3] * std::sin(x);
  }
  double dphi(double s) const {
    const double x = beta * s;
    return beta * (k[0] * std::sinh(x) + k[1] * std::cosh(x) - k[2] * std::sin(x) + k[3] * std::cos(x));
  }
};

}  // namespace

TEST(DrivenRoot, BaseExcitationMatchesEulerBernoulli) {
  // The seed cantilever (n = 50, undamped) shaken at its base below its first
  // resonance (βL = 1.2 against 1.875), started on the theory's steady state
  // (w = 0, ẇ = YΩφ, element spin YΩφ′), so that it stays on it: the tip
  // follows Y φ(L) sin Ωt over a period.
  using namespace cases;
  constexpr int n = 50;
  const double beta_l = 1.2;
  const BaseExcited theory(beta_l);
  EXPECT_NEAR(theory.phi(0), 1, 1e-12);
  EXPECT_NEAR(theory.dphi(0), 0, 1e-12);
  // the quasi-static limit: φ(L) ≈ 1 + (βL)⁴/8 (a uniform load ρAΩ²Y)
  EXPECT_NEAR(BaseExcited(0.1).phi(kL), 1 + std::pow(0.1, 4) / 8, 1e-8);
  const double omega = std::pow(beta_l / kL, 2) * std::sqrt(kEI / (kRho * kA * kA));
  const double Y = 1e-3 * kL;
  RodSpec rod = seed_cantilever(n);
  auto shake = std::make_shared<OscillatingMotion>();
  shake->translation_amplitude = {Y, 0, 0};
  shake->frequency = omega / (2 * std::numbers::pi);
  rod.root_motion = shake;
  rod.velocities.resize(n + 1);
  rod.angular_velocities.resize(n);
  for (int j = 0; j <= n; ++j) rod.velocities[j] = {Y * omega * theory.phi(kL * j / n), 0, 0};
  for (int e = 0; e < n; ++e) rod.angular_velocities[e] = {0, Y * omega * theory.dphi(kL * (e + 0.5) / n), 0};
  auto b = build_batch<double>({rod});
  const double period = 2 * std::numbers::pi / omega;
  const int samples = 40;
  const double dt0 = 0.5 * stable_dt(b).elastic;
  const std::int64_t per = std::llround(std::ceil(period / samples / dt0));
  const double dt = period / samples / double(per);
  double worst = 0;
  for (int i = 1; i <= samples; ++i) {
    advance(b, dt, per);
    const double expect = Y * theory.phi(kL) * std::sin(omega * b.state.time);
    worst = std::max(worst, std::abs(b.position(0, n)[0] - expect));
  }
  // Error budget: the discrete rod's bending frequencies lie below
  // Euler–Bernoulli's by the Timoshenko lowering plus the n = 50
  // discretization error, together < 0.1 % for mode 1 (tests/test_modes.cpp,
  // docs/validation.md "2a Small-amplitude bending frequencies"). A relative
  // frequency error δ acts as a forcing frequency off
  // by δ, i.e. βL off by δ/2: the steady state moves by |φ(L; βL(1 + δ/2)) −
  // φ(L; βL)| Y, and the start on the theory's (not the rod's) steady state
  // adds a free vibration of the same size: twice that in all. Time error
  // (Ωh)² and nonlinearity (Y/L)² are ≤ 1e-6 of it.
  const double delta = 1e-3;
  const double tol = 2 * Y * std::abs(BaseExcited(beta_l * (1 + delta / 2)).phi(kL) - theory.phi(kL));
  std::printf("base excitation at beta L = %.2f: tip amplitude ratio phi(L) = %.6f; max |tip - theory| = %.3e m = "
              "%.2e of the tip amplitude (bound %.3e m)\n",
              beta_l, theory.phi(kL), worst, worst / (Y * theory.phi(kL)), tol);
  EXPECT_LT(worst, tol);
}

TEST(DrivenRoot, PefrlStaysFourthOrder) {
  // As above with PEFRL, which moves the root drift by drift to the pose of
  // each stage's time. Steps 2× the Verlet ones (PEFRL is stable to 1.49×
  // Position Verlet's limit), h and h/2 against h/8.
  const double h = stable_dt(build_batch<double>({seed_cantilever(20)})).elastic;
  const double T = 0.25;
  const int frames = 10;
  const double h0 = T / frames / std::ceil(T / frames / h);
  const std::vector<Vec3> ref = shaken<Integrator::pefrl>(h0 / 8, T, frames);
  double err[2];
  for (int i = 0; i < 2; ++i) {
    err[i] = max_distance(shaken<Integrator::pefrl>(h0 / (1 << i), T, frames), ref);
  }
  const double order = std::log2(err[0] / err[1]);
  std::printf("shaken cantilever, PEFRL: error %.3e m at h, %.3e m at h/2: order %.2f\n", err[0], err[1], order);
  // the reference's error is 1/4096 of err[0] at order 4; a root moved once per
  // step at its mean velocity makes PEFRL second order (measured 2.07)
  EXPECT_NEAR(order, 4.0, 0.3);
}

TEST(DrivenRoot, ChunkingThreadsAndSegmentsDoNotChangeTheResult) {
  // 300 rods (three L2 segments), every other one driven, by two motions:
  // step_n in blocks of 50 against single steps, and 2 threads against 1,
  // bit for bit (each segment evaluates the motions for its own rods).
  auto nod = std::make_shared<OscillatingMotion>();
  nod->axis = {0, 1, 0};
  nod->rotation_amplitude = 0.3;
  nod->frequency = 5;
  nod->ramp_time = 0.01;
  auto slide = constant_velocity({0.1, 0, 0});
  std::vector<RodSpec> rods;
  for (int i = 0; i < 300; ++i) {
    RodSpec r = seed_cantilever(20, Damping::shear_bulk(0.02, 0.02));
    for (Vec3& x : r.nodes) x[1] += 0.02 * i;
    if (i % 2 == 0) r.root_motion = i % 4 == 0 ? std::shared_ptr<const RootMotion>(nod) : slide;
    rods.push_back(r);
  }
  auto check = [&]<class T>() {
    auto a = build_batch<T>(rods, {-9.81, 0, 0});
    ASSERT_GE(a.segments.size(), 3u);
    ASSERT_EQ(a.motions.size(), 2u);
    auto b = a, c = a;
    const T dt = T(0.5 * stable_dt(a).elastic);
    step_n(a, dt, 50, Exec{1});
    for (int i = 0; i < 50; ++i) step(b, dt, Exec{1});
    step_n(c, dt, 50, Exec{2});
    for (int d = 0; d < 3; ++d) {
      EXPECT_EQ(std::memcmp(a.state.node_x[d].data(), b.state.node_x[d].data(), a.state.node_x[d].size() * sizeof(T)), 0);
      EXPECT_EQ(std::memcmp(a.state.node_x[d].data(), c.state.node_x[d].data(), a.state.node_x[d].size() * sizeof(T)), 0);
    }
    EXPECT_GT(distance(a.position(0, 20), rods[0].nodes[20]), 1e-4);  // the driven rods moved
  };
  check.template operator()<double>();
  check.template operator()<float>();
}

TEST(DrivenRoot, MotionsAreValidatedAndRampIn) {
  auto bad = std::make_shared<OscillatingMotion>();
  bad->rotation_amplitude = 0.1;
  bad->axis = {0, 0, 0};
  bad->frequency = 1;
  RodSpec r = seed_cantilever(4);
  r.root_motion = bad;
  EXPECT_THROW((void)build_batch<double>({r}), InputError);
  RodSpec free = seed_cantilever(4);
  free.clamped_root = false;
  free.root_motion = constant_velocity({1, 0, 0});
  try {
    (void)build_batch<double>({free});
    ADD_FAILURE() << "a free driven root was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("root_motion: a driven root must be held"), std::string::npos)
        << e.what();
  }
  auto keys = std::make_shared<KeyframedMotion>();
  keys->times = {0, 1, 1};
  keys->translations = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  r.root_motion = keys;
  EXPECT_THROW((void)build_batch<double>({r}), InputError);
  // the ramp: pose and velocity start at zero, full motion after ramp_time
  OscillatingMotion m;
  m.translation_amplitude = {0.01, 0, 0};
  m.frequency = 2;
  m.phase = std::numbers::pi / 2;  // sin = 1 at t = 0: without the ramp a jump of 0.01 m
  m.ramp_time = 0.2;
  EXPECT_EQ(m.at(0).translation[0], 0.0);
  EXPECT_LT(m.at(1e-4).translation[0], 0.01 * 3 * std::pow(1e-4 / 0.2, 2) * 1.001);  // 3x² growth: no velocity jump
  EXPECT_NEAR(m.at(0.45).translation[0], 0.01 * std::sin(2 * std::numbers::pi * 2 * 0.45 + m.phase), 1e-15);
}
