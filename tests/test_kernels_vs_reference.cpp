// The batch kernels against the plain per-rod reference (tests/reference.h)
// on random curved, sheared, stretched, moving rods of different lengths in
// ONE batch, some clamped and some free, with gravity, point forces, couples
// and Kelvin–Voigt damping.
//
// Tolerances. Every comparison is |batch − reference| ≤ k·u·scale, where
// `scale` is the reference's running-error scale of that quantity (the value
// of the same formula with every operand replaced by its magnitude; see
// reference.h). Kernel and reference evaluate the same formulas in different
// orders (and the compiler may fuse multiply–adds), so each side is off by at
// most (number of roundings on its longest path)·u·scale. The longest path is
// a node force or element couple: strain (≈ 8 roundings: Q e is 3 products
// and 2 sums, ÷ l̂, − V0), rate (≈ 10), resultant (2), Qᵀn (5), the sum of
// two neighbours and the loads (3); for a couple the log map, J_r⁻¹ (≈ 12)
// and the cross products. About 30 per side, 60 for both: k = 64 in double.
// A genuine discrepancy in a formula shows up as a ratio of order 1/u ≈ 1e16;
// an approximation error (a truncated series, a wrong branch threshold)
// somewhere between; the worst ratio of every check is printed. Measured
// worst: ≈ 9, for κ̇ just above θ = 0.5 where γ's closed form costs ≈ 8u.
// (This comparison found two series in kernels/math.h cut off too early:
// θ/sin θ below θ = 0.1 (2e-9 relative in κ) and γ(θ) below θ = 0.5 (8e-11);
// both gave ratios of 1e4–1e5 before they were fixed.)
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "check.h"
#include "ref_batch.h"

using namespace manyrods;
using namespace manyrods::testing;

namespace {

constexpr double kU = std::numeric_limits<double>::epsilon() / 2;  // unit round-off, double
constexpr double kK = 64;  // roundings on both sides (see the top of this file)

const V3 kGravity(0.7, -9.81, 0.3);

// The reference steps the Kelvin–Voigt force explicitly (rates at the start
// of the kick), which is the library's Viscous::explicit_rate; the default
// implicit viscous update is a different scheme and is not compared here.
template <Terms kT, class T>
void explicit_step(RodBatch<T>& b, T h) {
  step<kT, Viscous::explicit_rate>(b, h);
}

// 3, 7, 12 and 20 elements, plus the edge cases of 1 and 2 elements,
// clamped and free mixed.
std::vector<ref::Rod> random_rods(std::uint64_t seed) {
  Random rnd(seed);
  return {random_rod(rnd, 3, true, kGravity),  random_rod(rnd, 7, false, kGravity),
          random_rod(rnd, 20, true, kGravity), random_rod(rnd, 1, false, kGravity),
          random_rod(rnd, 2, true, kGravity),  random_rod(rnd, 1, true, kGravity),
          random_rod(rnd, 12, false, kGravity)};
}

// Loads `rods` into one batch and compares, for Terms kT, against the
// reference with the switched-off terms zeroed: generalized forces, the
// scratch resultants (Qᵀn, m̃, D̂ κ × m), strains and their rates (kernel
// functions called directly), per-rod energies, and one Position Verlet step
// (with the library's 4 evaluations of the implicit-midpoint Euler map).
template <Terms kT>
void compare_all(const std::vector<ref::Rod>& rods, const std::string& label, double step_h = 1e-4) {
  RodBatch<double> b = make_batch<double>(rods);
  const ForceArrays<double> f = batch_forces<kT>(b);

  {
    Checker force(label + " node force", kU, kK), couple(label + " element couple", kU, kK);
    Checker qtn(label + " Q^T n (scratch)", kU, kK), mom(label + " m~ (scratch)", kU, kK),
        kxm(label + " D k x m (scratch)", kU, kK);
    Checker sigma(label + " sigma", kU, kK), sigma_rate(label + " sigma rate", kU, kK),
        kappa(label + " kappa", kU, kK), kappa_rate(label + " kappa rate", kU, kK);
    const ModelView<double> mv = b.model_view();
    const ConstStateView<double> sv = std::as_const(b).state_view();
    for (int r = 0; r < b.rod_count(); ++r) {
      const ref::Rod& rod = rods[r];
      const ref::Evaluation ev = ref::evaluate(rod, kT);
      const int n = rod.elements();
      for (int j = 0; j <= n; ++j) {
        const int k = b.node_index(r, j);
        force.vec(get3(f.force, k), ev.force[j], ev.force_scale[j], where("node", r, j));
      }
      for (int e = 0; e < n; ++e) {
        const int k = b.elem_index(r, e);
        couple.vec(get3(f.couple, k), ev.couple[e], ev.couple_scale[e], where("element", r, e));
        qtn.vec(get3(b.scratch.elem_force, k), rod.Q[e].transpose() * ev.n[e], ev.n_scale[e],
                where("element", r, e));
        const ElementStrain<double> es = element_strain(k, mv, sv);
        sigma.vec(V3(es.sigma.x, es.sigma.y, es.sigma.z), ev.sigma[e], ev.sigma_scale[e],
                  where("element", r, e));
        const vec3<double> sr = element_strain_rate(k, mv, sv, es);
        sigma_rate.vec(V3(sr.x, sr.y, sr.z), ev.sigma_rate[e], ev.sigma_rate_scale[e],
                       where("element", r, e));
      }
      // The kernel splits a joint's couples +J_r⁻ᵀm (element a) and −J_r⁻¹m
      // (element b) into m̃ = ½(on_a − on_b) = (I + γ[ψ]×²) m, stored as
      // vor_moment, and D̂κ × m = on_a + on_b, stored as vor_kxm.
      auto voronoi = [&](int k, const V3& kap, const V3& kap_rate, const V3& on_a, const V3& on_b,
                         double kap_scale, double kap_rate_scale, double couple_scale,
                         const std::string& at) {
        mom.vec(get3(b.scratch.vor_moment, k), 0.5 * (on_a - on_b), couple_scale, at);
        kxm.vec(get3(b.scratch.vor_kxm, k), on_a + on_b, 2 * couple_scale, at);
        const VoronoiStrain<double> vs = voronoi_strain(k, mv, sv);
        kappa.vec(V3(vs.kappa.x, vs.kappa.y, vs.kappa.z), kap, kap_scale, at);
        const vec3<double> kr = voronoi_strain_rate(k, mv, sv, vs);
        kappa_rate.vec(V3(kr.x, kr.y, kr.z), kap_rate, kap_rate_scale, at);
      };
      for (int j = 0; j + 1 < n; ++j)
        voronoi(b.vor_index(r, j), ev.kappa[j], ev.kappa_rate[j], ev.on_a[j], ev.on_b[j], ev.kappa_scale[j],
                ev.kappa_rate_scale[j], ev.joint_couple_scale[j], where("voronoi", r, j));
      if (rod.clamped)
        voronoi(b.root_vor_index(r), ev.root_kappa, ev.root_kappa_rate, ev.root_on_a, ev.root_on_b,
                ev.root_kappa_scale, ev.root_kappa_rate_scale, ev.root_joint_couple_scale,
                where("root voronoi", r, 0));
    }
  }

  // Energies per rod. Each is a sum over the rod's entries in double, in a
  // different order than the reference's: the same k·u·scale bound holds,
  // with the scales of reference.h (kinetic: its own value, a sum of
  // non-negative terms; elastic/dissipation: l̂·|C|·|strain|·strain_scale).
  {
    Checker kin(label + " kinetic energy", kU, kK), ela(label + " elastic energy", kU, kK),
        pot(label + " potential energy", kU, kK), dis(label + " 2 D_v", kU, kK);
    for (int r = 0; r < b.rod_count(); ++r) {
      const Energies e = energies<kT>(b, r);
      const ref::Energies x = ref::energies(rods[r], kT);
      kin.num(e.kinetic, x.kinetic, x.kinetic_scale, where("rod", r, r));
      ela.num(e.elastic, x.elastic, x.elastic_scale, where("rod", r, r));
      pot.num(e.potential, x.potential, x.potential_scale, where("rod", r, r));
      dis.num(e.dissipation, x.dissipation, x.dissipation_scale, where("rod", r, r));
    }
  }

  // One step. The two sides' half drifts may round differently (the kernel
  // may fuse x + ½h·v), so the forces are evaluated at positions that differ
  // by u·|x|: the force scales are taken with positions_rounded = true. Then
  //   v' = v + (h/m) F          error ≤ k·u·(|v| + (h/m)·F_scale)
  //   x' = x + ½h v + ½h v'     error ≤ k·u·(|x| + h|v| + h·(|v| + (h/m)·F_scale))
  //   ω' = Φ⁴(ω), Φ(w) = ω + h J⁻¹(C + (Jω̄)×ω̄), ω̄ = (ω + w)/2: each
  //   evaluation rounds like an explicit update and Φ contracts
  //   (h|ω|·J_max/J_min ≈ 1e-3 here), so
  //                             error ≤ k·u·(|ω| + (h/J_min)·C_scale)
  //   Q' = exp(−½hω') exp(−½hω) Q, entries O(1): error ≤ k·u·(1 + h·ω-error/u)
  // (scales taken at the start of the step: over one step of 1e-4 s they
  // change by far less than a factor 2).
  {
    const double h = step_h;
    explicit_step<kT>(b, h);
    Checker xs(label + " step: x", kU, kK), vs(label + " step: v", kU, kK), qs(label + " step: Q", kU, kK),
        ws(label + " step: w", kU, kK);
    for (int r = 0; r < b.rod_count(); ++r) {
      const ref::Rod& rod = rods[r];
      const ref::Rod next = ref::step(rod, h, kT);
      const ref::Evaluation ev = ref::evaluate(rod, kT, true);
      const int n = rod.elements();
      for (int j = 0; j <= n; ++j) {
        const int k = b.node_index(r, j);
        const double v_scale = rod.v[j].norm() + h / rod.mass[j] * ev.force_scale[j];
        vs.vec(get3(b.state.node_v, k), next.v[j], v_scale, where("node", r, j));
        xs.vec(get3(b.state.node_x, k), next.x[j], rod.x[j].norm() + h * rod.v[j].norm() + h * v_scale,
               where("node", r, j));
      }
      for (int e = 0; e < n; ++e) {
        const int k = b.elem_index(r, e);
        const double w_scale = rod.w[e].norm() + h / rod.J[e].minCoeff() * ev.couple_scale[e];
        ws.vec(get3(b.state.elem_w, k), next.w[e], w_scale, where("element", r, e));
        const double q_err = (get_frame(b, k) - next.Q[e]).cwiseAbs().maxCoeff();
        qs.num(q_err, 0, 1 + h * w_scale, where("element", r, e));
      }
      if (rod.clamped) {  // the clamp frame never moves
        EXPECT_EQ(get_frame(b, b.elem_index(r, -1)), rod.Q_clamp) << where("clamp of rod", r, r);
        EXPECT_EQ(get3(b.state.node_x, b.node_index(r, 0)), rod.x[0]) << where("clamped node of rod", r, r);
      }
    }
  }
}

constexpr Terms off(bool Terms::*which) {
  Terms t;
  t.*which = false;
  return t;
}
constexpr Terms kNoShear = off(&Terms::shear);
constexpr Terms kNoStretch = off(&Terms::stretch);
constexpr Terms kNoBend = off(&Terms::bend);
constexpr Terms kNoTwist = off(&Terms::twist);
constexpr Terms kNoLoads = off(&Terms::loads);
constexpr Terms kNothing{false, false, false, false, false, false, false};

}  // namespace

TEST(KernelsVsReference, AllTermsOnRandomRods) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    compare_all<kAllTerms>(random_rods(seed), "all terms, seed " + std::to_string(seed));
  }
}

// The test data make every term matter: with all terms on, the reference's
// forces differ from those with any one term zeroed by far more than the
// tolerance, so a batch that ignored a Terms flag (or applied it to the wrong
// components) would fail the comparisons below.
TEST(KernelsVsReference, EveryTermChangesTheForces) {
  const std::vector<ref::Rod> rods = random_rods(7);
  for (Terms t : {kNoShear, kNoStretch, kNoBend, kNoTwist, kNoKelvinVoigt, kNoGravity, kNoLoads}) {
    double largest = 0;  // max over entries of |F_on − F_off| / (u·scale)
    for (const ref::Rod& rod : rods) {
      const ref::Evaluation on = ref::evaluate(rod), o = ref::evaluate(rod, t);
      for (std::size_t j = 0; j < on.force.size(); ++j)
        largest = std::max(largest, (on.force[j] - o.force[j]).norm() / (kU * on.force_scale[j]));
      for (std::size_t e = 0; e < on.couple.size(); ++e)
        largest = std::max(largest, (on.couple[e] - o.couple[e]).norm() / (kU * on.couple_scale[e]));
    }
    EXPECT_GT(largest, 1e6 * kK) << "terms mask " << terms_mask(t);
  }
}

TEST(KernelsVsReference, ShearOff) { compare_all<kNoShear>(random_rods(11), "shear off"); }
TEST(KernelsVsReference, StretchOff) { compare_all<kNoStretch>(random_rods(12), "stretch off"); }
TEST(KernelsVsReference, BendOff) { compare_all<kNoBend>(random_rods(13), "bend off"); }
TEST(KernelsVsReference, TwistOff) { compare_all<kNoTwist>(random_rods(14), "twist off"); }
TEST(KernelsVsReference, KelvinVoigtOff) { compare_all<kNoKelvinVoigt>(random_rods(15), "kelvin-voigt off"); }
TEST(KernelsVsReference, GravityOff) { compare_all<kNoGravity>(random_rods(16), "gravity off"); }
TEST(KernelsVsReference, LoadsOff) { compare_all<kNoLoads>(random_rods(17), "loads off"); }
TEST(KernelsVsReference, EverythingOff) { compare_all<kNothing>(random_rods(18), "everything off"); }

// Neighbouring elements rotated by nearly π against each other: the log map
// switches to its near-π branch (cos θ < −0.9) and J_r⁻¹ is evaluated where
// sin θ → 0. Everything must stay finite and match the reference to the same
// round-off bound (the log map's condition |J_r⁻¹| ≤ π/2 stays bounded up to
// π, so no extra loss is expected).
TEST(KernelsVsReference, RelativeRotationsNearPi) {
  Random rnd(99);
  const double pi = std::numbers::pi;
  const std::vector<double> angles = {3.1, 3.14, pi - 1e-6, 2.7, 2.6, 0.49, 0.51, 1e-9};
  std::vector<ref::Rod> rods;
  for (bool clamped : {false, true}) {
    ref::Rod r = random_rod(rnd, static_cast<int>(angles.size()) + 1, clamped, kGravity);
    // Each frame rotated against the previous one by the given angle about a
    // random axis; the centreline stays as drawn (shear is then large, which
    // only makes the test harder).
    for (std::size_t j = 0; j < angles.size(); ++j) {
      r.Q[j + 1] = Eigen::AngleAxisd(angles[j], rnd.unit()).toRotationMatrix() * r.Q[j];
      r.U0[j] = -ref::rotation_log(r.Q[j + 1] * r.Q[j].transpose()) / r.D[j] + rnd.box(0.2 / r.D[j]);
    }
    if (clamped) r.Q_clamp = Eigen::AngleAxisd(3.1, rnd.unit()).toRotationMatrix() * r.Q[0];
    rods.push_back(r);
  }
  // the angles really are what the test claims
  const ref::Evaluation ev = ref::evaluate(rods[0]);
  for (std::size_t j = 0; j < angles.size(); ++j)
    EXPECT_NEAR(ev.kappa[j].norm() * rods[0].D[j], angles[j], 1e-12);

  compare_all<kAllTerms>(rods, "near pi");
  // A few explicit steps stay finite. The frames rotated by ≈ π against the
  // centreline give shear strains ≈ 2 and element rotation frequencies
  // ω_max² ≈ C_F·l̂/J ≈ 1.6e8 s⁻²; the explicit Kelvin–Voigt limit
  // dt ≲ 2/(τ ω_max²) is then ≈ 6e-7 s (1e-5 s blows up within 10 steps, as
  // it should), so step at 1e-7 s.
  RodBatch<double> b = make_batch<double>(rods);
  for (int i = 0; i < 100; ++i) explicit_step<kAllTerms>(b, 1e-7);
  EXPECT_FALSE(find_non_finite(b).found);
}

// float against double. The float batch holds the same rods rounded to float
// (positions, frames, parameters: relative error u_f = 2⁻²⁴ ≈ 6e-8 each; the
// frames are then orthonormal only to u_f). Its error is the float round-off
// of the same formulas, so it is bounded by k_f·u_f·scale with the scales of
// the reference taken with positions_rounded = true (the element vector
// x_{k+1} − x_k now inherits u_f·|x|, not u_f·|x_{k+1} − x_k|: that is the
// condition number |x|/l̂ of the strain). The double batch's own error is
// 1e-9 of that and is ignored. k_f: the ≈ 30 roundings of the longest path
// (see the top of this file) plus the input roundings (≈ 5 per path): 40.
// The measured worst ratio is printed (≈ 1.6 at the time of writing): a float
// evaluation that loses more than ~5 bits beyond this bound fails. (The
// absolute scales are generous for small relative rotations, so a relative
// error of a few u_f in a small ψ would pass; the double comparison above
// resolves such errors 10⁹ times more finely.)
TEST(KernelsVsReference, FloatAgreesWithDouble) {
  constexpr double kUf = std::numeric_limits<float>::epsilon() / 2;
  constexpr double kKf = 40;
  const std::vector<ref::Rod> rods = random_rods(5);
  RodBatch<double> bd = make_batch<double>(rods);
  RodBatch<float> bf = make_batch<float>(rods);
  const ForceArrays<double> fd = batch_forces<kAllTerms>(bd);
  const ForceArrays<float> ff = batch_forces<kAllTerms>(bf);
  Checker force("float node force", kUf, kKf), couple("float element couple", kUf, kKf);
  double largest_double_units = 0;  // the float error in units of the double round-off
  for (int r = 0; r < bd.rod_count(); ++r) {
    const ref::Evaluation ev = ref::evaluate(rods[r], kAllTerms, true);
    for (int j = 0; j <= rods[r].elements(); ++j) {
      const int k = bd.node_index(r, j);
      force.vec(get3(ff.force, k), get3(fd.force, k), ev.force_scale[j], where("node", r, j));
      largest_double_units = std::max(
          largest_double_units, (get3(ff.force, k) - get3(fd.force, k)).norm() / (kU * ev.force_scale[j]));
    }
    for (int e = 0; e < rods[r].elements(); ++e) {
      const int k = bd.elem_index(r, e);
      couple.vec(get3(ff.couple, k), get3(fd.couple, k), ev.couple_scale[e], where("element", r, e));
    }
  }
  // Not a tautology: the float batch really computed in float.
  EXPECT_GT(largest_double_units, 1e3 * kK);

  // Energies, same reasoning (summed in double from float terms).
  Checker kin("float kinetic energy", kUf, kKf), ela("float elastic energy", kUf, kKf),
      dis("float 2 D_v", kUf, kKf), pot("float potential energy", kUf, kKf);
  for (int r = 0; r < bd.rod_count(); ++r) {
    const Energies ed = energies(bd, r), ef = energies(bf, r);
    const ref::Energies x = ref::energies(rods[r]);
    // positions rounded to float: the strain scales grow by |x|/l̂ as above;
    // bound the energies by the force-scale argument: δE ≤ Σ |n|·δσ·l̂, with
    // δσ ≤ k·u·(|x_k|+|x_{k+1}|)/l̂ — taken here as the elastic scale times
    // the largest |x|/l̂ ratio of the rod.
    double cond = 1;
    for (int e = 0; e < rods[r].elements(); ++e)
      cond = std::max(cond, (rods[r].x[e].norm() + rods[r].x[e + 1].norm()) / rods[r].l0[e]);
    kin.num(ef.kinetic, ed.kinetic, x.kinetic_scale, where("rod", r, r));
    ela.num(ef.elastic, ed.elastic, cond * x.elastic_scale, where("rod", r, r));
    dis.num(ef.dissipation, ed.dissipation, cond * x.dissipation_scale, where("rod", r, r));
    pot.num(ef.potential, ed.potential, x.potential_scale, where("rod", r, r));
  }

  // One step in float agrees with one step in double: the step's error is
  // the force error times h/m (h/J), plus u_f per update.
  const double h = 1e-4;
  explicit_step<kAllTerms>(bd, h);
  explicit_step<kAllTerms>(bf, float(h));
  Checker vs("float step: v", kUf, kKf), ws("float step: w", kUf, kKf);
  for (int r = 0; r < bd.rod_count(); ++r) {
    const ref::Evaluation ev = ref::evaluate(rods[r], kAllTerms, true);
    for (int j = 0; j <= rods[r].elements(); ++j) {
      const int k = bd.node_index(r, j);
      vs.vec(get3(bf.state.node_v, k), get3(bd.state.node_v, k),
             rods[r].v[j].norm() + h / rods[r].mass[j] * ev.force_scale[j], where("node", r, j));
    }
    for (int e = 0; e < rods[r].elements(); ++e) {
      const int k = bd.elem_index(r, e);
      ws.vec(get3(bf.state.elem_w, k), get3(bd.state.elem_w, k),
             rods[r].w[e].norm() + h / rods[r].J[e].minCoeff() * ev.couple_scale[e], where("element", r, e));
    }
  }
}

// The rigid-body term is integrated by the implicit midpoint rule
// J(ω⁺ − ω)/h = C + (Jω̄)×ω̄ (kernels/integrate.h), with the fixed-point map Φ
// applied 4 times from ω (the explicit guess and three sweeps). Φ is a
// contraction with constant L = ½h·|J⁻¹|·|∂((Jω̄)×ω̄)/∂ω̄| ≤ h·(J_max/J_min)·|ω̄|,
// so Φ⁴(ω) lies within L⁴·|ω* − ω| of the exact midpoint solution ω*.
// Here |ω| ≈ 2000 rad/s, J_max/J_min ≤ 3 and h = 1e-5 s (L ≈ 0.06): the batch must
// match the converged reference to that bound (plus round-off), and it must
// NOT match the explicit Euler term (one evaluation of Φ), which is off by
// about L·|ω* − ω| — so the test tells the two schemes apart.
TEST(KernelsVsReference, EulerTermIsImplicitMidpoint) {
  Random rnd(31);
  std::vector<ref::Rod> rods = {random_rod(rnd, 6, false, kGravity), random_rod(rnd, 9, true, kGravity)};
  for (ref::Rod& r : rods) {
    // soft rods: elements spinning at 2000 rad/s against their nodes shear
    // at σ̇ ≈ |ω| (viscous n ≈ C_F τ |ω| ≈ 4000 N), whose couple would
    // otherwise change ω by thousands of rad/s in one step
    for (V3& c : r.CF) c *= 1e-3;
    for (V3& c : r.CM) c *= 1e-3;
    r.CM_root *= 1e-3;
    for (std::size_t e = 0; e < r.w.size(); ++e) {
      r.w[e] = rnd.box(1200.0);
      r.J[e] = rnd.range({1e-8, 1.5e-8, 3e-8}, {1.5e-8, 2e-8, 3e-8});  // anisotropic
    }
  }
  const double h = 1e-5;
  RodBatch<double> b = make_batch<double>(rods);
  explicit_step<kAllTerms>(b, h);
  double worst_over_bound = 0, explicit_over_bound = std::numeric_limits<double>::infinity();
  for (int r = 0; r < b.rod_count(); ++r) {
    const ref::Rod converged = ref::step(rods[r], h, kAllTerms, -1);
    const ref::Rod explicit_euler = ref::step(rods[r], h, kAllTerms, 1);
    const ref::Evaluation ev = ref::evaluate(rods[r], kAllTerms, true);
    for (int e = 0; e < rods[r].elements(); ++e) {
      const ref::Rod& rod = rods[r];
      const V3 w = get3(b.state.elem_w, b.elem_index(r, e));
      const double wbar = 0.5 * (rod.w[e] + converged.w[e]).norm();
      const double L = h * rod.J[e].maxCoeff() / rod.J[e].minCoeff() * wbar;
      ASSERT_LT(L, 0.2);
      const double roundoff = kK * kU * (rod.w[e].norm() + h / rod.J[e].minCoeff() * ev.couple_scale[e]);
      const double bound = std::pow(L, 4) * (converged.w[e] - rod.w[e]).norm() + roundoff;
      worst_over_bound = std::max(worst_over_bound, (w - converged.w[e]).norm() / bound);
      explicit_over_bound =
          std::min(explicit_over_bound, (explicit_euler.w[e] - converged.w[e]).norm() / bound);
    }
  }
  std::printf("  Euler term: |batch - midpoint| / bound = %.3g; explicit Euler term / bound >= %.3g\n",
              worst_over_bound, explicit_over_bound);
  EXPECT_LE(worst_over_bound, 1);
  EXPECT_GT(explicit_over_bound, 10);
}
