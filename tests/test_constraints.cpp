// Held nodes (include/manyrods/batch.h RodSpec: pinned and clamped ends,
// interior holds, driven tips and nodes; docs/validation.md "7j Constraints"):
// beams on supports against Euler–Bernoulli–Timoshenko statics, Euler's
// buckling loads and their O(dx²) convergence, a column that stays straight
// below its critical load and buckles above it, the catenary, driven holds
// (second order, exactly on their path), bit-identity, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <vector>

#include "cases.h"
#include "manyrods/statics.h"

using namespace manyrods;

namespace {

constexpr double kPi = std::numbers::pi;

// A straight round rod along e1 (d1 = e3), length L, n elements.
RodSpec round_rod(int n, double L, double r, double E, double rho) {
  RodSpec s = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, L, n);
  s.name = "rod";
  s.section = Section::circle(r);
  s.material = {rho, E, 0.3};
  return s;
}

struct Props {
  double EI, EA, kGA, rhoA;
};
Props props(const RodBatch<double>& b) {
  const RodInfo& i = b.rods[0];
  return {i.elastic.E * i.section.I1, i.elastic.E * i.section.area, i.section.shear_factor1 * i.elastic.G * i.section.area,
          i.elastic.density * i.section.area};
}

double midspan_z(const RodBatch<double>& b) { return b.position(0, b.elements(0) / 2)[2]; }

// The beam of span 1 m under its weight on two supports (pinned or clamped
// both ends): midspan deflection against w = c qL⁴/EI + qL²/(8κGA),
// c = 5/384 (simply supported) or 1/384 (clamped–clamped).
double beam_error(int n, bool clamped) {
  RodSpec s = round_rod(n, 1.0, 0.01, 1e11, 1000);
  s.clamped_root = s.clamped_tip = clamped;
  s.pinned_root = s.pinned_tip = !clamped;
  RodBatch<double> b = build_batch<double>({s}, {0, 0, -9.81});
  const Props p = props(b);
  StaticOptions opt;
  opt.load_steps = 1;
  opt.tolerance = 1e-14;
  (void)solve_static<kNoKelvinVoigt>(b, opt);
  const double q = p.rhoA * 9.81;
  const double w = (clamped ? 1.0 / 384 : 5.0 / 384) * q / p.EI + q / (8 * p.kGA);
  return (-midspan_z(b) - w) / w;
}

}  // namespace

TEST(Constraints, BeamsOnPinsAndClampsDeflectAsTheoryAtSecondOrder) {
  // A pinned end holds the node and leaves the frame free (no moment), a
  // clamped one holds both: the two classic beams. The deflection is 5e-5 L,
  // so the membrane tension of the held ends changes it by < 1e-4 relative.
  for (const bool clamped : {false, true}) {
    const double e8 = beam_error(8, clamped), e16 = beam_error(16, clamped), e32 = beam_error(32, clamped);
    std::printf("%s beam: relative midspan error %.3e (n = 8), %.3e (16), %.3e (32)\n",
                clamped ? "clamped-clamped" : "pinned-pinned", e8, e16, e32);
    EXPECT_NEAR(std::log2(e8 / e16), 2.0, 0.2);
    EXPECT_NEAR(std::log2(e16 / e32), 2.0, 0.2);
    EXPECT_LT(std::abs(e32), 2e-2);
  }
}

namespace {

// The buckling load of a column of span 1 m, slenderness L/r = 1000, with
// both ends pinned (mode sin πs/L, P = π²EI/L²) or clamped (mode 1 − cos 2πs/L,
// P = 4π²EI/L²): the tip is held δ closer to the root (axial force N), and a
// tiny lateral load of the mode's shape (sin πs/L, or cos 2πs/L, whose
// deflection is exactly 1 − cos 2πs/L) deflects the midspan by
// w(N) = w(0)/(1 − N/P) (Euler–Bernoulli, exact for that load); from the
// two static solves P = N/(1 − w(0)/w(N)), with N from the axial strain
// the solve reaches. Shear (P/κGA ≈ 1e-6) and the rod's shortening are
// negligible against the O(dx²) error measured.
double buckling_load(int n, bool clamped, double* exact) {
  auto solve = [&](double shorten, double* axial) {
    RodSpec s = round_rod(n, 1.0, 1e-3, 1e9, 1000);
    s.clamped_root = s.clamped_tip = clamped;
    s.pinned_root = s.pinned_tip = !clamped;
    RodBatch<double> b = build_batch<double>({s}, {0, 0, 0});
    // compressed, straight: the held tip is moved with the rest
    for (int j = 0; j <= n; ++j) b.state.node_x[0][b.node_index(0, j)] *= 1 - shorten;
    const Props p = props(b);
    const double P = (clamped ? 4 : 1) * kPi * kPi * p.EI;
    *exact = P;
    const double q0 = 1e-6 * P * kPi * kPi;  // w ≈ 1e-6 L
    for (int j = 1; j < n; ++j) {
      const double x = double(j) / n;
      const double shape = clamped ? -std::cos(2 * kPi * x) : std::sin(kPi * x);
      b.set_node_force(0, j, {0, 0, q0 * shape / n});
    }
    StaticOptions opt;
    opt.load_steps = 1;
    opt.tolerance = 1e-15;
    (void)solve_static<kNoKelvinVoigtNoGravity>(b, opt);
    double strain = 0;
    for (int e = 0; e < n; ++e) {
      const Vec3 a = b.position(0, e), c = b.position(0, e + 1);
      strain += (std::hypot(c[0] - a[0], c[1] - a[1], c[2] - a[2]) * n - 1) / n;
    }
    *axial = -p.EA * strain;
    return midspan_z(b);
  };
  double n0 = 0, p = 0;
  const double w0 = solve(0, &n0);
  RodSpec probe = round_rod(n, 1.0, 1e-3, 1e9, 1000);
  const Props pr = props(build_batch<double>({probe}));
  const double P = (clamped ? 4 : 1) * kPi * kPi * pr.EI;
  double axial = 0;
  const double wn = solve(0.5 * P / pr.EA, &axial);
  p = axial / (1 - w0 / wn);
  return p;
}

}  // namespace

TEST(Constraints, EulerBucklingLoadsConvergeAtSecondOrder) {
  for (const bool clamped : {false, true}) {
    double exact = 0, err[3];
    const int ns[3] = {8, 16, 32};
    for (int i = 0; i < 3; ++i) err[i] = buckling_load(ns[i], clamped, &exact) / exact - 1;
    std::printf("%s column: critical load %.4f·P_theory at n = 8, %.5f at 16, %.6f at 32\n",
                clamped ? "clamped-clamped (4π²EI/L²)" : "pinned-pinned (π²EI/L²)", 1 + err[0], 1 + err[1],
                1 + err[2]);
    EXPECT_NEAR(std::log2(err[0] / err[1]), 2.0, 0.15);
    EXPECT_NEAR(std::log2(err[1] / err[2]), 2.0, 0.15);
    EXPECT_LT(std::abs(err[2]), 2e-2);
  }
}

namespace {

// A pinned–pinned column (span 1 m, L/r = 50: its first bending mode is
// ω₁ ≈ 99 rad/s) whose tip is pushed towards the root by δ over 20/ω₁ (a
// driven, pinned tip: RampMotion), damped (Kelvin–Voigt, τ = 0.3/ω₁: a
// damping ratio of 0.15 for that mode), given a 1e-4 m/s lateral kick: its
// largest lateral deflection after 100/ω₁.
double pushed_column(double shorten_fraction_of_critical, double* expected) {
  const int n = 16;
  RodSpec s = round_rod(n, 1.0, 0.02, 1e9, 1000);
  s.pinned_root = s.pinned_tip = true;
  const Props p = props(build_batch<double>({s}));
  const double w1 = kPi * kPi * std::sqrt(p.EI / p.rhoA);
  s.damping = Damping::shear_extension(0.3 / w1, 0.3 / w1);
  const double P = kPi * kPi * p.EI, delta_cr = P / p.EA;
  const double delta = shorten_fraction_of_critical * delta_cr;
  auto push = std::make_shared<RampMotion>();
  push->translation = {-delta, 0, 0};
  push->duration = 20 / w1;
  s.tip_motion = push;
  s.velocities.assign(n + 1, {0, 0, 0});
  for (int j = 1; j < n; ++j) s.velocities[j][2] = 1e-4 * std::sin(kPi * j / n);
  RodBatch<double> b = build_batch<double>({s}, {0, 0, 0});
  const double dt = 0.5 * stable_dt(b).elastic;
  advance<kNoGravity>(b, dt, std::int64_t(100 / w1 / dt));
  // the elastica just above P: the end shortening beyond δ_cr goes into
  // π²w²/(4L), so w = (2/π)·sqrt(L(δ − δ_cr))
  *expected = delta > delta_cr ? 2 / kPi * std::sqrt(delta - delta_cr) : 0.0;
  double w = 0;
  for (int j = 0; j <= n; ++j) w = std::max(w, std::abs(b.position(0, j)[2]));
  EXPECT_NEAR(b.position(0, n)[0], 1 - delta, 1e-12) << "the driven tip ends where it was pushed";
  return w;
}

}  // namespace

TEST(Constraints, ColumnStaysStraightBelowItsCriticalLoadAndBucklesAbove) {
  double expected = 0;
  const double below = pushed_column(0.8, &expected);
  std::printf("column pushed to 0.8 P_cr: lateral deflection %.3e m (kick 1e-4 m/s)\n", below);
  EXPECT_LT(below, 1e-8);  // the kick's own deflection (1e-4 m/s / ω₁ = 1e-6 m), decayed
  const double above = pushed_column(1.3, &expected);
  std::printf("column pushed to 1.3 P_cr: deflection %.4e m, elastica %.4e m\n", above, expected);
  // the elastica's next term is O((w/L)²) = 1e-4; the discrete P_cr is
  // 1 − 3e-3 of the continuum one at n = 16 (above) and shear lowers it by
  // P/κGA ≈ 3e-3: together they shift δ − δ_cr by 2 %, w by 1 %
  EXPECT_NEAR(above / expected, 1.0, 0.02);
}

namespace {

// A cable (round, 5 mm, 1 kg/m) of length ≈ 1.2 m hung between two clamps
// 1 m apart at the same height, built as a circular arc of that chord and
// length with a straight rest shape, solved statically under gravity.
struct Catenary {
  double sag, expected, bending_length, kink;
};
Catenary hang(int n) {
  const double S = 1.0, r = 0.005, A = kPi * r * r, rho = 1 / A;
  // arc of chord S and length 1.2 S: 2R sin(θ/2) = S, Rθ = 1.2 S
  double th = 2;
  for (int i = 0; i < 100; ++i) th -= (2 * std::sin(th / 2) / th - 1 / 1.2) / (std::cos(th / 2) / th - 2 * std::sin(th / 2) / (th * th));
  const double R = 1.2 * S / th;
  std::vector<Vec3> nodes;
  for (int j = 0; j <= n; ++j) {
    const double a = -th / 2 + th * j / n;
    nodes.push_back({S / 2 + R * std::sin(a), 0, -(R * std::cos(a) - R * std::cos(th / 2))});
  }
  RodSpec s = RodSpec::polyline(nodes, RodSpec::parallel_transport_frames(nodes, {0, 1, 0}));
  s.name = "cable";
  s.section = Section::circle(r);
  s.material = {rho, 3.3e4, 0.3};
  s.shear_stretch_scale = 1e5;  // a nearly inextensible cable that hardly bends
  s.rest_curvature.assign(n - 1, {0, 0, 0});
  s.clamped_root = s.clamped_tip = true;
  RodBatch<double> b = build_batch<double>({s}, {0, 0, -9.81});
  double length = 0;  // the chain's length (chords of the arc)
  for (int e = 0; e < n; ++e) length += b.model.elem_rest_length[b.elem_index(0, e)];
  StaticOptions opt;
  opt.load_steps = 4;
  opt.tolerance = 1e-12;
  const StaticResult res = solve_static<kNoKelvinVoigt>(b, opt);
  EXPECT_TRUE(res.converged);
  // catenary z = a(cosh((x − S/2)/a) − cosh(S/2a)), length 2a·sinh(S/2a)
  double a = 0.3;
  for (int i = 0; i < 200; ++i) {
    const double f = 2 * a * std::sinh(S / (2 * a)) - length;
    const double df = 2 * std::sinh(S / (2 * a)) - S / a * std::cosh(S / (2 * a));
    a -= f / df;
  }
  Catenary c;
  c.expected = a * (std::cosh(S / (2 * a)) - 1);
  c.sag = -b.position(0, n / 2)[2];
  const Props p = props(b);
  const double H = a * p.rhoA * 9.81;  // horizontal tension
  c.bending_length = std::sqrt(p.EI / H);
  c.kink = std::abs(std::atan(std::sinh(S / (2 * a))) - th / 2);  // clamp angle against the catenary's
  return c;
}

}  // namespace

TEST(Constraints, CableBetweenTwoClampsHangsAsACatenary) {
  // Bending only matters within λ = sqrt(EI/H) of the clamps, where the
  // cable turns from the clamp's angle to the catenary's (a kink Δθ): the
  // supports are in effect moved by ≈ λΔθ, so |sag − catenary| ≲ λΔθ, plus
  // the chain's O(dx²) error, which Richardson's extrapolation of n = 20
  // and 40 removes (each against the catenary of its own chain's length),
  // and its stretch (H/EA = 2e-5).
  const Catenary c20 = hang(20), c40 = hang(40);
  for (const Catenary& c : {c20, c40})
    std::printf("catenary: sag %.6f m against %.6f m (bending length %.2e m, clamp kink %.3f rad)\n", c.sag,
                c.expected, c.bending_length, c.kink);
  const double layer = c40.bending_length * c40.kink;
  const double e20 = c20.sag - c20.expected, e40 = c40.sag - c40.expected, extrapolated = (4 * e40 - e20) / 3;
  std::printf("catenary: sag error %.2e (n = 20), %.2e (40), extrapolated %.2e m; bending layer %.2e m\n", e20,
              e40, extrapolated, layer);
  EXPECT_LT(std::abs(extrapolated), 2 * layer + 2e-5 * c40.expected);
  EXPECT_LT(std::abs(e40), std::abs(e20));
}

namespace {

// The seed-like cantilever (clamped root) whose clamped tip follows a smooth
// oscillation (translation and a nod, faded in) and whose node n/2 is pinned
// on a second one: node positions at 10 frames over 0.25 s.
std::vector<Vec3> driven_tip_run(double h, double T, int frames, std::vector<double>* path_error) {
  RodSpec s = cases::seed_cantilever(20);
  auto tip = std::make_shared<OscillatingMotion>();
  tip->translation_amplitude = {0.01, 0.005, 0};
  tip->axis = {0, 1, 0};
  tip->rotation_amplitude = 0.2;
  tip->frequency = 4;
  tip->ramp_time = 0.1;
  tip->pivot = {0, 0, cases::kL};
  s.clamped_tip = true;
  s.tip_motion = tip;
  auto mid = std::make_shared<OscillatingMotion>();
  mid->translation_amplitude = {0.004, -0.003, 0};
  mid->frequency = 3;
  mid->ramp_time = 0.08;
  s.holds.push_back({10, HoldKind::pinned, mid});
  RodBatch<double> b = build_batch<double>({s}, {0, 0, 0});
  std::vector<Vec3> out;
  const int per = int(std::lround(T / frames / h));
  for (int f = 0; f < frames; ++f) {
    step_n<kNoGravity>(b, h, per);
    for (int j = 0; j <= 20; j += 5) out.push_back(b.position(0, j));
    const Pose pt = tip->at(b.state.time), pm = mid->at(b.state.time);
    const Vec3 x0 = s.nodes[20], xm = s.nodes[10];
    Vec3 et{}, em{};
    for (int i = 0; i < 3; ++i) {
      et[i] = pt.translation[i] + pt.rotation[3 * i] * x0[0] + pt.rotation[3 * i + 1] * x0[1] + pt.rotation[3 * i + 2] * x0[2];
      em[i] = pm.translation[i] + xm[i];
    }
    if (path_error) {
      path_error->push_back(cases::distance(b.position(0, 20), et));
      path_error->push_back(cases::distance(b.position(0, 10), em));
    }
  }
  return out;
}

}  // namespace

TEST(Constraints, DrivenTipAndNodeStaySecondOrderAndOnTheirPath) {
  const double h = 0.5 * stable_dt(build_batch<double>({cases::seed_cantilever(20)})).elastic;
  std::vector<double> path;
  const auto err = cases::time_errors(h, 0.25, 10, [&](double dt) {
    return driven_tip_run(dt, 0.25, 10, path.empty() ? &path : nullptr);  // (the path: at the finest step)
  });
  ASSERT_FALSE(path.empty());
  for (double e : path) EXPECT_LT(e, 1e-14) << "a driven hold lands on its motion's pose at each step's end";
  for (double o : cases::time_orders(err, "driven tip and node")) EXPECT_NEAR(o, 2.0, 0.15);
}

namespace {

// A stiff hair (RodSpec::stiff_implicit) under gravity with a driven hold
// besides another hold (the solve keeps the second one's prescribed
// velocity, kernels/viscous_implicit_lanes.h kLift). Made as an arc in the
// x–z plane turning by 1.2 rad (its rest shape; its chord is 6 % shorter
// than it), so that both ends can be held without stretching it: 0, a
// clamped root nodding about itself (the solve's reference motion) with the
// tip pinned at rest; 1, a clamped root at rest with the clamped tip
// nodding about itself (no reference: the tip node at rest, its frame
// turning); 2, a clamped root and a pinned tip at rest with node 8 pinned
// on an oscillation out of the plane. Nodes 0, 4, …, 16 at 10 frames over
// 0.25 s; path_error: the driven node's distance from its pose. (Holds that
// force a stiff rod to stretch converge only once the step resolves its
// stretch waves, hω ≪ 1: the stiff model is for rods that bend.)
RodSpec arc_hair(int n) {
  const double L = cases::kHairL, phi = 1.2, R = L / phi, t0 = -0.5 * phi;
  std::vector<Vec3> nodes(n + 1);
  std::vector<Mat3> frames(n);
  for (int j = 0; j <= n; ++j) {
    const double t = t0 + (L * j / n) / R;
    nodes[j] = {R * (std::sin(t) - std::sin(t0)), 0, -R * (std::cos(t) - std::cos(t0))};
  }
  for (int e = 0; e < n; ++e) {
    const double dx = nodes[e + 1][0] - nodes[e][0], dz = nodes[e + 1][2] - nodes[e][2], l = std::hypot(dx, dz);
    frames[e] = {0, 1, 0, -dz / l, 0, dx / l, dx / l, 0, dz / l};  // d1 = e_y, d2 = d3 × d1, d3 along the chord
  }
  RodSpec h = cases::hair(n, true);
  RodSpec s = RodSpec::polyline(nodes, frames);
  s.name = h.name;
  s.section = h.section;
  s.material = h.material;
  s.clamped_root = true;
  s.stiff_implicit = true;
  return s;
}

std::vector<Vec3> stiff_holds_run(int which, double h, double T, int frames, std::vector<double>* path_error) {
  RodSpec s = arc_hair(16);
  auto motion = std::make_shared<OscillatingMotion>();
  motion->frequency = 2;
  motion->ramp_time = 0.05;
  int driven = 0;
  if (which == 2) {
    motion->translation_amplitude = {0, 0.004, 0};  // out of the plane: no stretch needed
    s.holds.push_back({8, HoldKind::pinned, motion});
    s.pinned_tip = true;
    driven = 8;
  } else {
    motion->axis = {0, 1, 0};
    motion->rotation_amplitude = 0.15;
    if (which == 0) {
      s.root_motion = motion;
      s.pinned_tip = true;
    } else {
      motion->pivot = s.nodes[16];
      s.clamped_tip = true;
      s.tip_motion = motion;
      driven = 16;
    }
  }
  RodBatch<double> b = build_batch<double>({s}, {0, 0, -9.81});
  std::vector<Vec3> out;
  const int per = int(std::lround(T / frames / h));
  for (int f = 0; f < frames; ++f) {
    step_n<kAllTerms>(b, h, per);
    for (int j = 0; j <= 16; j += 4) out.push_back(b.position(0, j));
    const Pose p = motion->at(b.state.time);  // x = R x₀ + c (the pivot is in c)
    const Vec3 x0 = s.nodes[driven];
    Vec3 want{};
    for (int i = 0; i < 3; ++i)
      want[i] = p.translation[i] + p.rotation[3 * i] * x0[0] + p.rotation[3 * i + 1] * x0[1] +
                p.rotation[3 * i + 2] * x0[2];
    if (path_error) path_error->push_back(cases::distance(b.position(0, driven), want));
  }
  return out;
}

}  // namespace

TEST(Constraints, StiffRodsTakeADrivenHoldBesidesAnother) {
  // Self-convergence (reference: the same run at h/32). The stiff rod's
  // shear, stretch and twist are backward Euler (first order, acting on
  // their small rates), its bending second order (kernels/viscous_implicit.h
  // "Stiff rods"): the error falls at least at first order; 0.15 below it
  // allows for the pre-asymptotic terms, as the driven-tip test does.
  const char* names[3] = {"stiff: driven root, pinned tip", "stiff: driven clamped tip", "stiff: driven node"};
  for (int which = 0; which < 3; ++which) {
    std::vector<double> path;
    const auto err = cases::time_errors(1.0 / 960, 0.25, 10, [&](double dt) {
      return stiff_holds_run(which, dt, 0.25, 10, path.empty() ? &path : nullptr);
    });
    ASSERT_FALSE(path.empty());
    for (double e : path) EXPECT_LT(e, 1e-14) << names[which] << ": the driven node lands on its pose";
    for (double o : cases::time_orders(err, names[which])) EXPECT_GT(o, 0.85) << names[which];
  }
}

namespace {

// The seed cantilever (damped) whose clamped root nods (the implicit solve's
// reference motion) while its tip is clamped at rest: node positions at 10
// frames over 0.1 s with the Kelvin–Voigt term implicit or explicit.
template <Viscous kV>
std::vector<Vec3> nodding_root_clamped_tip(double h) {
  RodSpec s = cases::seed_cantilever(20, Damping::shear_bulk(0.002, 0.002));
  auto nod = std::make_shared<OscillatingMotion>();
  nod->axis = {0, 1, 0};
  nod->rotation_amplitude = 0.2;
  nod->frequency = 4;
  nod->ramp_time = 0.02;
  s.root_motion = nod;
  s.clamped_tip = true;
  RodBatch<double> b = build_batch<double>({s}, {-9.81, 0, 0});
  std::vector<Vec3> out;
  const int per = int(std::lround(0.01 / h));
  for (int f = 0; f < 10; ++f) {
    advance<kAllTerms, kV, Integrator::position_verlet>(b, h, per);
    for (int j = 0; j <= 20; j += 4) out.push_back(b.position(0, j));
  }
  return out;
}

}  // namespace

TEST(Constraints, NoddingRootWithAClampedTipAgreesWithTheExplicitKelvinVoigt) {
  // The solve runs relative to the root's rigid motion; the tip's clamp
  // frame, held at rest, then has the prescribed relative angular velocity
  // −Q Ω, which its joint to the last element feels. Reference: the same
  // run with the Kelvin–Voigt rates explicit (no solve, no shift). Both
  // are first order in the viscous term, so their difference falls at
  // least at first order with h (0.15 below it allowed, as above); a solve
  // that left the tip frame turning with the root adds a torque at its joint
  // that does not shrink with h.
  const StableDt st = stable_dt(build_batch<double>({cases::seed_cantilever(20, Damping::shear_bulk(0.002, 0.002))}));
  const double h0 = 0.01 / std::ceil(0.01 / (0.5 * std::min(st.elastic, st.explicit_viscous)));
  double diff[3];
  for (int i = 0; i < 3; ++i) {
    const double h = h0 / (1 << i);
    diff[i] = cases::max_distance(nodding_root_clamped_tip<Viscous::implicit>(h),
                                  nodding_root_clamped_tip<Viscous::explicit_rate>(h));
    std::printf("nodding root, clamped tip: implicit against explicit Kelvin-Voigt at h0/%d: %.3e m\n", 1 << i,
                diff[i]);
  }
  for (int i = 0; i + 1 < 3; ++i) EXPECT_GT(std::log2(diff[i] / diff[i + 1]), 0.85) << "halving " << i;
}

TEST(Constraints, ClampedInteriorNodeHoldsTwoCantilevers) {
  // A free–free beam clamped at its middle node under gravity: two
  // cantilevers of length ℓ = L/2, tip deflection qℓ⁴/(8EI) + qℓ²/(2κGA).
  // The clamp holds the frames of the two elements at the node, whose
  // curvature is measured from their centres: the cantilevers are in effect
  // ℓ − dx/2 long, a first-order error (1 − dx/2ℓ)⁴ − 1 (against the ends'
  // half-Voronoi clamp, which is second order); what remains is O(dx²).
  double err[2];
  for (int i = 0; i < 2; ++i) {
    const int n = 16 << i;
    RodSpec s = round_rod(n, 1.0, 0.01, 1e11, 1000);
    s.holds.push_back({n / 2, HoldKind::clamped, nullptr});
    RodBatch<double> b = build_batch<double>({s}, {0, 0, -9.81});
    StaticOptions opt;
    opt.load_steps = 1;
    opt.tolerance = 1e-14;
    (void)solve_static<kNoKelvinVoigt>(b, opt);
    const Props p = props(b);
    const double q = p.rhoA * 9.81, l = 0.5, dx = 1.0 / n;
    const double w = q * std::pow(l, 4) / (8 * p.EI) + q * l * l / (2 * p.kGA);
    const double w0 = -b.position(0, 0)[2], wn = -b.position(0, n)[2];
    EXPECT_NEAR(w0, wn, 1e-9 * w) << "symmetric";
    err[i] = wn / w - 1;
    const double first_order = std::pow(1 - dx / (2 * l), 4) - 1;
    std::printf("beam clamped at its middle node, n = %d: tip deflection %.4e m, theory %.4e m (%.3e; "
                "clamp-extent model %.3e)\n", n, wn, w, err[i], first_order);
    EXPECT_LT(std::abs(err[i] - first_order), 2 * (dx / l) * (dx / l));
  }
  EXPECT_LT(std::abs(err[1]), std::abs(err[0]));
}

TEST(Constraints, HeldRodsAreBitIdenticalForAnyThreadCountAndChunking) {
  // pinned ends, interior holds, damped rods with a driven tip or node
  // besides other holds (lane groups keeping their prescribed velocities),
  // a stiff rod whose only hold is a driven tip (the lane solve relative to
  // that motion), stiff rods with a driven root and a pinned tip or a driven
  // node, plain damped rods (lanes), all in a turbulent wind
  auto motion = std::make_shared<OscillatingMotion>();
  motion->translation_amplitude = {0.0, 0.01, 0.0};
  motion->frequency = 2;
  motion->ramp_time = 0.05;
  std::vector<RodSpec> rods;
  for (int i = 0; i < 24; ++i) {
    RodSpec s = cases::seed_cantilever(12 + i % 5, Damping::shear_extension(0.01, 0.02));
    s.nodes = RodSpec::straight({0.05 * i, 0, 0}, {0, 0, 1}, {1, 0, 0}, cases::kL, s.elements()).nodes;
    switch (i % 4) {
      case 0: s.clamped_root = false; s.pinned_root = true; s.pinned_tip = true; break;
      case 1: s.clamped_tip = true; s.tip_motion = motion; s.holds.push_back({4, HoldKind::clamped, nullptr}); break;
      case 2: s.holds.push_back({6, HoldKind::pinned, motion}); break;
      default: break;
    }
    rods.push_back(s);
  }
  RodSpec stiff = cases::hair(16, true);
  stiff.clamped_root = false;
  stiff.clamped_tip = true;
  stiff.tip_motion = motion;
  rods.push_back(stiff);
  RodSpec stiff_ends = cases::hair(16, true);
  stiff_ends.root_motion = motion;
  stiff_ends.pinned_tip = true;
  rods.push_back(stiff_ends);
  RodSpec stiff_node = cases::hair(14, true);
  stiff_node.holds.push_back({5, HoldKind::pinned, motion});
  rods.push_back(stiff_node);
  for (RodSpec& r : rods) r.drag = {0.05, 0.02, 1.0, 0.01, true};  // in wind, too
  RodBatch<double> a = build_batch<double>(rods, {0, 0, -9.81});
  Fluid wind;
  wind.density = 1.2;
  wind.times = {0, 1e-4};
  wind.velocities = {{0, 0, 0}, {1, 2, 0}};
  wind.turbulence.intensity = 0.5;
  wind.turbulence.length_scale = 0.1;
  wind.turbulence.time_scale = 0.2;
  set_fluid(a, wind);
  RodBatch<double> c = a;
  const double dt = 1e-5;
  for (int i = 0; i < 40; ++i) step<kAllTerms>(a, dt, Exec{1});
  step_n<kAllTerms>(c, dt, 13, Exec{2});
  step_n<kAllTerms>(c, dt, 27, Exec{2});
  EXPECT_EQ(state_hash(a), state_hash(c));
  EXPECT_TRUE(!find_non_finite(a).found);
}

TEST(Constraints, BadHoldsAreNamed) {
  auto expect_error = [](RodSpec s, const std::string& what) {
    try {
      (void)build_batch<double>({s});
      ADD_FAILURE() << "accepted: " << what;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  RodSpec s = cases::seed_cantilever(10);
  RodSpec a = s;
  a.holds.push_back({11, HoldKind::pinned, nullptr});
  expect_error(a, "holds[0]: node 11 does not exist (the rod has nodes 0 … 10)");
  a = s;
  a.holds = {{3, HoldKind::pinned, nullptr}, {3, HoldKind::clamped, nullptr}};
  expect_error(a, "holds[1]: node 3 is held twice");
  a = s;
  a.holds.push_back({0, HoldKind::pinned, nullptr});
  expect_error(a, "holds[0]: node 0 is the root");
  a = s;
  a.pinned_root = true;
  expect_error(a, "clamped_root and pinned_root both set");
  a = s;
  a.tip_motion = std::make_shared<OscillatingMotion>();
  expect_error(a, "tip_motion: a driven tip must be held");
  a = s;
  a.drag.normal = -1;
  expect_error(a, "drag.normal = -1: must be a finite number >= 0");
}
