// docs/validation.md "1a Pure bending into a circle" and "1b Large-deflection
// cantilever (elastica)" — statics: pure bending into a circle and the
// large-deflection cantilever (1b), solved by Newton (host/core/analysis/statics.h).
#include <gtest/gtest.h>

#include <random>

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
