// docs/validation.md "1a Pure bending into a circle" and "1b Large-deflection
// cantilever (elastica)" — statics: pure bending into a circle and the
// large-deflection cantilever (1b), solved by Newton (host/core/analysis/statics.h).
#include <gtest/gtest.h>

#include <array>
#include <random>
#include <vector>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include "cases.h"
#include "host/core/advanced.h"

using namespace manyrods;
using namespace manyrods::cases;

namespace {

constexpr double kPi = std::numbers::pi;

struct BendResult {
  double closure;        // |x_n − x_0| / L
  double tangent_error;  // |d3_last − continuum tangent at s = L − dx/2|
  double shape_error;    // max_j |x_j − circle(s_j)| / L
};

// 1a. End moment M = 2π EI / L about d1 (= e1) at the free end, no gravity.
BendResult pure_bending(int n) {
  RodSpec s = seed_cantilever(n);
  auto b = build_batch<double>({s});
  const double M = 2 * kPi * kEI / kL;
  b.set_element_couple(0, n - 1, {M, 0, 0});
  StaticOptions opt;
  opt.load_steps = 16;
  opt.tolerance = 1e-12;
  const StaticResult r = solve_static(b, opt);
  EXPECT_TRUE(r.converged) << "n = " << n;
  // Continuum: curvature κ = M/EI = 2π/L about e1; with t' = κ e1 × t the
  // rod curls towards −e2: x(s) = (0, −R(1 − cos(s/R)), R sin(s/R)), R = 1/κ.
  const double R = kL / (2 * kPi), dx = kL / n;
  BendResult out{};
  const Vec3 x0 = b.position(0, 0), xn = b.position(0, n);
  out.closure = std::hypot(xn[0] - x0[0], xn[1] - x0[1], xn[2] - x0[2]) / kL;
  for (int j = 0; j <= n; ++j) {
    const double sj = j * dx;
    const Vec3 x = b.position(0, j);
    const double e = std::hypot(x[0], x[1] + R * (1 - std::cos(sj / R)), x[2] - R * std::sin(sj / R));
    out.shape_error = std::max(out.shape_error, e / kL);
  }
  const Mat3 q = b.frame(0, n - 1);
  const double sm = kL - dx / 2;
  out.tangent_error = std::hypot(q[6], q[7] + std::sin(sm / R), q[8] - std::cos(sm / R));
  return out;
}

}  // namespace

TEST(Statics, PureBendingClosesIntoACircle) {
  // Discrete analysis: under a pure end moment the force resultant vanishes
  // (σ = 0: every element keeps its rest length, tangent = d3) and every
  // Voronoi moment equals M, so κ = M/EI at every joint, the root half-joint
  // included: element e points along the continuum tangent at s = (e + ½)dx
  // EXACTLY. The nodes then form a regular polygon of side dx inscribed in a
  // circle, which closes after a total turn of 2π: the tip returns to the
  // clamp to the Newton tolerance (1e-12), whatever n. Node positions differ
  // from the continuum circle only through chord vs arc length, a relative
  // (κ dx)²/24 — O(dx²).
  const BendResult r25 = pure_bending(25), r50 = pure_bending(50), r100 = pure_bending(100);
  for (const BendResult& r : {r25, r50, r100}) {
    EXPECT_LT(r.closure, 1e-9);
    EXPECT_LT(r.tangent_error, 1e-9);
  }
  // Shape error (κ dx)²/24 ·(diameter ~ L/π) bound at n = 50: (2π/50)²/24 = 6.6e-4.
  EXPECT_LT(r50.shape_error, 6.6e-4);
  const double p1 = std::log2(r25.shape_error / r50.shape_error);
  const double p2 = std::log2(r50.shape_error / r100.shape_error);
  // O(dx²): observed order 2; the leading term dominates already at n = 25
  // (next term relative (κdx)² ≈ 6% there), so ±0.1.
  EXPECT_NEAR(p1, 2.0, 0.1);
  EXPECT_NEAR(p2, 2.0, 0.1);
}

namespace {

struct Elastica {
  double deflection, shortening, rotation;  // δ/L, (L − x_tip)/L, θ_L
};

// 1b. Dead tip force P = α EI / L² along +e1, shear and stretch stiffened
// 1e4× (nearly inextensible and unshearable), no gravity.
Elastica elastica(int n, double alpha) {
  RodSpec s = seed_cantilever(n);
  s.shear_stretch_scale = 1e4;
  auto b = build_batch<double>({s});
  b.set_node_force(0, n, {alpha * kEI / (kL * kL), 0, 0});
  StaticOptions opt;
  opt.load_steps = alpha > 5 ? 20 : 8;
  // 1e-10 (relative update): with C_F ×1e4 the Jacobian's condition (~1e11)
  // puts the round-off floor of the update near 1e-12; 1e-10 is far below
  // the discrete errors measured here (≥ 1e-6 at n = 100).
  opt.tolerance = 1e-10;
  EXPECT_TRUE(solve_static(b, opt).converged);
  const Vec3 tip = b.position(0, n);
  const Mat3 q = b.frame(0, n - 1);
  // θ of the last element (its centre is at s = L − dx/2). θ'(L) = κ(L) = 0
  // (no moment at the free end), so θ(L − dx/2) = θ_L − O(dx²).
  return {tip[0] / kL, (kL - tip[2]) / kL, std::atan2(q[6], q[8])};
}

struct Row {
  double alpha, deflection, shortening, rotation;
};
// 1b: converged inextensible, unshearable reference (shooting on
// θ'' = −α cos θ, θ(0) = 0, θ'(1) = 0; docs/validation.md).
constexpr Row kTable[] = {{1, 0.301720774, 0.0564332363, 0.461351950},
                          {2, 0.493457480, 0.160641721, 0.781749832},
                          {10, 0.810609025, 0.554995598, 1.430285539}};

}  // namespace

class ElasticaCase : public ::testing::TestWithParam<Row> {};

TEST_P(ElasticaCase, MatchesReferenceAtSecondOrder) {
  const Row ref = GetParam();
  const Elastica e25 = elastica(25, ref.alpha), e50 = elastica(50, ref.alpha),
                 e100 = elastica(100, ref.alpha);
  auto err = [&](const Elastica& e) {
    return std::array<double, 3>{e.deflection - ref.deflection, e.shortening - ref.shortening,
                                 e.rotation - ref.rotation};
  };
  const auto a = err(e25), b = err(e50), c = err(e100);
  const double refs[3] = {ref.deflection, ref.shortening, ref.rotation};
  for (int i = 0; i < 3; ++i) {
    SCOPED_TRACE(testing::Message() << "alpha " << ref.alpha << " quantity " << i << " errors "
                                    << a[i] << " " << b[i] << " " << c[i]);
    // 1b: the standard scheme's discrete error at n = 50 is about 2e-4
    // relative. Bound it at 1e-3 relative and demand the O(dx²) order.
    EXPECT_LT(std::abs(b[i]) / refs[i], 1e-3);
    const double p = std::log2(a[i] / b[i]), q = std::log2(b[i] / c[i]);
    // Order 2 within ±0.15 (the O(dx⁴) remainder and the 1e-4 relative
    // extensibility of the stiffened rod, P/(1e4·EA) ≈ 1e-7, are far below
    // the n = 100 error).
    EXPECT_NEAR(p, 2.0, 0.15);
    EXPECT_NEAR(q, 2.0, 0.15);
    // Richardson extrapolation from n = 50, 100 removes the dx² term: what
    // is left is O(dx⁴) plus the extensibility (~1e-7); bound 2e-6·ref.
    const double extrapolated = refs[i] + c[i] + (c[i] - b[i]) / 3;
    EXPECT_NEAR(extrapolated, refs[i], 2e-6 * refs[i] + 1e-7);
  }
}

INSTANTIATE_TEST_SUITE_P(Case1b, ElasticaCase, ::testing::ValuesIn(kTable));

// A bent, curly rod under gravity at its static equilibrium, with the
// unknowns of its Newton problem and the force buffers (the Jacobian tests).
struct CurlyRod {
  RodBatch<double> b;
  detail::RodDofs d;
  std::array<Array<double>, 3> f, c;
  bool converged = false;
  CurlyRod() {
    RodSpec s = seed_cantilever(24);
    s.rest_curvature.assign(23, {3.0, 1.0, 0.5});
    b = build_batch<double>({s}, {0, 0, -9.81});
    b.set_node_force(0, 24, {0.02, 0.01, 0});
    converged = solve_static(b).converged;
    for (int j = 0; j <= 24; ++j)
      if (b.model.node_inv_mass[b.node_index(0, j)] != 0) d.node_slots.push_back(b.node_index(0, j));
    for (int e = 0; e < 24; ++e) d.elem_slots.push_back(b.elem_index(0, e));
    for (int a = 0; a < 3; ++a) f[a].resize(b.slots(), 0.0), c[a].resize(b.slots(), 0.0);
  }
};

TEST(Statics, GroupedJacobianIsTheColumnByColumnOne) {
  // The Newton Jacobian perturbs the unknowns of cells five apart together
  // (host/core/analysis/statics.h residual_jacobian): exact only if each cell's residual
  // depends on the unknowns of cells r − 2 … r + 2 alone. On a bent, curly
  // rod under gravity: the one-column-at-a-time Jacobian is exactly zero
  // beyond that band, and the grouped one equals it.
  CurlyRod rod;
  ASSERT_TRUE(rod.converged);
  auto &b = rod.b;
  auto &d = rod.d;
  auto &f = rod.f, &c = rod.c;
  const Eigen::MatrixXd full = detail::residual_jacobian<kAllTerms>(b, d, f, c, kL, 1e-6, false);
  const Eigen::MatrixXd grouped = detail::residual_jacobian<kAllTerms>(b, d, f, c, kL, 1e-6, true);
  const int first = b.node_index(0, 0);
  double outside = 0;
  for (int r = 0; r < full.rows(); ++r)
    for (int col = 0; col < full.cols(); ++col)
      if (std::abs(detail::dof_cell(d, r, first) - detail::dof_cell(d, col, first)) > 2)
        outside = std::max(outside, std::abs(full(r, col)));
  EXPECT_EQ(outside, 0.0);
  // equal to round-off: ±h steps do not restore the state bit for bit
  // (x + h − 2h + h, frame rotations), so the two orders of evaluation see
  // base states ε|x| apart, which moves a difference quotient by about
  // ε/h_rel of the entries' scale; ten times that asserted
  const double scale = full.cwiseAbs().maxCoeff(), diff = (grouped - full).cwiseAbs().maxCoeff();
  std::printf("grouped against one column at a time: %.3e of the largest entry\n", diff / scale);
  EXPECT_GT(scale, 0.0);
  EXPECT_LE(diff, 10 * std::numeric_limits<double>::epsilon() / 1e-6 * scale);
}

TEST(Statics, BandedSolveIsTheDenseLuSolve) {
  // The Newton step's banded storage holds the grouped Jacobian's entries,
  // and its banded LU with partial pivoting solves J x = r as the
  // dense LU does: the two solutions agree to the round-off that the
  // condition number allows (κ ε, ten times asserted).
  CurlyRod rod;
  ASSERT_TRUE(rod.converged);
  auto &b = rod.b;
  auto &d = rod.d;
  auto &f = rod.f, &c = rod.c;
  const Eigen::MatrixXd dense = detail::residual_jacobian<kAllTerms>(b, d, f, c, kL, 1e-6, true);
  detail::BandedJacobian J;
  J.plan(d, b.rods[0].offset);
  detail::banded_jacobian<kAllTerms>(b, d, f, c, kL, 1e-6, J);
  // (two evaluations: the ±h steps move the state by round-off between
  // them, as in GroupedJacobianIsTheColumnByColumnOne, hence its bound)
  const double scale = dense.cwiseAbs().maxCoeff();
  EXPECT_LE((J.dense() - dense).cwiseAbs().maxCoeff(), 10 * std::numeric_limits<double>::epsilon() / 1e-6 * scale);
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  Eigen::VectorXd rhs(dense.rows());
  for (int i = 0; i < rhs.size(); ++i) rhs[i] = g(rng);
  Eigen::VectorXd x;
  ASSERT_TRUE(detail::solve_banded(J, rhs, x));
  const Eigen::VectorXd ref = dense.partialPivLu().solve(rhs);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(dense);
  const double kappa = svd.singularValues()(0) / svd.singularValues().tail(1)(0);
  const double err = (x - ref).norm() / ref.norm();
  std::printf("banded against dense LU: %.3e relative (condition number %.3e)\n", err, kappa);
  EXPECT_LE(err, 10 * kappa * std::numeric_limits<double>::epsilon());
  EXPECT_LE((J.times(x) - rhs).norm(), 10 * kappa * std::numeric_limits<double>::epsilon() * rhs.norm());
}

namespace {

// A straight round rod along e1 from `start`, length 1 m, n elements.
RodSpec support_rod(Vec3 start, int n) {
  RodSpec s = RodSpec::straight(start, {1, 0, 0}, {0, 0, 1}, 1.0, n);
  s.name = "beam";
  s.section = Section::circle(0.01);
  s.material = {1000, 1e9, 0.3};
  s.clamped_root = false;
  return s;
}

Vec3 cross3(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

}  // namespace

TEST(Statics, HoldReactionsBalanceTheLoads) {
  // What the holds exert on their rods at static equilibrium (hold_reactions):
  // a cantilever with a tip force, a span clamped at both ends, a propped
  // cantilever (clamped root, pinned tip), a free rod clamped at its middle
  // node, a clamped rod with a pinned interior node, under gravity.
  // Independent references:
  //  * the loads: the discrete internal forces and couples sum to zero force
  //    and zero moment (they are differences of element and joint
  //    resultants, and the element couple carries the moment of the shear
  //    force), so the reactions balance each rod's weight and tip force,
  //    force and moment about the origin, up to what the equilibrium leaves
  //    on the free unknowns (the residual r: Σ|r| over the free nodes, and
  //    Σ|x||r| + Σ|couple| over the free elements for the moment) and the
  //    round-off of those sums (1e-12 of the weight allowed);
  //  * beam statics: the cantilever's root carries W + P and the moment
  //    W L/2 + P L about e2, to within the load times the tip deflection
  //    (the arms shorten by less than the deflection); the clamped span
  //    splits the weight in halves (symmetry: to the residual); the propped
  //    cantilever's pin carries 3W/8 (Euler–Bernoulli, small deflections:
  //    the batch is under a tenth of gravity; at full gravity the pin
  //    carries 1.8e-3 W more, a large-deflection effect that does not fall
  //    with dx), to the discrete beam's O(dx²) error (measured 5.2e-4,
  //    1.6e-4, 7.6e-5 of W at n = 20, 40, 80) and its shear flexibility
  //    (r²E/(κGL²) ≈ 3e-4), allowed as 2 (dx/L)² + 3e-4 of W; pinned holds
  //    exert no moment (exactly); the rod clamped at its middle carries its
  //    weight with no moment (symmetry).
  const int n = 20;
  std::vector<RodSpec> rods;
  RodSpec a = support_rod({0, 0, 0}, n);  // cantilever
  a.clamped_root = true;
  rods.push_back(a);
  RodSpec c = support_rod({0, 1, 0}, n);  // clamped span
  c.clamped_root = c.clamped_tip = true;
  rods.push_back(c);
  RodSpec p = support_rod({0, 2, 0}, n);  // propped cantilever: clamped root, pinned tip
  p.clamped_root = true;
  p.pinned_tip = true;
  rods.push_back(p);
  RodSpec m = support_rod({0, 3, 0}, n);  // clamped at the middle
  m.holds.push_back({n / 2, HoldKind::clamped, nullptr});
  rods.push_back(m);
  RodSpec q = support_rod({0, 4, 0}, n);  // clamped root, pinned node 12
  q.clamped_root = true;
  q.holds.push_back({12, HoldKind::pinned, nullptr});
  rods.push_back(q);
  const double g = 0.981;  // a tenth of gravity: small deflections (see above)
  RodBatch<double> b = build_batch<double>(rods, {0, 0, -g});
  const Vec3 P = {0.0, 0.02, -0.05};  // N, on the cantilever's tip
  b.set_node_force(0, n, P);
  StaticOptions opt;
  opt.load_steps = 4;
  opt.tolerance = 1e-12;
  const StaticResult res = solve_static<kNoKelvinVoigt>(b, opt);
  std::printf("static solve: %d Newton iterations, last update %.2e\n", res.iterations, res.last_update);
  ASSERT_TRUE(res.converged);
  const std::vector<HoldReaction> h = hold_reactions<kNoKelvinVoigt>(b);
  ASSERT_EQ(h.size(), 8u);
  // the residual: generalized forces (velocities are zero after the solve)
  std::array<std::vector<double>, 3> rf3, rc3;
  for (int i = 0; i < 3; ++i) rf3[i].assign(std::size_t(b.slots()), 0.0), rc3[i].assign(std::size_t(b.slots()), 0.0);
  double* const rfp[3] = {rf3[0].data(), rf3[1].data(), rf3[2].data()};
  double* const rcp[3] = {rc3[0].data(), rc3[1].data(), rc3[2].data()};
  generalized_forces<kNoKelvinVoigt>(b, rfp, rcp);
  const double W = b.rods[0].elastic.density * b.rods[0].section.area * 1.0 * g;
  double residual[5];  // each rod's Σ|r| over its free nodes, plus round-off
  for (int r = 0; r < 5; ++r) {
    Vec3 force{}, moment{};  // of the loads and the reactions, about the origin
    double left_f = 0, left_m = 0;  // what the equilibrium leaves on the free unknowns
    for (int j = 0; j <= n; ++j) {
      const Vec3 x = b.position(r, j);
      const int k = b.node_index(r, j);
      if (b.model.node_inv_mass[k] != 0) {
        const double rf = std::hypot(rf3[0][k], rf3[1][k], rf3[2][k]);
        left_f += rf;
        left_m += rf * std::hypot(x[0], x[1], x[2]);
      }
      if (j < n && b.model.elem_inv_inertia[0][k] != 0)
        left_m += std::hypot(rc3[0][k], rc3[1][k], rc3[2][k]);
      Vec3 w = {0, 0, -g * b.model.node_mass[b.node_index(r, j)]};
      if (r == 0 && j == n) w = {w[0] + P[0], w[1] + P[1], w[2] + P[2]};
      const Vec3 mw = cross3(x, w);
      for (int i = 0; i < 3; ++i) force[i] += w[i], moment[i] += mw[i];
    }
    int holds = 0;
    for (const HoldReaction& hr : h) {
      if (hr.rod != r) continue;
      ++holds;
      const Vec3 mr = cross3(b.position(r, hr.node), hr.force);
      for (int i = 0; i < 3; ++i) force[i] += hr.force[i], moment[i] += mr[i] + hr.moment[i];
      if (!hr.clamped) {
        EXPECT_EQ(hr.moment[0] * hr.moment[0] + hr.moment[1] * hr.moment[1] + hr.moment[2] * hr.moment[2], 0.0);
      }
    }
    EXPECT_GT(holds, 0) << "rod " << r;
    std::printf("rod %d: %d holds; force balance %.2e N (residual %.2e), moment balance %.2e N m (residual %.2e)\n",
                r, holds, std::hypot(force[0], force[1], force[2]), left_f, std::hypot(moment[0], moment[1], moment[2]),
                left_m);
    residual[r] = left_f + 1e-12 * W;
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(force[i], 0.0, left_f + 1e-12 * W) << "rod " << r << " force " << i;
      EXPECT_NEAR(moment[i], 0.0, left_m + 1e-12 * W * 5) << "rod " << r << " moment " << i;  // arms ≤ 5 m
    }
  }
  // the cantilever: W + P at the root, and the moment that holds them
  const HoldReaction& root = h[0];
  ASSERT_EQ(root.rod, 0);
  ASSERT_TRUE(root.clamped);
  const Vec3 tip = b.position(0, n);
  const double deflection = std::hypot(tip[0] - 1.0, tip[1], tip[2]), load = W + std::hypot(P[0], P[1], P[2]);
  std::printf("cantilever: root force (%.6e, %.6e, %.6e) N, moment (%.6e, %.6e, %.6e) N m, tip deflection %.2e m\n",
              root.force[0], root.force[1], root.force[2], root.moment[0], root.moment[1], root.moment[2], deflection);
  EXPECT_NEAR(root.force[1], -P[1], residual[0]);
  EXPECT_NEAR(root.force[2], W - P[2], residual[0]);
  EXPECT_NEAR(root.moment[1], -(W / 2 - P[2]) * 1.0, load * deflection);  // −(moment of the loads) about the root
  EXPECT_NEAR(root.moment[2], -P[1] * 1.0, load * deflection);
  // the symmetric spans: half the weight at each end; the middle clamp: all of it, no moment
  for (int r : {1, 2}) {
    std::vector<const HoldReaction*> ends;
    for (const HoldReaction& hr : h)
      if (hr.rod == r) ends.push_back(&hr);
    ASSERT_EQ(ends.size(), 2u);
    std::printf("rod %d: end forces %.6e and %.6e N (weight %.6e N)\n", r, ends[0]->force[2], ends[1]->force[2], W);
    if (r == 1) {
      EXPECT_NEAR(ends[0]->force[2], W / 2, residual[1]) << "clamped span";
      EXPECT_NEAR(ends[1]->force[2], W / 2, residual[1]) << "clamped span";
      EXPECT_NEAR(ends[0]->force[0], -ends[1]->force[0], residual[1]) << "clamped span";
      EXPECT_NEAR(ends[0]->moment[1], -ends[1]->moment[1], residual[1]) << "clamped span (arms ≤ 1 m)";
    } else {
      const double dx = 1.0 / n;
      EXPECT_NEAR(ends[1]->force[2], 3 * W / 8, (2 * dx * dx + 3e-4) * W) << "propped cantilever's pin";
    }
  }
  for (const HoldReaction& hr : h)
    if (hr.rod == 3) {
      EXPECT_TRUE(hr.clamped);
      EXPECT_NEAR(hr.force[2], W, residual[3]);
      EXPECT_NEAR(hr.moment[1], 0.0, residual[3]);  // (arms ≤ 1 m)
    }
}

namespace {

// A column between pins, its tip pushed towards its root so that the
// chord is (1 − shorten) L (a driven pinned tip, solved at the end of its
// ramp). Built bowed (tangent angle 0.1 cos(πs/L), unstressed rest shape
// straight, arc length L) so that the load path follows the buckled branch,
// not the straight compressed one (an equilibrium too, unstable: Newton
// does not tell them apart). The seed cantilever's section, shear and
// stretch stiffened 1e4× (nearly inextensible), no gravity. Returns the
// midspan deflection /L, the axial reaction at the root /(EI/L²), and the
// reactions' largest lateral part /(EI/L²).
struct Column {
  double deflection, axial, lateral;
  StaticResult result;
};
Column pinned_column(int n, double shorten) {
  const double dx = kL / n;
  std::vector<Vec3> nodes{{0, 0, 0}};
  for (int e = 0; e < n; ++e) {
    const double th = 0.1 * std::cos(kPi * (e + 0.5) / n);
    const Vec3& p = nodes.back();
    nodes.push_back({p[0] + dx * std::sin(th), 0, p[2] + dx * std::cos(th)});
  }
  RodSpec s = seed_cantilever(n);
  const RodSpec straight = s;
  s.nodes = nodes;
  s.frames = RodSpec::parallel_transport_frames(nodes, {0, 1, 0});
  s.rest_curvature.assign(std::size_t(n - 1), {0, 0, 0});
  s.shear_stretch_scale = 1e4;
  s.clamped_root = false;
  s.pinned_root = s.pinned_tip = true;
  auto ramp = std::make_shared<RampMotion>();
  ramp->translation = {-nodes.back()[0], 0, (1 - shorten) * kL - nodes.back()[2]};
  ramp->duration = 1;
  s.tip_motion = ramp;
  auto b = build_batch<double>({s});
  StaticOptions opt;
  opt.hold_time = 1;
  opt.load_steps = 20;
  Column out{};
  out.result = solve_static<kNoKelvinVoigtNoGravity>(b, opt);
  const double scale = kEI / (kL * kL);
  out.deflection = std::abs(b.position(0, n / 2)[0]) / kL;
  for (const HoldReaction& h : hold_reactions<kNoKelvinVoigtNoGravity>(b)) {
    if (h.node == 0) out.axial = h.force[2] / scale;
    out.lateral = std::max({out.lateral, std::abs(h.force[0]) / scale, std::abs(h.force[1]) / scale});
  }
  return out;
}

// The inextensible pinned–pinned elastica (its first mode: two cantilevers
// of length L/2 back to back, Timoshenko & Gere §2.7): with k = sin(α/2), α
// the end slope, K, E the complete elliptic integrals of modulus k, the
// chord is L (2E/K − 1), the load P = 4K² EI/L² and the midspan deflection
// δ = k L/K. k from the chord by bisection (2E/K − 1 falls from 1 at k = 0
// to −1 at k = 1).
struct ColumnTheory {
  double deflection, axial;  // δ/L, P/(EI/L²)
};
ColumnTheory column_theory(double shorten) {
  double lo = 0, hi = 1 - 1e-15;
  for (int i = 0; i < 200; ++i) {
    const double k = 0.5 * (lo + hi);
    const double chord = 2 * std::comp_ellint_2(k) / std::comp_ellint_1(k) - 1;
    (chord > 1 - shorten ? lo : hi) = k;
  }
  const double k = 0.5 * (lo + hi), K = std::comp_ellint_1(k);
  return {k / K, 4 * K * K};
}

}  // namespace

TEST(Statics, PinnedColumnPushedInIsTheEulerElastica) {
  // docs/validation.md 1d. Independent reference: the closed form above.
  // The discrete error is O(dx²) (the scheme's, as in 1b); the rod's
  // extensibility adds P/(1e4 EA) ≈ 1e-8 relative, far below it. Asserted:
  // the error at n = 40 below 2e-3 relative (the 1b errors at n = 50 are
  // ~2e-4; the column bends twice as hard per length) and the observed order
  // 2 ± 0.2 from n = 20, 40, 80. Pinned holds exert no lateral force on a
  // symmetric column: the reactions' lateral parts are the residual's.
  for (const double shorten : {0.1, 0.4}) {
    const ColumnTheory th = column_theory(shorten);
    const Column c20 = pinned_column(20, shorten), c40 = pinned_column(40, shorten), c80 = pinned_column(80, shorten);
    for (const Column* c : {&c20, &c40, &c80}) {
      EXPECT_TRUE(c->result.converged);
      EXPECT_LT(c->lateral, 1e-6);
    }
    const double d[3] = {c20.deflection - th.deflection, c40.deflection - th.deflection, c80.deflection - th.deflection};
    const double p[3] = {c20.axial - th.axial, c40.axial - th.axial, c80.axial - th.axial};
    std::printf("shortening %.1f: deflection %.6f (theory %.6f), errors %.2e %.2e %.2e; axial %.5f (theory %.5f), "
                "errors %.2e %.2e %.2e\n",
                shorten, c80.deflection, th.deflection, d[0], d[1], d[2], c80.axial, th.axial, p[0], p[1], p[2]);
    EXPECT_LT(std::abs(d[1]) / th.deflection, 2e-3);
    EXPECT_LT(std::abs(p[1]) / th.axial, 2e-3);
    EXPECT_NEAR(std::log2(d[0] / d[1]), 2.0, 0.2);
    EXPECT_NEAR(std::log2(d[1] / d[2]), 2.0, 0.2);
    EXPECT_NEAR(std::log2(p[0] / p[1]), 2.0, 0.2);
    EXPECT_NEAR(std::log2(p[1] / p[2]), 2.0, 0.2);
  }
}

TEST(Statics, ARodFreeToMoveUnderItsLoadsIsNamedAsAMechanism) {
  // A rod without holds in gravity: the loads push along motions of zero
  // stiffness (its rigid motions) and no equilibrium exists. The solve says
  // so: not converged, a mechanism, the rod named (the clamped cantilever
  // beside it is solved), zero modes counted. A pendulum (pinned root, the
  // rod horizontal) is a mechanism too, but with an equilibrium: the
  // trust-region steps turn it about the pin (0.05 rad per update, the
  // turn costing nothing) until it hangs straight down, stretched by its
  // weight: the tip 0.3 m below the pin, within its strain (< 1e-2 L).
  // A pinned–pinned rod without loads has a zero mode that the loads do not
  // push along (its frames spinning about its axis): that one converges.
  RodSpec free_rod = seed_cantilever(10);
  free_rod.clamped_root = false;
  RodSpec pendulum = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, kL, 10);
  pendulum.section = free_rod.section;
  pendulum.material = free_rod.material;
  pendulum.pinned_root = true;
  RodSpec pinned = pendulum;
  pinned.pinned_tip = true;
  {
    auto b = build_batch<double>({seed_cantilever(10), free_rod}, {0, 0, -9.81});
    const StaticResult r = solve_static(b);
    std::printf("free rod: converged %d, mechanism %d, %d zero modes, residual %.3g N at node %d\n", r.converged,
                r.mechanism, r.zero_modes, r.residual_force, r.failed_node);
    EXPECT_FALSE(r.converged);
    EXPECT_TRUE(r.mechanism);
    EXPECT_EQ(r.failed_rod, 1);
    EXPECT_GE(r.zero_modes, 3);
    EXPECT_GT(r.residual_force, 0.0);
  }
  {
    auto b = build_batch<double>({pendulum}, {0, 0, -9.81});
    const StaticResult r = solve_static(b);
    EXPECT_TRUE(r.converged);
    const Vec3 tip = b.position(0, 10);
    EXPECT_NEAR(tip[0], 0, 1e-9);
    EXPECT_NEAR(tip[2], -kL, 1e-2 * kL);
    EXPECT_LT(tip[2], -kL);  // (stretched, not compressed)
  }
  auto b = build_batch<double>({pinned}, {0, 0, 0});
  const StaticResult r = solve_static(b);
  EXPECT_TRUE(r.converged);
  EXPECT_FALSE(r.mechanism);
}

TEST(Statics, AdaptiveLoadStepsReachTheSameEquilibrium) {
  // The 1b cantilever at α = 10 (θ_L = 82°) in one requested load step:
  // the increments adapt (Newton from the straight rod under the full load
  // fails within its iterations, the increment is halved) and reach the
  // equilibrium that 20 equal steps reach, to the Newton tolerance's
  // effect on positions (1e-10 L, ten times asserted). A self-consistency
  // check of the path control; the reference equilibrium is checked
  // against the elastica in Case1b.
  auto solve = [](int steps, int max_iterations) {
    RodSpec s = seed_cantilever(40);
    s.shear_stretch_scale = 1e4;
    auto b = build_batch<double>({s});
    b.set_node_force(0, 40, {10 * kEI / (kL * kL), 0, 0});
    StaticOptions opt;
    opt.load_steps = steps;
    opt.max_newton_iterations = max_iterations;
    const StaticResult r = solve_static<kNoKelvinVoigtNoGravity>(b, opt);
    EXPECT_TRUE(r.converged);
    return std::pair{b.position(0, 40), r};
  };
  const auto [x20, r20] = solve(20, 50);
  const auto [x1, r1] = solve(1, 8);
  std::printf("one requested step: %d increments, %d iterations (20 steps: %d, %d)\n", r1.load_increments,
              r1.iterations, r20.load_increments, r20.iterations);
  EXPECT_GT(r1.load_increments, 1);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(x1[a], x20[a], 1e-9 * kL);
}

namespace {

// A heavy cantilever clamped level at height h (plus its contact radius)
// above a frictionless floor, long enough to touch down and lie on it: its
// clamp's force and moment (z, about e2), the touchdown span's theory a.
struct Touchdown {
  double force, moment, span;
  StaticResult result;
};
// A frictionless floor through the origin, normal +z (a plane collider).
void on_a_floor(RodBatch<double>& b) {
  ContactSpec spec;
  Collider floor;
  floor.kind = ColliderKind::plane;
  spec.colliders.push_back(floor);
  set_contact(b, spec);
}

Touchdown touchdown(int n, double h) {
  RodSpec s = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, kL, n);
  s.section = Section::rectangle(kA, kA);
  s.material = {kRho, kE, kNu};
  s.clamped_root = true;
  s.shear_stretch_scale = 100;  // (an Euler–Bernoulli beam: shear would add 1.5 % at this span)
  auto b = build_batch<double>({s}, {0, 0, -9.81});
  const double r = b.rods[0].contact_radius;
  for (int j = 0; j <= n; ++j) b.state.node_x[2][b.node_index(0, j)] = r + h;
  on_a_floor(b);
  StaticOptions opt;
  opt.load_steps = 20;
  Touchdown out{};
  out.result = solve_static<kNoKelvinVoigt>(b, opt);
  const HoldReaction root = hold_reactions<kNoKelvinVoigt>(b).at(0);
  out.force = root.force[2];
  out.moment = root.moment[1];
  const double q = kRho * kA * kA * 9.81;
  out.span = std::pow(72 * kEI * h / q, 0.25);
  return out;
}

}  // namespace

TEST(Statics, ACantileverOnAFloorTouchesDownWhereBeamTheorySays) {
  // docs/validation.md 1e. Independent reference: Euler–Bernoulli, the span
  // 0 … a clamped level at height h with zero slope and moment where it
  // touches down (the floor carries the rest flat): EI w'''' = −q gives
  // h = q a⁴/(72 EI), the clamp's force 2qa/3 (up) and moment q a²/6 (the
  // floor takes qa/3 at the touchdown point). The rod is stiffened in shear
  // and stretch ×100 (unstiffened, its shear adds 1.45 % to the force and
  // 2.6 % to the moment: a Timoshenko beam, measured; ×100 leaves 1.5e-4);
  // its geometric nonlinearity adds O((h/a)²) ≈ 1.3e-4; the penalty's
  // overlap (~1e-6 m) is negligible against h = 1 mm. The discrete error is
  // O(dx²) (measured 2.3e-3 → 6.4e-4 for the force, 5.5e-3 → 1.4e-3 for the
  // moment, n = 60 → 120). Asserted: the order from n = 60 to 120 above 1.5,
  // and the error at n = 120 below 4 (dx/a)² + 3e-4 (3.5e-3: the touchdown
  // and the clamp each err at O(dx²)).
  const double h = 1e-3, q = kRho * kA * kA * 9.81;
  const Touchdown t60 = touchdown(60, h), t120 = touchdown(120, h);
  const double a = t60.span, F = 2 * q * a / 3, M = q * a * a / 6;
  for (const Touchdown* t : {&t60, &t120}) EXPECT_TRUE(t->result.converged);
  const double e60[2] = {t60.force / F - 1, -t60.moment / M - 1}, e120[2] = {t120.force / F - 1, -t120.moment / M - 1};
  std::printf("touchdown span %.4f m: clamp force %.5f / %.5f N (theory %.5f), moment %.6f / %.6f N m (theory %.6f); "
              "relative errors %.2e %.2e, %.2e %.2e\n",
              a, t60.force, t120.force, F, t60.moment, t120.moment, -M, e60[0], e120[0], e60[1], e120[1]);
  const double dx = kL / 120;
  for (int i = 0; i < 2; ++i) {
    EXPECT_LT(std::abs(e120[i]), 4 * (dx / a) * (dx / a) + 3e-4);
    EXPECT_GT(std::log2(e60[i] / e120[i]), 1.5);
  }
}

TEST(Statics, ARodSolvedBeforeWalksOnlyItsMovedHoldsInOneIncrement) {
  // A heavy cable clamped at both ends, its tip lowered on a ramp (the
  // cable drawn taut: one equilibrium); solved at t = 0.5 (cold: the loads
  // ramped from 0), then at t = 0.51 after its tip moved 2 mm (warm: in
  // equilibrium under its full loads, so only the tip walks, in one
  // increment). The warm solve reaches the equilibrium a
  // cold solve at t = 0.51 reaches, to the Newton tolerance's effect on
  // positions (1e-10 L, a hundred times asserted: two solves' round-off
  // floors); a self-consistency check of the warm start.
  auto cable = [] {
    RodSpec s = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 1.0, 40);
    s.section = Section::circle(0.004);
    s.material = {1400, 5e7, 0.45};
    s.clamped_root = s.clamped_tip = true;
    auto ramp = std::make_shared<RampMotion>();
    ramp->translation = {0, 0, -0.2};
    ramp->duration = 1;
    s.tip_motion = ramp;
    return build_batch<double>({s}, {0, 0, -9.81});
  };
  StaticOptions opt;
  auto warm = cable();
  opt.hold_time = 0.5;
  const StaticResult first = solve_static(warm, opt);
  ASSERT_TRUE(first.converged);
  EXPECT_EQ(first.warm_rods, 0);
  EXPECT_GE(first.load_increments, 10);
  opt.hold_time = 0.51;
  const StaticResult again = solve_static(warm, opt);
  ASSERT_TRUE(again.converged);
  EXPECT_EQ(again.warm_rods, 1);
  EXPECT_EQ(again.load_increments, 1);
  auto cold = cable();
  ASSERT_TRUE(solve_static(cold, opt).converged);
  std::printf("warm re-solve: %d Newton iterations (the first solve %d)\n", again.iterations, first.iterations);
  for (int j = 0; j <= 40; ++j)
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(warm.position(0, j)[a], cold.position(0, j)[a], 1e-8);
}

TEST(Statics, ATaperedCantileverDeflectsAsItsLocalSectionSays) {
  // docs/validation.md "1g A tapered cantilever". Independent reference: a
  // cantilever whose circular section tapers linearly from r0 at the root
  // to r1 at the tip, under a small tip load F across it: its tip
  // deflection is δ = F ∫₀ᴸ (L − s)²/(E I(s)) ds + F ∫₀ᴸ ds/(κ G A(s))
  // (bending and the Timoshenko shear term, I = π r⁴/4, A = π r², κ the
  // section's shear factor), both integrals by composite Simpson on 4,000
  // panels (exact to 1e-12). The rod: section_scale = r(s_e)/r0 at each
  // element's midpoint. At δ/L ≈ 2e-4 the geometric nonlinearity is
  // O((δ/L)²); the discrete error is O(dx²) (the midpoint sections, the
  // joints' mean stiffness). Asserted: the error below 2 (dx/L)² at n = 40
  // and second order (above 1.7) from n = 20 to 40; and the rod's mass is
  // ρ Σ A_e l̂_e exactly (to 1e-14).
  const double L = 0.3, r0 = 0.01, r1 = 0.004, E = 1e6, nu = 0.3, rho = 1000, F = 1e-5;
  auto radius = [&](double s) { return r0 + (r1 - r0) * s / L; };
  RodSpec probe = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, L, 4);
  probe.section = Section::circle(r0);
  probe.material = {rho, E, nu};
  const RodBatch<double> pb = build_batch<double>({probe});
  const double kappa = pb.rods[0].section.shear_factor1, G = pb.rods[0].elastic.G;
  double bend = 0, shear = 0;
  const int panels = 4000;
  for (int i = 0; i <= panels; ++i) {
    const double s = L * i / panels, w = (i == 0 || i == panels) ? 1 : (i % 2 ? 4 : 2);
    const double r = radius(s), I = kPi * r * r * r * r / 4, A = kPi * r * r;
    bend += w * (L - s) * (L - s) / (E * I);
    shear += w / (kappa * G * A);
  }
  const double delta = F * (bend + shear) * (L / panels) / 3;
  auto tip = [&](int n) {
    RodSpec s = probe;
    s = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, L, n);
    s.section = Section::circle(r0);
    s.material = {rho, E, nu};
    s.clamped_root = true;
    for (int e = 0; e < n; ++e) s.section_scale.push_back(radius((e + 0.5) * L / n) / r0);
    RodBatch<double> b = build_batch<double>({s});
    double mass = 0, expected = 0;
    for (int j = 0; j <= n; ++j) mass += b.model.node_mass[b.node_index(0, j)];
    for (int e = 0; e < n; ++e) expected += rho * kPi * std::pow(r0 * s.section_scale[std::size_t(e)], 2) * L / n;
    EXPECT_NEAR(mass, expected, 1e-14 * expected);
    b.set_node_force(0, n, {F, 0, 0});
    EXPECT_TRUE(solve_static(b).converged);
    return b.position(0, n)[0];
  };
  const double e20 = std::abs(tip(20) / delta - 1), e40 = std::abs(tip(40) / delta - 1);
  std::printf("tapered cantilever: delta %.6e m (shear part %.2e); errors %.3e (n = 20), %.3e (n = 40), order %.2f\n",
              delta, shear / (bend + shear), e20, e40, std::log2(e20 / e40));
  EXPECT_LT(e40, 2.0 / (40 * 40));
  EXPECT_GT(std::log2(e20 / e40), 1.7);
}

TEST(Statics, AHeavyCableBetweenClampsTendsToTheCatenaryAsItsBendingLayerVanishes) {
  // docs/validation.md "1h". A cable of length 1 m (r = 2 mm, ρ = 1400,
  // stretch and shear stiffened to EA = 1.3e4 N: nearly inextensible, its
  // stretch 1e-5) clamped level at both ends, its tip driven 0.2 m in over
  // a second, solved static at t = 1. Independent reference: the
  // inextensible catenary of that length and span, L = 2a sinh(S/2a),
  // H = q a, end tension T = q a cosh(S/2a). The cable's bending stiffness
  // holds its ends level over a layer λ = √(EI/H) and carries part of the
  // weight: its tension tends to the catenary's as λ → 0, the layer's
  // effect on the slack being at most first order in λ/S. Asserted: the
  // clamps' vertical forces add up to the weight and the horizontal ones
  // cancel, to the solve's residual (its largest force on a node, times the
  // nodes); at E = 100 kPa and 10 kPa (λ √10 apart) the errors of H and T
  // are below 2 λ/S (the first-order bound; measured 1.1 λ/S and 0.4 λ/S at
  // 100 kPa) and fall by more than 2 (measured 7.9: order 1.8 in λ; at
  // 10 kPa λ = 1.4 mm is below dx = 25 mm, so that error is partly the
  // discretization's).
  const double Lc = 1.0, S = 0.8, r = 0.002, rho = 1400, q = rho * kPi * r * r * 9.81;
  auto cable = [&](double E) {
    RodSpec s = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, Lc, 40);
    s.section = Section::circle(r);
    s.material = {rho, E, 0.45};
    s.shear_stretch_scale = 1e10 / E;  // EA = 1.3e4 N whatever E
    s.clamped_root = s.clamped_tip = true;
    auto ramp = std::make_shared<RampMotion>();
    ramp->translation = {-(Lc - S), 0, 0};
    ramp->duration = 1;
    ramp->smooth = true;
    s.tip_motion = ramp;
    return build_batch<double>({s}, {0, 0, -9.81});
  };
  // the catenary: solve L = 2a sinh(S/2a) for a by bisection
  double lo = 0.01, hi = 100;
  for (int i = 0; i < 200; ++i) {
    const double a = 0.5 * (lo + hi);
    (2 * a * std::sinh(S / (2 * a)) > Lc ? lo : hi) = a;
  }
  const double a = 0.5 * (lo + hi), H = q * a, T = q * a * std::cosh(S / (2 * a));
  struct Errors {
    double h, t, lambda;
  };
  auto errors = [&](double E) {
    RodBatch<double> b = cable(E);
    StaticOptions opt;
    opt.hold_time = 1.0;
    const StaticResult res = solve_static(b, opt);
    EXPECT_TRUE(res.converged) << E;
    const std::vector<HoldReaction> h = hold_reactions(b);
    EXPECT_EQ(h.size(), 2u);
    const double weight = q * Lc, left = 41 * res.residual_force;
    EXPECT_NEAR(h[0].force[2] + h[1].force[2], weight, left);
    EXPECT_NEAR(h[0].force[0] + h[1].force[0], 0, left);
    const double lambda = std::sqrt(E * kPi * std::pow(r, 4) / 4 / H);
    const Errors e{std::abs(-h[0].force[0] / H - 1), std::abs(std::hypot(h[0].force[0], h[0].force[2]) / T - 1), lambda};
    std::printf("catenary, E = %.0e Pa: H %.5f N (catenary %.5f), T %.5f N (catenary %.5f): errors %.2e, %.2e; "
                "lambda/S = %.4f; balance to %.1e N\n",
                E, -h[0].force[0], H, std::hypot(h[0].force[0], h[0].force[2]), T, e.h, e.t, lambda / S, left);
    return e;
  };
  const Errors e1 = errors(1e5), e2 = errors(1e4);
  EXPECT_GT(e1.h / e2.h, 2);
  EXPECT_GT(e1.t / e2.t, 2);
  for (const Errors& e : {e1, e2}) {
    EXPECT_LT(e.h, 2 * e.lambda / S);
    EXPECT_LT(e.t, 2 * e.lambda / S);
  }
}

TEST(Statics, ACableLiftedOffAFloorByAPinnedNodeCarriesBeamTheorysLoad) {
  // docs/validation.md "1i". A rod of the seed's section and material
  // (shear and stretch ×100, as 1e), 0.6 m, lying on a frictionless floor
  // (a plane collider), its ends free, so that it slides in from both
  // sides as its middle rises (with an end clamped, the lifted arc has to
  // stretch: its tension changes the load by 3–6 %, measured; turning
  // about the pin is a motion of zero stiffness, which the loads do not
  // push along); its middle node is pinned and driven up by h = 1 mm over a
  // second, solved static at t = 1 under gravity. By symmetry the lifted node keeps zero slope, so each side is
  // 1e's span: clamped level at height h, touching down at
  // a = (72 EI h/q)^¼ with zero slope and moment, the floor carrying the
  // rest (Euler–Bernoulli, independent). The pin carries 2 × 2qa/3 = 4qa/3.
  // Asserted, as 1e: the error at n = 240 (dx = 2.5 mm) below
  // 4 (dx/a)² + 3e-4 and the order from n = 120 to 240 above 1.5.
  const double L = 0.6, h = 1e-3, q = kRho * kA * kA * 9.81;
  const double a = std::pow(72 * kEI * h / q, 0.25), P = 4 * q * a / 3;
  auto lift = [&](int n) {
    // built lying on the floor: its centreline a contact radius above it
    const double r = contact_radius(Section::rectangle(kA, kA));
    RodSpec s = RodSpec::straight({0, 0, r}, {1, 0, 0}, {0, 0, 1}, L, n);
    s.section = Section::rectangle(kA, kA);
    s.material = {kRho, kE, kNu};
    s.shear_stretch_scale = 100;
    auto up = std::make_shared<RampMotion>();
    up->translation = {0, 0, h};
    up->duration = 1;
    s.holds.push_back({n / 2, HoldKind::pinned, up});
    auto b = build_batch<double>({s}, {0, 0, -9.81});
    on_a_floor(b);
    StaticOptions opt;
    opt.hold_time = 1;
    EXPECT_TRUE(solve_static<kNoKelvinVoigt>(b, opt).converged) << n;
    for (const HoldReaction& hr : hold_reactions<kNoKelvinVoigt>(b))
      if (hr.node == n / 2) return hr.force[2];
    return 0.0;
  };
  const double e120 = std::abs(lift(120) / P - 1), e240 = std::abs(lift(240) / P - 1);
  std::printf("lifted cable: pin force error %.3e (n = 120), %.3e (n = 240), order %.2f (4qa/3 = %.5f N, a = %.4f m)\n",
              e120, e240, std::log2(e120 / e240), P, a);
  const double dx = L / 240;
  EXPECT_LT(e240, 4 * (dx / a) * (dx / a) + 3e-4);
  EXPECT_GT(std::log2(e120 / e240), 1.5);
}

TEST(Statics, TwoClampedBeamsCrossedAtTheirMiddlesShareTheLoadAsBeamTheorySays) {
  // docs/validation.md "1j". Rod–rod contact in the static solve: two
  // clamped–clamped round beams of length L = 0.1 m (r = 1 mm, ρ = 250,
  // shear and stretch ×100: Euler–Bernoulli beams), crossed at right
  // angles at their middles, the upper one (E) resting on the lower one
  // (4E) at the crossing, both under gravity. Independent reference (beam
  // theory, small deflection): each beam's midspan deflects under its own
  // weight qL⁴/384EI and a point load P at the middle, PL³/192EI, up on
  // the upper beam and down on the lower; the two middles move together,
  // apart by the overlap o that the contact law carries P at,
  // o = √(2δP/k) (k = EA/ℓ of the upper beam's element, δ = r/10:
  // docs/model.md "Rod–rod contact"), so with a = qL⁴/384EI,
  //   a − x = a/4 + x/4 + o,  x = PL³/192EI  ⇒  P = (0.6 a − 0.8 o)·192EI/L³,
  // solved for P with o(P) by fixed point (P → 0.3 qL as o → 0). P is read
  // from the upper beam's clamps: its weight less what they carry.
  // Asserted: the error at n = 41 below 4 (dx/L)² + 2e-4 (the discrete
  // beam's O(dx²), measured 3.8 (dx/L)², plus the large-deflection and
  // shear effects, estimated 7e-5 and 4e-5 at a/r = 0.026 from runs at
  // four times the weight and without the shear stiffening); the order from
  // n = 21 to 41 above 1.5; the lower beam's clamps carry its weight plus
  // P, to the solve's residual (the push is one force on both rods).
  const double L = 0.1, r = 0.001, E = 1e8, rho = 250, ss = 100;
  const double q = rho * kPi * r * r * 9.81, EI = E * kPi * std::pow(r, 4) / 4, a = q * std::pow(L, 4) / (384 * EI);
  auto crossing = [&](int n) {
    RodSpec up = RodSpec::straight({0, 0, 2 * r}, {1, 0, 0}, {0, 0, 1}, L, n);
    up.section = Section::circle(r);
    up.material = {rho, E, 0.3};
    up.clamped_root = up.clamped_tip = true;
    up.shear_stretch_scale = ss;
    RodSpec low = RodSpec::straight({L / 2, -L / 2, 0}, {0, 1, 0}, {0, 0, 1}, L, n);
    low.section = Section::circle(r);
    low.material = {rho, 4 * E, 0.3};
    low.clamped_root = low.clamped_tip = true;
    low.shear_stretch_scale = ss;
    auto b = build_batch<double>({up, low}, {0, 0, -9.81});
    ContactSpec spec;
    spec.rod_rod = true;
    set_contact(b, spec);
    const StaticResult res = solve_static<kNoKelvinVoigt>(b);
    EXPECT_TRUE(res.converged) << n;
    double held[2] = {0, 0};
    for (const HoldReaction& h : hold_reactions<kNoKelvinVoigt>(b)) held[h.rod] += h.force[2];
    const double P = q * L - held[0];
    EXPECT_NEAR(held[1], q * L + P, 2 * (n + 1) * res.residual_force) << n;
    // the reference with the overlap at P
    const double k = ss * E * kPi * r * r / (L / n), delta = 0.1 * r;
    double ref = 0.3 * q * L;
    for (int i = 0; i < 50; ++i) ref = (0.6 * a - 0.8 * std::sqrt(2 * delta * ref / k)) * 192 * EI / (L * L * L);
    const double err = std::abs(P / ref - 1);
    std::printf("crossed beams, n = %d: P = %.6e N, beam theory %.6e N (0.3 qL = %.6e N): error %.3e\n", n, P, ref,
                0.3 * q * L, err);
    return err;
  };
  const double e21 = crossing(21), e41 = crossing(41);
  std::printf("crossed beams: order %.2f\n", std::log2(e21 / e41));
  EXPECT_LT(e41, 4 * std::pow(1.0 / 41, 2) + 2e-4);
  EXPECT_GT(std::log2(e21 / e41), 1.5);
}

TEST(Statics, AFoldedCableRestsOnItselfWithSelfContactAndFallsThroughWithout) {
  // Self contact in the static solve: a cable (r = 4 mm) built folded as a
  // hairpin in a horizontal plane — two 0.5 m legs 2r apart joined by a
  // half circle — clamped at both ends side by side, gravity across the
  // legs (−y), so that the upper leg comes to lie on the lower one.
  // Regression of behaviour, with an independent bound: with self contact
  // the solve converges, the facing nodes of the two legs stay at least
  // 2r less the deepest overlap apart (contact_stats, below r/100: a
  // penalty overlap, not a pass), upper above lower; without it the upper
  // leg sinks through the lower one (the same solve, the legs crossed).
  const double r = 0.004, leg = 0.5;
  const int nl = 25, nc = 8;
  std::vector<Vec3> nodes;
  for (int i = 0; i <= nl; ++i) nodes.push_back({leg * i / nl, r, 0});
  for (int i = 1; i < nc; ++i) nodes.push_back({leg + r * std::sin(kPi * i / nc), r * std::cos(kPi * i / nc), 0});
  for (int i = 0; i <= nl; ++i) nodes.push_back({leg - leg * i / nl, -r, 0});
  const int last = int(nodes.size()) - 1;
  auto fold = [&](bool self) {
    RodSpec s = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 1.0, last);
    s.nodes = nodes;
    s.frames = RodSpec::parallel_transport_frames(nodes, {0, 0, 1});
    s.rest_curvature.clear();  // (the rest shape: the fold as built)
    s.section = Section::circle(r);
    s.material = {1400, 5e7, 0.45};
    s.clamped_root = s.clamped_tip = true;
    auto b = build_batch<double>({s}, {0, -9.81, 0});
    ContactSpec spec;
    spec.self = self;
    set_contact(b, spec);
    EXPECT_TRUE(solve_static<kNoKelvinVoigt>(b).converged) << self;
    // the facing nodes' distance, negative where the upper leg is below
    double apart = 1e9;
    for (int j = 1; j < nl; ++j) {
      const Vec3 u = b.position(0, j), l = b.position(0, last - j);
      apart = std::min(apart, std::hypot(u[0] - l[0], u[1] - l[1], u[2] - l[2]) * (u[1] > l[1] ? 1 : -1));
    }
    const ContactStats st = contact_stats(b);
    std::printf("folded cable, self contact %d: facing nodes at least %.5f m apart (2r = %.4f m), %lld contacts, "
                "deepest overlap %.2e m\n", int(self), apart, 2 * r, static_cast<long long>(st.contacts), st.max_penetration);
    if (self) {
      EXPECT_GT(st.contacts, 0);
      EXPECT_LT(st.max_penetration, 0.01 * r);
      EXPECT_GT(apart, 2 * r - st.max_penetration - 1e-12);
    } else {
      EXPECT_LT(apart, 0);
    }
  };
  fold(true);
  fold(false);
}

namespace {

// A free steel wire (L = 1 m, r = 2 mm, 50 elements: stiff, so that pulled
// across at its middle it moves as a whole, where a soft cable folds into
// a V and trails its ends, sliding early along its axis; and pressed only
// nanometres into the floor by its weight, which the Jacobian's
// differences must resolve) lying along x on a floor
// with friction μ across and μa along it, pressed into it by a twentieth
// of the push law's width δ (so that friction holds it from the first
// increment: a node just touching, unpressed, holds nothing), in gravity −z,
// pulled by a node force F = pull × W along `direction` at node `node`
// (W: the cable's weight): whether the static solve finds it held.
struct FloorPull {
  StaticResult first, again;
  double weight;
};
FloorPull pull_on_a_floor(double mu, double axial, int node, Vec3 direction, double pull) {
  const int n = 50;
  const double r = 0.002, L = 1.0;
  RodSpec s = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, L, n);
  s.section = Section::circle(r);
  s.material = {7850, 2e11, 0.3};
  auto b = build_batch<double>({s}, {0, 0, -9.81});
  for (int j = 0; j <= n; ++j) b.state.node_x[2][b.node_index(0, j)] = r - 0.05 * 0.1 * r;
  ContactSpec spec;
  Collider floor;
  floor.kind = ColliderKind::plane;
  floor.friction.static_coefficient = floor.friction.kinetic_coefficient = mu;
  floor.friction.static_axial = floor.friction.kinetic_axial = axial;
  spec.colliders.push_back(floor);
  set_contact(b, spec);
  FloorPull out{};
  out.weight = 7850 * kPi * r * r * L * 9.81;
  b.set_node_force(0, node, {direction[0] * pull * out.weight, direction[1] * pull * out.weight, 0});
  out.first = solve_static<kNoKelvinVoigt>(b);
  if (out.first.converged) out.again = solve_static<kNoKelvinVoigt>(b);
  return out;
}

}  // namespace

TEST(Statics, FrictionOnAFloorHoldsACableUpToCoulombsLimitAlongAndAcrossIt) {
  // Independent reference: Coulomb's law for the whole cable. Pulled along
  // its axis at its tip, a cable on a floor with the axial coefficient μa
  // is held while the pull is at most μa W (every node slipping at the
  // limit carries μa times its share of the weight); pulled across at its
  // middle node, it translates (by symmetry) once the pull exceeds μ W.
  // The loads and gravity ramp together, so the pull's ratio to the
  // weight is the same all along the load path. 10 % either side of the
  // limit: far outside the law's discrete errors (the stick length ε =
  // r/100 lets a node creep before it slips; it shifts no limit). With
  // μ = 0 along the axis (frictionless that way) the cable slides off under
  // any axial pull. A second solve of the same state keeps the contact
  // points where the rods stuck (ContactData::static_anchors): it starts in
  // equilibrium (warm).
  const double mu = 0.5, axial = 0.2;
  for (const double f : {0.9, 1.1}) {
    const FloorPull along = pull_on_a_floor(mu, axial, 50, {1, 0, 0}, f * axial);
    const FloorPull across = pull_on_a_floor(mu, axial, 25, {0, 1, 0}, f * mu);
    std::printf("cable on a floor (W = %.4f N), pull %.1f x the limit: along %s (%d stick, %d slip), across %s (%d stick, "
                "%d slip)\n", along.weight, f, along.first.converged ? "held" : "slides", along.first.sticking,
                along.first.slipping, across.first.converged ? "held" : "slides", across.first.sticking, across.first.slipping);
    for (const FloorPull* p : {&along, &across}) {
      EXPECT_EQ(p->first.converged, f < 1) << f;
      if (!p->first.converged) continue;
      EXPECT_GT(p->first.sticking + p->first.slipping, 40);  // (the nodes on the floor: 51, less a slipping end's lift)
      EXPECT_TRUE(p->again.converged);
      EXPECT_EQ(p->again.warm_rods, 1);
    }
  }
  EXPECT_FALSE(pull_on_a_floor(mu, 0.0, 50, {1, 0, 0}, 0.01).first.converged);
}

TEST(Statics, ACableOverAFrictionalCapsuleHoldsTipLoadsUpToTheCapstanRatio) {
  // docs/validation.md 1k. Independent reference: the capstan (Euler–
  // Eytelwein) equation. A cable (r = 0.5 mm, E = 1 GPa) hangs over a
  // horizontal capsule (radius R = 5 cm, μ = 0.3) with loads T1 = 10 N and
  // T2 = f e^{μπ} T1 on its free tips: it is held for f ≤ 1 and slides
  // beyond. The threshold f* is found by bisection on f. Bounds: the
  // discrete wrap (nodes dθ = ℓ/R apart, each carrying μ times its push)
  // raises the ratio by e^{μπ dθ²(1+μ²)/12} (the product of the nodes'
  // (1 + μ tan(dθ/2))/(1 − μ tan(dθ/2))); the cable's bending stiffness makes
  // it leave the capsule a bending length λ = √(EI/T) early at each end,
  // losing at most μ(λ1 + λ2)/R of the exponent. Asserted: 1 − μ(λ1 + λ2)/R
  // − res ≤ f* ≤ 1 + μπ dθ²(1+μ²)/12 + res, res the bisection's last
  // bracket. Frictionless (μ = 0) any unequal loads slide: no equilibrium,
  // the solve says so.
  const double R = 0.05, r = 0.0005, leg = 0.1, E = 1e9, T1 = 10;
  const int n = 80;
  auto hang = [&](double mu, double f, std::vector<Vec3>* shape = nullptr) {
    // nodes on a circle whose chords touch the capsule pressed a twentieth
    // of δ, then two vertical legs
    double a = R + r;
    a = (R + r - 0.005 * r) / std::cos(0.5 * ((2 * leg + kPi * a) / n) / a);
    const double L = 2 * leg + kPi * a;
    std::vector<Vec3> x;
    for (int j = 0; j <= n; ++j) {
      const double s = L * j / n;
      if (s < leg) x.push_back({-a, 0, s - leg});
      else if (s < leg + kPi * a) x.push_back({-a * std::cos((s - leg) / a), 0, a * std::sin((s - leg) / a)});
      else x.push_back({a, 0, leg + kPi * a - s});
    }
    RodSpec s = RodSpec::polyline(x, RodSpec::parallel_transport_frames(x, {0, 1, 0}));
    s.section = Section::circle(r);
    s.material = {1400, E, 0.45};
    s.rest_curvature.assign(n - 1, {0, 0, 0});  // (straight at rest)
    auto b = build_batch<double>({s});
    ContactSpec spec;
    Collider pipe;
    pipe.kind = ColliderKind::capsule;
    pipe.a = {0, -0.5, 0};
    pipe.b = {0, 0.5, 0};
    pipe.radius = R;
    pipe.friction.static_coefficient = pipe.friction.kinetic_coefficient = mu;
    spec.colliders.push_back(pipe);
    set_contact(b, spec);
    b.set_node_force(0, 0, {0, 0, -T1});
    b.set_node_force(0, n, {0, 0, -f * std::exp(mu * kPi) * T1});
    const StaticResult out = solve_static<kNoGravity>(b);
    if (shape)
      for (int j = 0; j <= n; ++j) shape->push_back(b.position(0, j));
    return out;
  };
  const double mu = 0.3;
  double lo = 0.9, hi = 1.05;
  ASSERT_TRUE(hang(mu, lo).converged);
  ASSERT_FALSE(hang(mu, hi).converged);
  for (int i = 0; i < 7; ++i) {
    const double mid = 0.5 * (lo + hi);
    (hang(mu, mid).converged ? lo : hi) = mid;
  }
  const double I = kPi * r * r * r * r / 4, T2 = std::exp(mu * kPi) * T1;
  const double bending = mu * (std::sqrt(E * I / T1) + std::sqrt(E * I / T2)) / R;
  const double dtheta = (2 * leg + kPi * R) / n / R, discrete = mu * kPi * dtheta * dtheta * (1 + mu * mu) / 12;
  std::printf("capstan: held up to T2/T1 = %.4f..%.4f x e^(mu pi) (bending bound -%.4f, discrete +%.5f)\n", lo, hi,
              bending, discrete);
  EXPECT_GE(lo, 1 - bending - (hi - lo));
  EXPECT_LE(hi, 1 + discrete + (hi - lo));
  const StaticResult slick = hang(0.0, 1.05);
  EXPECT_FALSE(slick.converged);
  EXPECT_EQ(slick.failed_rod, 0);
  EXPECT_FALSE(hang(0.0, 1.001).converged);  // (a thousandth more on one side slides it too)
  // Frictionless with equal loads: an equilibrium, neutral along the
  // capsule and around it (Newton's matrix singular there: the solve ends
  // where the residual is round-off). It is the symmetric one — the tips
  // level, the apex on the capsule's top — to the round-off that the
  // neutral motions amplify (measured 4e-16 m; asserted 1e-9 L), and the
  // cable lies on the capsule: the chords beside the apex node pressed into
  // it by at most the law's δ = r/10 (the node a chord's half-angle above
  // them).
  std::vector<Vec3> x;
  const StaticResult even = hang(0.0, 1.0, &x);
  ASSERT_TRUE(even.converged);
  const double length = 2 * leg + kPi * (R + r);
  EXPECT_LE(std::abs(x[0][2] - x[n][2]), 1e-9 * length);
  EXPECT_LE(std::abs(x[n / 2][0]), 1e-9 * length);
  const double chord = std::cos(0.5 * length / n / (R + r));
  EXPECT_GE(x[n / 2][2] * chord, R + r - 0.1 * r);
  EXPECT_LE(x[n / 2][2] * chord, R + r);
}
