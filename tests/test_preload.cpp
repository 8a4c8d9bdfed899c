// docs/validation.md "1f Gravity preload" — the rest shape that makes a rod
// as built its own static equilibrium (include/manyrods/statics.h
// preload_rest_shape, host/core/analysis/preload.h).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "cases.h"
#include "host/core/advanced.h"

using namespace manyrods;
using namespace manyrods::cases;

namespace {

constexpr double kGravity = 9.81;  // m/s²

// The seed cantilever (along e3, d1 = e1) loaded across by gravity along −e2.
RodBatch<double> sideways_cantilever(int n, bool clamped_tip) {
  RodSpec s = seed_cantilever(n);
  s.clamped_tip = clamped_tip;
  s.preload = true;
  return build_batch<double>({s}, {0, -kGravity, 0});
}

std::vector<Vec3> positions(const RodBatch<double>& b, int rod) {
  std::vector<Vec3> x;
  for (int j = 0; j <= b.elements(rod); ++j) x.push_back(b.position(rod, j));
  return x;
}

Vec3 rest_curvature(const RodBatch<double>& b, int slot) {
  return {b.model.vor_rest_curvature[0][slot], b.model.vor_rest_curvature[1][slot], b.model.vor_rest_curvature[2][slot]};
}

}  // namespace

TEST(Preload, ACantileverGetsTheRestCurvatureOfItsBendingMoment) {
  // Independent reference: a straight cantilever with a free tip is
  // statically determinate: the bending moment at node j is the moment of
  // the weights beyond it, M_j = g Σ_{k>j} m_k (s_k − s_j) (its lumped node
  // masses, straight lever arms), and the shear force in element i the
  // weight beyond it. The preload's rest curvature is then −M_j/EI about d1
  // (curved up against gravity: U0·d1 > 0 would curl d3 towards −e2) and its
  // rest shear strain V0·d2 the weight beyond over κGA, to round-off (the
  // equations are linear in the rest shape; asserted at 1e-9 relative).
  const int n = 30;
  RodBatch<double> b = sideways_cantilever(n, false);
  const PreloadResult r = preload_rest_shape(b);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.rods, 1);
  const double dx = kL / n, kGA = b.model.elem_stiffness[1][b.elem_index(0, 0)];
  double worst_moment = 0, worst_shear = 0, largest = 0;
  for (int j = 0; j < n; ++j) {
    double M = 0, V = 0;
    for (int k = j + 1; k <= n; ++k) {
      const double m = b.model.node_mass[b.node_index(0, k)];
      M += kGravity * m * (k - j) * dx;
      V += kGravity * m;
    }
    // joint j sits at node j: the root joint's slot is the root ghost's + 1
    const Vec3 u0 = rest_curvature(b, b.node_index(0, j));
    worst_moment = std::max({worst_moment, std::abs(u0[0] + M / kEI), std::abs(u0[1]), std::abs(u0[2])});
    largest = std::max(largest, M / kEI);
    const int k = b.elem_index(0, j);
    // V0 = (0, 0, 1) as built; the internal force n = C_F(σ − V0) (what the
    // part beyond exerts on the part before) is −V e2: V0·d2 = V/κGA
    worst_shear = std::max({worst_shear, std::abs(b.model.elem_rest_strain[1][k] - V / kGA),
                            std::abs(b.model.elem_rest_strain[0][k]), std::abs(b.model.elem_rest_strain[2][k] - 1)});
  }
  std::printf("cantilever preload: |ΔU0 + M/EI| %.2e of %.3e 1/m, |ΔV0 − shear| %.2e\n", worst_moment, largest,
              worst_shear);
  EXPECT_LT(worst_moment, 1e-9 * largest);
  EXPECT_LT(worst_shear, 1e-9 * kGravity * kRho * kA * kA * kL / kGA);
  // and the rod as built is now in equilibrium: a static solve moves nothing
  const std::vector<Vec3> built = positions(b, 0);
  const StaticResult s = solve_static(b);
  ASSERT_TRUE(s.converged);
  EXPECT_EQ(s.warm_rods, 1);
  EXPECT_LT(max_distance(positions(b, 0), built), 1e-10 * kL);
}

TEST(Preload, AClampedClampedBeamCarriesTheBeamTheorysMoments) {
  // Independent reference: both ends clamped, the beam is indeterminate; the
  // preload takes the rest shape of least complementary energy, which by
  // Menabrea's theorem gives the moments of the linear beam built straight:
  // M(s) = q (6Ls − 6s² − L²)/12 (clamped–clamped Euler–Bernoulli). The
  // discrete rod differs at O(dx²) (lumped loads, the midpoint joints) and
  // by its shear compliance, O(EI/(κGA L²)) ≈ 4e-5 here. Asserted: the
  // largest error over the joints, relative to qL²/12, below
  // 2 (dx/L)² + 1e-4 at n = 40, and second order from n = 20 to 40.
  const double q = kRho * kA * kA * kGravity;
  auto error = [&](int n) {
    RodBatch<double> b = sideways_cantilever(n, true);
    const PreloadResult r = preload_rest_shape(b);
    EXPECT_TRUE(r.ok) << n;
    double worst = 0;
    for (int j = 0; j <= n; ++j) {
      const double s = j * kL / n;
      const double M = q * (6 * kL * s - 6 * s * s - kL * kL) / 12;
      // joints 0 … n: the root joint, the interior ones, the tip joint (slot of node j)
      const Vec3 u0 = rest_curvature(b, b.node_index(0, j));
      worst = std::max(worst, std::abs(u0[0] * kEI - M));  // (M sagging positive: U0·d1 > 0 curls the rod down)
    }
    return worst / (q * kL * kL / 12);
  };
  const double e20 = error(20), e40 = error(40);
  std::printf("clamped-clamped preload: moment error %.3e (n = 20), %.3e (n = 40), order %.2f\n", e20, e40,
              std::log2(e20 / e40));
  EXPECT_LT(e40, 2.0 / (40 * 40) + 1e-4);
  EXPECT_GT(std::log2(e20 / e40), 1.7);
}

TEST(Preload, ACableLyingOnAFloorNeedsNone) {
  // A cable built lying on a floor (its centreline one radius above it),
  // clamped at one end: the floor can carry every node's weight, and the
  // preload lets it (contact forces cost no energy), so the rest shape
  // stays the straight one, to round-off — and the touches carry the weight.
  RodSpec s = RodSpec::straight({0, 0, 0.01}, {1, 0, 0}, {0, 0, 1}, 1.0, 20);
  s.section = Section::circle(0.01);
  s.material = {1400, 5e7, 0.45};
  s.clamped_root = true;
  s.preload = true;
  RodBatch<double> b = build_batch<double>({s}, {0, 0, -kGravity});
  ContactSpec cs;
  Collider floor;
  floor.kind = ColliderKind::plane;
  floor.point = {0, 0, 0};
  floor.normal = {0, 0, 1};
  cs.colliders.push_back(floor);
  set_contact(b, cs);
  const PreloadResult r = preload_rest_shape(b);
  ASSERT_TRUE(r.ok) << r.residual_force << " N at node " << r.failed_node << ", " << r.residual_couple << " N m";
  EXPECT_GE(r.contacts, 20);
  double worst = 0;
  for (int j = 0; j < 20; ++j) {
    const Vec3 u0 = rest_curvature(b, b.node_index(0, j));
    worst = std::max({worst, std::abs(u0[0]), std::abs(u0[1]), std::abs(u0[2])});
  }
  EXPECT_LT(worst, 1e-9);  // 1/m, against a cantilever's 8 1/m without the floor
}

TEST(Preload, AFreeRodInGravityHasNoneAndIsLeftAsItWas) {
  RodSpec s = seed_cantilever(10);
  s.clamped_root = false;
  s.preload = true;
  RodBatch<double> b = build_batch<double>({s}, {0, -kGravity, 0});
  const RodBatch<double> before = b;
  const PreloadResult r = preload_rest_shape(b);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.failed_rod, 0);
  EXPECT_GT(r.residual_force, 0);
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < b.slots(); ++k) {
      EXPECT_EQ(b.model.vor_rest_curvature[a][k], before.model.vor_rest_curvature[a][k]);
      EXPECT_EQ(b.model.elem_rest_strain[a][k], before.model.elem_rest_strain[a][k]);
    }
}

TEST(Preload, APreloadedCurlyHairStaysWhereItWasBuiltAndOneWithoutSags) {
  // Dynamics: a stiff, damped human hair 10 cm long built in a curl (rest
  // curvature (15, 0, 5) 1/m), its root clamped pointing down, stepped
  // for 1 s at 1/240 s under gravity. Preloaded, it starts in equilibrium,
  // and what moves it is the step's round-off: asserted below 1e-3 L (the
  // groom's requirement; measured ~2e-14 L). Not preloaded, it sags: by
  // more than 0.05 L (measured in the printout) — what the preload takes
  // away. (A 20 cm hair in the same curl is beyond its buckling load under
  // its own weight, ρAgL³/EI = 65: preloaded, it is in equilibrium but an
  // unstable one, and it falls away from it; docs/model.md "Gravity
  // preload".)
  auto drift = [](bool preload) {
    // built in its curl: frames turned by the rest curvature from joint to
    // joint, Q_{e+1} = exp(−D̂[κ]×) Q_e (the discrete curvature of the
    // batch's joints), nodes along d3
    const double length = 0.1, dx = length / 32;
    RodSpec s = hair(32, true, Damping::shear_extension(1e-3, 1e-3));
    const RodSpec down = RodSpec::straight({0, 0, 0}, {0, 0, -1}, {1, 0, 0}, length, 32);
    s.nodes = down.nodes;
    mat3<double> q;
    for (int i = 0; i < 9; ++i) q.m[i] = down.frames[0][std::size_t(i)];
    for (int e = 0; e < 32; ++e) {
      for (int i = 0; i < 9; ++i) s.frames[std::size_t(e)][std::size_t(i)] = q.m[i];
      for (int a = 0; a < 3; ++a) s.nodes[std::size_t(e + 1)][std::size_t(a)] = s.nodes[std::size_t(e)][std::size_t(a)] + dx * q.m[6 + a];
      q = mul(rotation_exp(vec3<double>{-15 * dx, 0, -5 * dx}), q);
    }
    s.preload = preload;
    RodBatch<double> b = build_batch<double>({s}, {0, 0, -kGravity});
    if (preload) {
      EXPECT_TRUE(preload_rest_shape(b).ok);
    }
    const std::vector<Vec3> built = positions(b, 0);
    advance(b, 1.0 / 240, 240);
    return max_distance(positions(b, 0), built) / length;
  };
  const double with = drift(true), without = drift(false);
  std::printf("curly hair over 1 s: drift %.3e L preloaded, %.3e L not\n", with, without);
  EXPECT_LT(with, 1e-3);
  EXPECT_GT(without, 0.05);
}
