// tests/test_parameters.cpp — docs/validation.md "3e Parameter forms" and
// "0b Cross-section properties and the batch model": Kelvin–Voigt parameter
// forms, the cross-section properties of every shape, and the per-slot model
// arrays that build_batch derives from them (docs/model.md "Retardation times
// and the three parameter forms", "Cross sections").
//
// Tolerances. u = 2^-53 is the unit round-off of double. A quantity computed
// with m roundings from exact inputs, with no cancellation, has a relative
// error of at most about m·u; two such computations of the same quantity
// along different paths differ by at most (m1 + m2)·u. Each assertion states
// the operation count it allows for. Where a form subtracts nearly equal
// terms (τB from (τS, τE) as ν → ½) the bound is scaled by the condition
// number of that subtraction, derived at the assertion.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "cases.h"
#include "host/core/advanced.h"

using namespace manyrods;

namespace {

constexpr double kU = std::numeric_limits<double>::epsilon() / 2;  // unit round-off
constexpr double kPi = std::numbers::pi;

// |got − want| ≤ k·u·|scale| (scale defaults to |want|).
::testing::AssertionResult near_ulps(double got, double want, double k, double scale = -1) {
  if (scale < 0) scale = std::abs(want);
  const double err = std::abs(got - want), tol = k * kU * scale;
  if (err <= tol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "got " << got << ", want " << want << ": |err| = " << err
                                       << " > " << k << "·u·" << scale << " = " << tol;
}

Material material(double E, double nu, double rho = 1000) {
  Material m;
  m.density = rho;
  m.youngs_modulus = E;
  m.poisson_ratio = nu;
  return m;
}

// The retardation times computed here from (η, ζ), independently
// of host/core/model/material.cpp: G = E/(2(1+ν)), K = E/(3(1−2ν)), τS = η/G, τB = ζ/K,
// τE = [(1−2ν)τB + 2(1+ν)τS]/3. At ν = ½, K = ∞ and τB = ζ/∞ = 0 (IEEE).
struct Taus {
  double shear, bulk, extension;
};
Taus taus_from_viscosities(double eta, double zeta, double E, double nu) {
  const double G = E / (2 * (1 + nu));
  const double K = E / (3 * (1 - 2 * nu));
  Taus t;
  t.shear = eta / G;
  t.bulk = zeta / K;
  t.extension = ((1 - 2 * nu) * t.bulk + 2 * (1 + nu) * t.shear) / 3;
  return t;
}

const std::vector<double> kNus = {0.0, 0.3, 0.45, 0.499};

}  // namespace

// ---------------------------------------------------------------------------
// 3e: the three parameter forms give the same retardation times.
// ---------------------------------------------------------------------------

TEST(ParameterForms, ThreeFormsAgreeForEveryPoissonRatio) {
  const double E = 2.5e6, eta = 3.7e3, zeta = 1.9e4;  // Pa, Pa·s, Pa·s
  for (double nu : kNus) {
    SCOPED_TRACE("nu = " + std::to_string(nu));
    const ElasticConstants c = resolve_material(material(E, nu));
    const Taus want = taus_from_viscosities(eta, zeta, E, nu);

    const RetardationTimes from_visc = resolve_damping(Damping::viscosities(eta, zeta), c);
    const RetardationTimes from_sb = resolve_damping(Damping::shear_bulk(want.shear, want.bulk), c);
    const RetardationTimes from_se = resolve_damping(Damping::shear_extension(want.shear, want.extension), c);

    // (η, ζ): τS = η/G takes 4 roundings on either side (G: 3, division: 1),
    // τB = ζ/K 4 each; sum 8 → 16 allowed. τE adds a sum of two positive
    // products and a division (≈ 5 more per side, no cancellation) → 32.
    EXPECT_TRUE(near_ulps(from_visc.shear, want.shear, 16));
    EXPECT_TRUE(near_ulps(from_visc.bulk, want.bulk, 16));
    EXPECT_TRUE(near_ulps(from_visc.extension, want.extension, 32));

    // (τS, τB): τS and τB are passed through (exact); τE is the same
    // expression on the same inputs (≤ 6 roundings each side) → 12.
    EXPECT_EQ(from_sb.shear, want.shear);
    EXPECT_EQ(from_sb.bulk, want.bulk);
    EXPECT_TRUE(near_ulps(from_sb.extension, want.extension, 12));

    // (τS, τE): τS and τE pass through exactly. τB = (3τE − 2(1+ν)τS)/(1−2ν)
    // subtracts two terms of size s = 3τE + 2(1+ν)τS: an error of m·u·s in
    // either term (τE itself carries ≈ 10 roundings from the test, the
    // library's products 3 more) becomes m·u·s/(1−2ν) in τB. With m = 16:
    // at ν = 0.499 that is ≈ 16·u·s/0.002, far above 16·u·τB — cancellation,
    // not a defect.
    EXPECT_EQ(from_se.shear, want.shear);
    EXPECT_EQ(from_se.extension, want.extension);
    const double s = 3 * want.extension + 2 * (1 + nu) * want.shear;
    EXPECT_TRUE(near_ulps(from_se.bulk, want.bulk, 16, s / (1 - 2 * nu)));

    // Extensional viscosity η_E = E τE = ζ(1−2ν)² + (4/3)η(1+ν)² (seed eq. 5):
    // both sides ≈ 40 roundings of positive terms → 64.
    const double eta_E = zeta * (1 - 2 * nu) * (1 - 2 * nu) + 4.0 / 3.0 * eta * (1 + nu) * (1 + nu);
    EXPECT_TRUE(near_ulps(from_visc.extensional_viscosity(c), eta_E, 64));
  }
}

// Giving the shear modulus instead of ν resolves to the same material and so
// to the same damping.
TEST(ParameterForms, ShearModulusAndPoissonRatioAgree) {
  const double E = 2.5e6;
  for (double nu : kNus) {
    Material m;
    m.density = 1000;
    m.youngs_modulus = E;
    m.shear_modulus = E / (2 * (1 + nu));
    const ElasticConstants c = resolve_material(m), c_nu = resolve_material(material(E, nu));
    // ν = E/(2G) − 1: G carries 3 roundings, E/(2G) one more, the
    // subtraction one; the error relative to the terms E/(2G) ≈ 1+ν is
    // ≈ 5u·(1+ν), absolute (ν may be 0) → 8·u·(1+ν).
    EXPECT_TRUE(near_ulps(c.nu, nu, 8, 1 + nu)) << "nu = " << nu;
    EXPECT_EQ(c.G, c_nu.G);
  }
}

// The model depends on the damping only through τS and τE (elem_tau =
// (τS, τS, τE), vor_tau = (τE, τE, τS)). Rods built with each form carry the
// same arrays.
TEST(ParameterForms, RodsBuiltWithEachFormHaveTheSameModelArrays) {
  const double E = cases::kE, eta = 4.1e3, zeta = 2.3e4;
  for (double nu : kNus) {
    SCOPED_TRACE("nu = " + std::to_string(nu));
    const Taus want = taus_from_viscosities(eta, zeta, E, nu);
    std::vector<RodSpec> rods;
    for (const Damping& d : {Damping::viscosities(eta, zeta), Damping::shear_bulk(want.shear, want.bulk),
                             Damping::shear_extension(want.shear, want.extension)}) {
      RodSpec s = cases::seed_cantilever(6, d);
      s.material.poisson_ratio = nu;
      rods.push_back(s);
    }
    const RodBatch<double> b = build_batch<double>(rods);
    const auto& m = b.model;
    for (int r = 0; r < 3; ++r) {
      for (int e = 0; e < 6; ++e) {
        const int k = b.elem_index(r, e);
        // (τS, τE) passes both through; the other forms are within the
        // bounds of ThreeFormsAgreeForEveryPoissonRatio (16 and 32 ulps).
        EXPECT_TRUE(near_ulps(m.elem_tau[0][k], want.shear, 16)) << "rod " << r << " element " << e;
        EXPECT_TRUE(near_ulps(m.elem_tau[1][k], want.shear, 16)) << "rod " << r << " element " << e;
        EXPECT_TRUE(near_ulps(m.elem_tau[2][k], want.extension, 32)) << "rod " << r << " element " << e;
      }
      for (int j = -1; j < 5; ++j) {  // -1: the root Voronoi point of the clamp
        const int k = j < 0 ? b.root_vor_index(r) : b.vor_index(r, j);
        EXPECT_TRUE(near_ulps(m.vor_tau[0][k], want.extension, 32)) << "rod " << r << " voronoi " << j;
        EXPECT_TRUE(near_ulps(m.vor_tau[1][k], want.extension, 32)) << "rod " << r << " voronoi " << j;
        EXPECT_TRUE(near_ulps(m.vor_tau[2][k], want.shear, 16)) << "rod " << r << " voronoi " << j;
      }
    }
    // Everything but the damping is bit-identical between the three rods.
    for (int r = 1; r < 3; ++r)
      for (int e = 0; e < 6; ++e)
        for (int d = 0; d < 3; ++d) {
          EXPECT_EQ(m.elem_stiffness[d][b.elem_index(r, e)], m.elem_stiffness[d][b.elem_index(0, e)]);
          EXPECT_EQ(m.elem_inertia[d][b.elem_index(r, e)], m.elem_inertia[d][b.elem_index(0, e)]);
        }
    // The (τS, τE) rod carries exactly the given times.
    for (int e = 0; e < 6; ++e) {
      EXPECT_EQ(m.elem_tau[0][b.elem_index(2, e)], want.shear);
      EXPECT_EQ(m.elem_tau[2][b.elem_index(2, e)], want.extension);
    }
  }
}

// ---------------------------------------------------------------------------
// 3e pinned special cases.
// ---------------------------------------------------------------------------

// ν = ½: E = 3G, τE = τS, and η_E = E τE = 3η (Trouton).
TEST(ParameterForms, IncompressibleTrouton) {
  const double E = 3.3e6, eta = 5.0e3, zeta = 7.0e3;
  const ElasticConstants c = resolve_material(material(E, 0.5));
  // G = E/(2·1.5) = E/3: 1 rounding each way.
  EXPECT_TRUE(near_ulps(3 * c.G, E, 2));

  const RetardationTimes t = resolve_damping(Damping::viscosities(eta, zeta), c);
  EXPECT_EQ(t.bulk, 0.0);  // K = ∞: ζ/K = 0
  // τE = (0 + 3τS)/3: 2 roundings.
  EXPECT_TRUE(near_ulps(t.extension, t.shear, 2));
  // η_E = E·τE = E·(η/G)·(1 ± 2u) with G = E/3·(1 ± u): ≈ 5 roundings → 8.
  EXPECT_TRUE(near_ulps(t.extensional_viscosity(c), 3 * eta, 8));

  const RetardationTimes sb = resolve_damping(Damping::shear_bulk(0.02, 0.5), c);
  EXPECT_TRUE(near_ulps(sb.extension, 0.02, 2));  // τB has no weight at ν = ½

  // (τS, τE) at ν = ½: τE must equal τS; τB is undetermined (NaN).
  const RetardationTimes se = resolve_damping(Damping::shear_extension(0.02, 0.02), c);
  EXPECT_EQ(se.extension, 0.02);
  EXPECT_TRUE(std::isnan(se.bulk));
  try {
    resolve_damping(Damping::shear_extension(0.02, 0.03), c);
    ADD_FAILURE() << "tau_E != tau_S at nu = 1/2 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("damping.tau_extension"), std::string::npos) << e.what();
  }
}

// ν = 0 ⇒ τE = (τB + 2τS)/3.
TEST(ParameterForms, ZeroPoissonRatio) {
  const ElasticConstants c = resolve_material(material(1e6, 0.0));
  const double tS = 0.013, tB = 0.071;
  const RetardationTimes t = resolve_damping(Damping::shear_bulk(tS, tB), c);
  // Library: (1·τB + 2·τS)/3 (3 roundings); here 2 → 5, allow 6.
  EXPECT_TRUE(near_ulps(t.extension, (tB + 2 * tS) / 3, 6));
  const RetardationTimes back = resolve_damping(Damping::shear_extension(tS, (tB + 2 * tS) / 3), c);
  // τB = 3τE − 2τS: cancellation bounded as in ThreeFormsAgree, s = 3τE + 2τS.
  EXPECT_TRUE(near_ulps(back.bulk, tB, 16, tB + 4 * tS));
}

// τB = τS ⇒ τE = τS for every ν (and (τS, τE = τS) ⇒ τB = τS where defined).
TEST(ParameterForms, EqualShearAndBulkTimesGiveEqualExtensionTime) {
  const double tau = 0.037;
  for (double nu : {-0.9, -0.5, 0.0, 0.1, 0.3, 0.45, 0.499, 0.5}) {
    const ElasticConstants c = resolve_material(material(1e6, nu));
    const RetardationTimes t = resolve_damping(Damping::shear_bulk(tau, tau), c);
    // [(1−2ν)τ + 2(1+ν)τ]/3: both terms are ≥ 0 for ν ∈ (−1, ½] (no
    // cancellation) and sum to 3τ; ≈ 6 roundings in all → allow 8.
    EXPECT_TRUE(near_ulps(t.extension, tau, 8)) << "nu = " << nu;
    if (nu < 0.5) {
      const RetardationTimes back = resolve_damping(Damping::shear_extension(tau, tau), c);
      // τB = (3τ − 2(1+ν)τ)/(1−2ν): cancellation, s = 3τ + 2(1+ν)τ.
      EXPECT_TRUE(near_ulps(back.bulk, tau, 16, (3 + 2 * (1 + nu)) * tau / (1 - 2 * nu))) << "nu = " << nu;
    }
  }
}

// A (τS, τE) pair with τE < 2(1+ν)τS/3 implies τB < 0 and is rejected; the
// boundary τE = 2(1+ν)τS/3 (τB = 0) is accepted.
TEST(ParameterForms, NegativeBulkViscosityIsRejected) {
  const double nu = 0.3, tS = 0.1, tE_min = 2 * (1 + nu) * tS / 3;  // 0.08667
  const ElasticConstants c = resolve_material(material(1e6, nu));
  const RetardationTimes at_min = resolve_damping(Damping::shear_extension(tS, tE_min), c);
  // τB = (3τE − 2(1+ν)τS)/(1−2ν) ≈ 0 up to the cancellation bound.
  EXPECT_TRUE(near_ulps(at_min.bulk, 0.0, 16, 2 * 3 * tE_min / (1 - 2 * nu)));
  EXPECT_GE(at_min.bulk, 0.0);

  for (double tE : {0.05, 0.0, 0.9 * tE_min}) {
    SCOPED_TRACE("tau_E = " + std::to_string(tE));
    try {
      resolve_damping(Damping::shear_extension(tS, tE), c);
      ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
      const std::string w = e.what();
      EXPECT_NE(w.find("negative bulk"), std::string::npos) << w;
      EXPECT_NE(w.find("tau_extension"), std::string::npos) << w;
    }
  }

  // In a batch: the message also names the rod (index and name).
  std::vector<RodSpec> rods = {cases::seed_cantilever(4, Damping::shear_extension(tS, 0.2)),
                               cases::seed_cantilever(4, Damping::shear_extension(tS, 0.05))};
  rods[1].name = "jacket";
  try {
    build_batch<double>(rods);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("rod 1 ('jacket')"), std::string::npos) << w;
    EXPECT_NE(w.find("damping.tau_extension"), std::string::npos) << w;
    EXPECT_NE(w.find("negative bulk"), std::string::npos) << w;
  }
}

// ---------------------------------------------------------------------------
// Section properties.
// ---------------------------------------------------------------------------

// Relative-error helper for closed forms: `ops` roundings on each side.
#define EXPECT_CLOSED(got, want, ops) EXPECT_TRUE(near_ulps((got), (want), 2 * (ops)))

TEST(Sections, Circle) {
  for (double nu : {-0.5, 0.0, 0.3, 0.5}) {
    const double r = 0.0123;
    const SectionProperties p = section_properties(Section::circle(r), nu);
    // ≤ 6 roundings per side for every closed form below.
    EXPECT_CLOSED(p.area, kPi * r * r, 3);
    EXPECT_CLOSED(p.I1, kPi * std::pow(r, 4) / 4, 6);
    EXPECT_CLOSED(p.I2, kPi * std::pow(r, 4) / 4, 6);
    EXPECT_CLOSED(p.torsion_constant, kPi * std::pow(r, 4) / 2, 6);
    EXPECT_CLOSED(p.I3, kPi * std::pow(r, 4) / 2, 7);
    EXPECT_CLOSED(p.shear_factor1, 6 * (1 + nu) / (7 + 6 * nu), 5);  // Cowper (1966)
    EXPECT_EQ(p.shear_factor1, p.shear_factor2);
  }
}

TEST(Sections, Ellipse) {
  const double a = 0.03, b = 0.01;  // a along d1, b along d2
  const SectionProperties p = section_properties(Section::ellipse(a, b), 0.3);
  EXPECT_CLOSED(p.area, kPi * a * b, 3);
  EXPECT_CLOSED(p.I1, kPi * a * b * b * b / 4, 6);  // ∫ξ2² dA: bending about d1
  EXPECT_CLOSED(p.I2, kPi * a * a * a * b / 4, 6);  // ∫ξ1² dA: bending about d2
  EXPECT_CLOSED(p.torsion_constant, kPi * a * a * a * b * b * b / (a * a + b * b), 10);
  EXPECT_LT(p.I1, p.I2);  // the section is flat in d2: stiffer about d2
  EXPECT_LE(p.torsion_constant, p.I3);

  // a = b reduces to the circle (κ: Cowper's ellipse formula at a = b is
  // 48(1+ν)/(56+48ν), ≈ 15 roundings vs 5 → 20 per side).
  for (double nu : {-0.5, 0.0, 0.3, 0.5}) {
    const double r = 0.02;
    const SectionProperties e = section_properties(Section::ellipse(r, r), nu),
                            c = section_properties(Section::circle(r), nu);
    EXPECT_CLOSED(e.area, c.area, 3);
    EXPECT_CLOSED(e.I1, c.I1, 6);
    EXPECT_CLOSED(e.I2, c.I2, 6);
    EXPECT_CLOSED(e.torsion_constant, c.torsion_constant, 10);
    EXPECT_CLOSED(e.shear_factor1, c.shear_factor1, 20);
    EXPECT_CLOSED(e.shear_factor2, c.shear_factor2, 20);
  }
}

TEST(Sections, Rectangle) {
  const double w = 0.04, h = 0.01;  // w along d1, h along d2
  const SectionProperties p = section_properties(Section::rectangle(w, h), 0.3);
  EXPECT_CLOSED(p.area, w * h, 1);
  EXPECT_CLOSED(p.I1, w * h * h * h / 12, 5);
  EXPECT_CLOSED(p.I2, h * w * w * w / 12, 5);
  EXPECT_CLOSED(p.shear_factor1, 10 * (1 + 0.3) / (12 + 11 * 0.3), 5);  // Cowper (1966)

  // Square: J_T = 0.140577 a⁴ (the seed cantilever's section), quoted to 6 digits →
  // |error| ≤ 0.5e-6·a⁴.
  const double s = 0.01;
  const SectionProperties q = section_properties(Section::rectangle(s, s), 0.3);
  EXPECT_NEAR(q.torsion_constant / std::pow(s, 4), 0.140577, 0.5e-6);

  // J_T = β·long·short³ against the classic table (Timoshenko & Goodier,
  // Theory of Elasticity, §109), quoted to 3 digits → |Δβ| ≤ 5e-4.
  const std::vector<std::pair<double, double>> table = {{1.5, 0.196}, {2, 0.229}, {2.5, 0.249}, {3, 0.263},
                                                        {4, 0.281},   {5, 0.291}, {10, 0.312}};
  for (auto [ratio, beta] : table) {
    for (bool wide : {true, false}) {  // the long side along d1, then along d2
      const double ww = wide ? ratio * s : s, hh = wide ? s : ratio * s;
      const SectionProperties r = section_properties(Section::rectangle(ww, hh), 0.3);
      EXPECT_NEAR(r.torsion_constant / (ratio * std::pow(s, 4)), beta, 5e-4) << "ratio " << ratio;
    }
  }

  // Very thin strip: J_T = w h³/3 (1 − c h/w + O(e^{−πw/h})) with c =
  // (192/π⁵)·Σ_{odd n} n⁻⁵ = 0.630247…; the usual c = 0.630 differs by
  // 2.5e-4, i.e. a relative difference ≤ 2.5e-4·(h/w)/(1 − 0.63 h/w); the
  // exponential remainder at w/h ≥ 20 is below e^{−60}. Allow 3e-4·h/w.
  for (double ratio : {20.0, 50.0, 200.0}) {
    const double ww = ratio * s, hh = s;
    const SectionProperties r = section_properties(Section::rectangle(ww, hh), 0.3);
    const double approx = ww * hh * hh * hh / 3 * (1 - 0.630 / ratio);
    EXPECT_NEAR(r.torsion_constant / approx, 1.0, 3e-4 / ratio) << "ratio " << ratio;
  }
}

TEST(Sections, HollowCircle) {
  const double ro = 0.02, ri = 0.015;
  for (double nu : {-0.5, 0.0, 0.3, 0.5}) {
    const SectionProperties p = section_properties(Section::hollow_circle(ro, ri), nu);
    EXPECT_CLOSED(p.area, kPi * (ro * ro - ri * ri), 4);
    const double I = kPi * (std::pow(ro, 4) - std::pow(ri, 4)) / 4;
    // ro⁴ − ri⁴ cancels: relative error ≈ 6u·(ro⁴ + ri⁴)/(ro⁴ − ri⁴) ≈ 13u; → 40.
    EXPECT_CLOSED(p.I1, I, 20);
    EXPECT_CLOSED(p.I2, I, 20);
    EXPECT_CLOSED(p.torsion_constant, 2 * I, 20);
    EXPECT_LE(p.shear_factor1, 1.0);
    EXPECT_GT(p.shear_factor1, 0.0);
    EXPECT_LT(p.shear_factor1, section_properties(Section::circle(ro), nu).shear_factor1);  // thin wall shears more

    // ri = 0 reduces to the solid circle (m = 0: identical expressions but for
    // the ordering of products, ≤ 6 roundings per side).
    const SectionProperties h0 = section_properties(Section::hollow_circle(ro, 0), nu),
                            c = section_properties(Section::circle(ro), nu);
    EXPECT_CLOSED(h0.area, c.area, 4);
    EXPECT_CLOSED(h0.I1, c.I1, 6);
    EXPECT_CLOSED(h0.torsion_constant, c.torsion_constant, 6);
    EXPECT_CLOSED(h0.shear_factor1, c.shear_factor1, 6);
    EXPECT_CLOSED(h0.shear_factor2, c.shear_factor2, 6);
  }
}

// κ ∈ (0, 1], J_T ≤ I3 and Nikolai's bound J_T ≤ 4 I1 I2/(I1 + I2) (equality
// for the ellipse and for the circle and annulus) over aspect ratios and ν ≥ 0.
// The equality cases carry ≈ 10 roundings per side → slack 20u relative.
TEST(Sections, InequalitiesOverAspectRatios) {
  const double slack = 1 + 20 * kU;
  std::vector<double> ratios;
  for (double q = 0.02; q <= 50.0; q *= 1.25) ratios.push_back(q);
  for (double nu : {0.0, 0.2, 0.3, 0.45, 0.5}) {
    for (double q : ratios) {
      const double base = 0.01;
      std::vector<std::pair<std::string, Section>> shapes = {
          {"circle", Section::circle(base)},
          {"ellipse", Section::ellipse(q * base, base)},
          {"rectangle", Section::rectangle(q * base, base)},
      };
      if (q < 1) shapes.push_back({"hollow", Section::hollow_circle(base, q * base)});
      for (const auto& [name, sec] : shapes) {
        SCOPED_TRACE(name + " q = " + std::to_string(q) + " nu = " + std::to_string(nu));
        const SectionProperties p = section_properties(sec, nu);
        EXPECT_GT(p.shear_factor1, 0.0);
        EXPECT_LE(p.shear_factor1, 1.0);
        EXPECT_GT(p.shear_factor2, 0.0);
        EXPECT_LE(p.shear_factor2, 1.0);
        EXPECT_GT(p.torsion_constant, 0.0);
        EXPECT_LE(p.torsion_constant, p.I3 * slack);
        EXPECT_LE(p.torsion_constant, 4 * p.I1 * p.I2 / (p.I1 + p.I2) * slack);
        EXPECT_TRUE(near_ulps(p.I3, p.I1 + p.I2, 1));
      }
    }
  }
}

// Cowper's ellipse formula κ = 12(1+ν)a²(3a²+b²)/((40+37ν)a⁴ + (16+10ν)a²b² + νb⁴)
// changes sign in its denominator for flat ellipses when ν < 0; the library
// rejects such input rather than build a rod with negative shear stiffness.
// Ellipses of auxetic material that keep 0 < κ ≤ 1 are accepted.
TEST(Sections, AuxeticFlatEllipseIsRejected) {
  for (double q : {0.1, 0.2, 5.0, 10.0}) {
    try {
      section_properties(Section::ellipse(q * 0.01, 0.01), -0.5);
      ADD_FAILURE() << "accepted q = " << q;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("shear"), std::string::npos) << e.what();
    }
  }
  for (double q : {0.5, 1.0, 2.0}) {
    const SectionProperties p = section_properties(Section::ellipse(q * 0.01, 0.01), -0.5);
    EXPECT_GT(p.shear_factor1, 0.0);
    EXPECT_LE(p.shear_factor1, 1.0);
    EXPECT_GT(p.shear_factor2, 0.0);
    EXPECT_LE(p.shear_factor2, 1.0);
  }
}

// Independent check of which axis is which: I1 = ∫ξ2² dA and I2 = ∫ξ1² dA by
// quadrature over the section, with ξ1 along d1 (first constructor argument).
//
// Rectangle [−w/2, w/2] × [−h/2, h/2]: tensor grid of 2-point Gauss–Legendre
// cells, exact for the quadratic integrands, so only round-off remains
// (N² terms summed: ≈ N²·u relative worst case, N = 64 → 4096 u; the
// observed error is far smaller, but the bound is what we assert).
// Ellipse: ξ1 = a ρ cos φ, ξ2 = b ρ sin φ, dA = a b ρ dρ dφ; the trapezoid rule
// in φ with M ≥ 3 points is exact for cos²φ, sin²φ, and 2-point Gauss in ρ is
// exact for ρ³: again round-off only (M = 64 terms → 64·4 u, allow 512 u).
TEST(Sections, SecondMomentsByQuadrature) {
  const double g = 1 / std::sqrt(3.0);  // Gauss–Legendre nodes ±g on [−1, 1]
  {
    const double w = 0.05, h = 0.013;
    const int N = 64;
    double i1 = 0, i2 = 0, area = 0;
    for (int ix = 0; ix < N; ++ix)
      for (int iy = 0; iy < N; ++iy)
        for (double gx : {-g, g})
          for (double gy : {-g, g}) {
            const double x1 = -w / 2 + (ix + 0.5 + gx / 2) * w / N;  // ξ1
            const double x2 = -h / 2 + (iy + 0.5 + gy / 2) * h / N;  // ξ2
            const double dA = (w / N) * (h / N) / 4;
            i1 += x2 * x2 * dA;
            i2 += x1 * x1 * dA;
            area += dA;
          }
    const SectionProperties p = section_properties(Section::rectangle(w, h), 0.3);
    EXPECT_TRUE(near_ulps(p.area, area, 4.0 * N * N));
    EXPECT_TRUE(near_ulps(p.I1, i1, 4.0 * N * N));
    EXPECT_TRUE(near_ulps(p.I2, i2, 4.0 * N * N));
  }
  {
    const double a = 0.031, b = 0.012;
    const int M = 64;
    double i1 = 0, i2 = 0, area = 0;
    for (int k = 0; k < M; ++k) {
      const double phi = 2 * kPi * k / M;
      for (double gr : {-g, g}) {
        const double rho = 0.5 + gr / 2;
        const double x1 = a * rho * std::cos(phi), x2 = b * rho * std::sin(phi);
        const double dA = a * b * rho * 0.5 * (2 * kPi / M);  // weight 1/2 per Gauss node on [0,1]
        i1 += x2 * x2 * dA;
        i2 += x1 * x1 * dA;
        area += dA;
      }
    }
    const SectionProperties p = section_properties(Section::ellipse(a, b), 0.3);
    EXPECT_TRUE(near_ulps(p.area, area, 512));
    EXPECT_TRUE(near_ulps(p.I1, i1, 512));
    EXPECT_TRUE(near_ulps(p.I2, i2, 512));
  }
}

// ---------------------------------------------------------------------------
// The batch model of the seed cantilever.
// ---------------------------------------------------------------------------

TEST(BatchModel, SeedCantilever) {
  const int n = 10;
  const double a = cases::kA, L = cases::kL, rho = cases::kRho, E = cases::kE, nu = cases::kNu;
  const double A = a * a, I = a * a * a * a / 12, I3 = a * a * a * a / 6, G = E / (2 * (1 + nu));
  const double kappa = 10 * (1 + nu) / (12 + 11 * nu);  // Cowper, rectangle
  const double JT = section_properties(Section::rectangle(a, a), nu).torsion_constant;
  EXPECT_NEAR(JT / (a * a * a * a), 0.140577, 0.5e-6);  // 0a

  RodSpec free_rod = cases::seed_cantilever(n);
  free_rod.name = "free";
  free_rod.clamped_root = false;
  RodSpec stiff = cases::seed_cantilever(n);
  stiff.name = "stiff";
  stiff.shear_stretch_scale = 1e4;
  const RodBatch<double> b = build_batch<double>({cases::seed_cantilever(n), free_rod, stiff});
  const auto& m = b.model;

  // All values below are ≤ 8 roundings from the inputs on either side → 16.
  double mass = 0;
  for (int j = 0; j <= n; ++j) mass += m.node_mass[b.node_index(0, j)];
  // + n additions of positive terms.
  EXPECT_TRUE(near_ulps(mass, rho * A * L, 16 + n));

  for (int e = 0; e < n; ++e) {
    SCOPED_TRACE("element " + std::to_string(e));
    const int k = b.elem_index(0, e);
    const double l = L / n;
    EXPECT_TRUE(near_ulps(m.elem_rest_length[k], l, 16));
    EXPECT_TRUE(near_ulps(m.elem_stiffness[0][k], kappa * G * A, 16));
    EXPECT_TRUE(near_ulps(m.elem_stiffness[1][k], kappa * G * A, 16));
    EXPECT_TRUE(near_ulps(m.elem_stiffness[2][k], E * A, 16));
    EXPECT_TRUE(near_ulps(m.elem_inertia[0][k], rho * l * I, 16));
    EXPECT_TRUE(near_ulps(m.elem_inertia[1][k], rho * l * I, 16));
    EXPECT_TRUE(near_ulps(m.elem_inertia[2][k], rho * l * I3, 16));
    for (int d = 0; d < 3; ++d) EXPECT_TRUE(near_ulps(m.elem_inv_inertia[d][k] * m.elem_inertia[d][k], 1.0, 2));
    // straight, untwisted: V0 = e3
    EXPECT_TRUE(near_ulps(m.elem_rest_strain[2][k], 1.0, 16));
    EXPECT_NEAR(m.elem_rest_strain[0][k], 0.0, 16 * kU);
    EXPECT_NEAR(m.elem_rest_strain[1][k], 0.0, 16 * kU);
  }
  for (int j = 0; j + 1 < n; ++j) {
    SCOPED_TRACE("voronoi " + std::to_string(j));
    const int k = b.vor_index(0, j);
    EXPECT_TRUE(near_ulps(m.vor_rest_length[k], L / n, 16));
    EXPECT_TRUE(near_ulps(m.vor_stiffness[0][k], E * I, 16));
    EXPECT_TRUE(near_ulps(m.vor_stiffness[1][k], E * I, 16));
    EXPECT_TRUE(near_ulps(m.vor_stiffness[2][k], G * JT, 16));
    for (int d = 0; d < 3; ++d) EXPECT_EQ(m.vor_rest_curvature[d][k], 0.0);
  }

  // Root Voronoi point: clamped → length l̂0/2 with the bending/twist stiffness
  // of element 0's section; free → zero stiffness.
  const int root = b.root_vor_index(0), root_free = b.root_vor_index(1);
  EXPECT_TRUE(near_ulps(m.vor_rest_length[root], 0.5 * m.elem_rest_length[b.elem_index(0, 0)], 1));
  for (int d = 0; d < 3; ++d) {
    EXPECT_EQ(m.vor_stiffness[d][root], m.vor_stiffness[d][b.vor_index(0, 0)]);
    EXPECT_EQ(m.vor_stiffness[d][root_free], 0.0);
  }
  // The clamped node has infinite mass (zero inverse mass), the free rod's not.
  EXPECT_EQ(m.node_inv_mass[b.node_index(0, 0)], 0.0);
  EXPECT_GT(m.node_inv_mass[b.node_index(1, 0)], 0.0);

  // Ghost slots (root ghost element, tip ghost element) carry nothing.
  for (int r = 0; r < 3; ++r)
    for (int ghost : {b.elem_index(r, -1), b.elem_index(r, n)})
      for (int d = 0; d < 3; ++d) {
        EXPECT_EQ(m.elem_stiffness[d][ghost], 0.0);
        EXPECT_EQ(m.elem_inv_inertia[d][ghost], 0.0);
        EXPECT_EQ(m.node_mass[b.node_index(r, -1)], 0.0);
      }

  // shear_stretch_scale multiplies elem_stiffness only.
  for (int e = 0; e < n; ++e) {
    const int k0 = b.elem_index(0, e), k2 = b.elem_index(2, e);
    for (int d = 0; d < 3; ++d) {
      // ((f·κ)·G)·A vs f·((κ·G)·A): 3 roundings on either side → 6, allow 8.
      EXPECT_TRUE(near_ulps(m.elem_stiffness[d][k2], 1e4 * m.elem_stiffness[d][k0], 8));
      EXPECT_EQ(m.elem_inertia[d][k2], m.elem_inertia[d][k0]);
      EXPECT_EQ(m.elem_tau[d][k2], m.elem_tau[d][k0]);
    }
  }
  for (int j = 0; j + 1 < n; ++j)
    for (int d = 0; d < 3; ++d)
      EXPECT_EQ(m.vor_stiffness[d][b.vor_index(2, j)], m.vor_stiffness[d][b.vor_index(0, j)]);
  for (int j = 0; j <= n; ++j) EXPECT_EQ(m.node_mass[b.node_index(2, j)], m.node_mass[b.node_index(0, j)]);
}

// Damping in the batch: elem_tau = (τS, τS, τE), vor_tau = (τE, τE, τS).
TEST(BatchModel, DampingArrays) {
  const RodBatch<double> b = build_batch<double>({cases::seed_cantilever(5, Damping::shear_extension(0.03, 0.05))});
  const auto& m = b.model;
  for (int e = 0; e < 5; ++e) {
    const int k = b.elem_index(0, e);
    EXPECT_EQ(m.elem_tau[0][k], 0.03);
    EXPECT_EQ(m.elem_tau[1][k], 0.03);
    EXPECT_EQ(m.elem_tau[2][k], 0.05);
  }
  for (int j = -1; j < 4; ++j) {
    const int k = j < 0 ? b.root_vor_index(0) : b.vor_index(0, j);
    EXPECT_EQ(m.vor_tau[0][k], 0.05);
    EXPECT_EQ(m.vor_tau[1][k], 0.05);
    EXPECT_EQ(m.vor_tau[2][k], 0.03);
  }
}
