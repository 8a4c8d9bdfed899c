// Property tests (docs/validation.md "2d Free fall", "3a Objectivity under rigid
// motion", "7c Frames, permutation and thread count"): objectivity under
// rigid motion, orthonormal frames over long runs, permutation invariance of
// the batch, thread-count determinism, and free fall.
//
// Tolerances are k·u·scale with the running-error scales of the reference
// (tests/reference.h): the exact answer of (a) and of the shape in (e) is
// zero, so "relative to the result" cannot be used; the scale is what the
// same formula would give with every operand replaced by its magnitude. k =
// 64 covers the ≈ 30 roundings on the longest path of a node force or
// element couple with a factor 2 to spare (tests/test_kernels_vs_reference.cpp
// measures k ≲ 10 against the reference).
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

#include "cases.h"
#include "check.h"
#include "ref_batch.h"

using namespace manyrods;
using namespace manyrods::testing;

namespace {

constexpr double kU = std::numeric_limits<double>::epsilon() / 2;
constexpr double kK = 64;
constexpr double kPi = std::numbers::pi;

Vec3 vec(const V3& a) { return {a[0], a[1], a[2]}; }
Mat3 mat(const M3& q) {
  Mat3 m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m[3 * i + j] = q(i, j);
  return m;
}

// Seed-cantilever material (tests/cases.h): 1 cm × 1 cm, E = 1 MPa, ν = 0.3,
// ρ = 1000, with Kelvin–Voigt τS = 0.01 s, τE = 0.02 s.
void seed_material(RodSpec& s) {
  s.section = Section::rectangle(0.01, 0.01);
  s.material = {1000, 1e6, 0.3};
  s.damping = Damping::shear_extension(0.01, 0.02);
}

// A strongly curled rod: its tangent turns by `turn` rad per element about an
// axis that itself precesses (a tight, irregular helix), the frames are
// twisted by `twist` rad per element about the tangent and tilted 0.05 rad
// off it (so the rest shape has shear). Neighbouring frames differ by about
// √(turn² + twist²). The given geometry is the rest shape.
RodSpec curly_rod(int n, double length, double turn, double twist, bool clamped, std::uint64_t seed) {
  Random rnd(seed);
  std::vector<Vec3> nodes;
  std::vector<Mat3> frames;
  V3 x = rnd.box(0.2), t = rnd.unit(), d1 = rnd.unit_perpendicular(t);
  V3 axis = rnd.unit_perpendicular(t);
  nodes.push_back(vec(x));
  for (int e = 0; e < n; ++e) {
    x += length / n * t;
    nodes.push_back(vec(x));
    const M3 tilt = Eigen::AngleAxisd(0.05, rnd.unit_perpendicular(t)).toRotationMatrix();
    const V3 q3 = tilt * t, q1 = tilt * d1;
    frames.push_back(mat(frame_from_rows(q1, q3.cross(q1), q3)));
    const M3 r = Eigen::AngleAxisd(turn, axis).toRotationMatrix();
    t = (r * t).normalized();
    d1 = Eigen::AngleAxisd(twist, t) * (r * d1);
    d1 = (d1 - t * t.dot(d1)).normalized();
    axis = Eigen::AngleAxisd(0.3, t) * axis;  // precess
    axis = (axis - t * t.dot(axis)).normalized();
  }
  RodSpec s = RodSpec::polyline(nodes, frames);
  seed_material(s);
  s.clamped_root = clamped;
  if (clamped) {  // a clamp frame 0.5 rad away from element 0's: the root joint is bent and twisted
    const M3 q0 = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(frames[0].data());
    s.root_frame = mat(q0 * Eigen::AngleAxisd(0.5, rnd.unit()).toRotationMatrix());
  }
  return s;
}

// ---- (a) objectivity ---------------------------------------------------------

// Moves rod r of b rigidly: x ← G x + t, every frame (clamp and ghosts too)
// Q ← Q Gᵀ (each director d ← G d), and gives it the rigid velocity field
// v = V + Ω × (x − c), ω = Q Ω (material components of the lab Ω).
void rigid_motion(RodBatch<double>& b, int r, const M3& G, const V3& t, const V3& V, const V3& Omega,
                  const V3& c) {
  const int n = b.elements(r);
  for (int j = -1; j <= n; ++j) {
    const int k = b.node_index(r, j);
    const V3 x = G * get3(b.state.node_x, k) + t;
    const V3 v = V + Omega.cross(x - c);
    for (int d = 0; d < 3; ++d) {
      b.state.node_x[d][k] = x[d];
      b.state.node_v[d][k] = v[d];
    }
  }
  for (int e = -1; e <= n; ++e) {
    const int k = b.elem_index(r, e);
    const M3 q = get_frame(b, k) * G.transpose();
    const V3 w = q * Omega;
    for (int i = 0; i < 9; ++i) b.state.elem_Q[i][k] = q(i / 3, i % 3);
    for (int d = 0; d < 3; ++d) b.state.elem_w[d][k] = w[d];
  }
}

constexpr Terms kInternal = [] {
  Terms t;
  t.gravity = false;
  t.loads = false;
  return t;
}();

// 3a. A rigid translation plus a rigid rotation at 40 rad/s, by large
// angles up to nearly π, of strongly curled rods (relative rotations of
// about 1 rad between neighbours) at their rest shape: the elastic AND
// viscous resultants vanish, so the internal node forces and element
// couples, less the rigid-body term (Jω)×ω, vanish to round-off, and so do
// the elastic energy and 2·D_v. The curvature rate that makes this work is
// the exact one, J_r(ψ)⁻¹(Rᵀω_b − ω_a)/D̂; the plain difference
// (ω_b − ω_a)/D̂ is computed alongside and shown to be ~1e13 times larger
// than the tolerance: the case is hard.
TEST(Properties, RigidMotionGivesNoInternalForce) {
  const std::vector<RodSpec> specs = {curly_rod(16, 0.3, 0.8, 0.45, false, 1),
                                      curly_rod(16, 0.3, 0.8, 0.45, true, 2),
                                      curly_rod(9, 0.3, 1.0, 0.3, false, 3)};
  Random rnd(4);
  for (double angle : {0.0, 0.7, 2.0, 3.1, kPi - 1e-7}) {
    SCOPED_TRACE("rotation angle " + std::to_string(angle));
    RodBatch<double> b = build_batch<double>(specs);
    const V3 axis = rnd.unit(), t = rnd.box(1.0), V = rnd.box(2.0), c = rnd.box(0.5);
    const V3 Omega = 40 * rnd.unit();
    const M3 G = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    for (int r = 0; r < b.rod_count(); ++r) rigid_motion(b, r, G, t, V, Omega, c);

    const ForceArrays<double> f = batch_forces<kInternal>(b);
    const ModelView<double> mv = b.model_view();
    const ConstStateView<double> sv = std::as_const(b).state_view();
    Checker force("rigid: node force", kU, kK), couple("rigid: couple - (Jw)xw", kU, kK),
        n_res("rigid: n (scratch, lab)", kU, kK), m_res("rigid: m~ (scratch)", kU, kK),
        srate("rigid: sigma rate", kU, kK), krate("rigid: kappa rate", kU, kK);
    double min_relative_rotation = 10, max_relative_rotation = 0;
    double plain_over_tolerance = std::numeric_limits<double>::infinity();
    for (int r = 0; r < b.rod_count(); ++r) {
      const ref::Rod rod = extract_rod(b, r);
      const ref::Evaluation ev = ref::evaluate(rod, kInternal, true);
      const int n = rod.elements();
      for (int j = 0; j <= n; ++j)
        force.vec(get3(f.force, b.node_index(r, j)), V3::Zero(), ev.force_scale[j], where("node", r, j));
      for (int e = 0; e < n; ++e) {
        const int k = b.elem_index(r, e);
        const V3 w = get3(b.state.elem_w, k);
        const V3 inertial = rod.J[e].cwiseProduct(w).cross(w);
        couple.vec(get3(f.couple, k) - inertial, V3::Zero(), ev.couple_scale[e], where("element", r, e));
        n_res.vec(get3(b.scratch.elem_force, k), V3::Zero(), ev.n_scale[e], where("element", r, e));
        const vec3<double> sr = element_strain_rate(k, mv, sv, element_strain(k, mv, sv));
        srate.vec(V3(sr.x, sr.y, sr.z), V3::Zero(), ev.sigma_rate_scale[e], where("element", r, e));
      }
      for (int j = 0; j + 1 < n; ++j) {
        const int k = b.vor_index(r, j);
        m_res.vec(get3(b.scratch.vor_moment, k), V3::Zero(), ev.joint_couple_scale[j],
                  where("voronoi", r, j));
        const vec3<double> kr = voronoi_strain_rate(k, mv, sv, voronoi_strain(k, mv, sv));
        krate.vec(V3(kr.x, kr.y, kr.z), V3::Zero(), ev.kappa_rate_scale[j], where("voronoi", r, j));
        const double theta = ev.kappa[j].norm() * rod.D[j];
        min_relative_rotation = std::min(min_relative_rotation, theta);
        max_relative_rotation = std::max(max_relative_rotation, theta);
        // the plain difference of the neighbours' angular velocities
        const V3 plain = (rod.w[j + 1] - rod.w[j]) / rod.D[j];
        plain_over_tolerance =
            std::min(plain_over_tolerance, plain.norm() / (kK * kU * ev.kappa_rate_scale[j]));
      }
      if (rod.clamped)
        m_res.vec(get3(b.scratch.vor_moment, b.root_vor_index(r)), V3::Zero(), ev.root_joint_couple_scale,
                  where("root voronoi", r, 0));

      // Energies: every strain and rate is below k·u·(its scale), so the
      // elastic energy is below Σ ½ l̂ |C_F| (k u σ_scale)² + …, 2·D_v below
      // Σ l̂ |V_F| (k u σ̇_scale)² + … (quadratic in round-off).
      double elastic_bound = 0, dissipation_bound = 0;
      for (int e = 0; e < n; ++e) {
        elastic_bound += 0.5 * rod.l0[e] * rod.CF[e].maxCoeff() * std::pow(kK * kU * ev.sigma_scale[e], 2);
        dissipation_bound += rod.l0[e] * rod.CF[e].cwiseProduct(rod.tauF[e]).maxCoeff() *
                             std::pow(kK * kU * ev.sigma_rate_scale[e], 2);
      }
      for (int j = 0; j + 1 < n; ++j) {
        elastic_bound += 0.5 * rod.D[j] * rod.CM[j].maxCoeff() * std::pow(kK * kU * ev.kappa_scale[j], 2);
        dissipation_bound += rod.D[j] * rod.CM[j].cwiseProduct(rod.tauM[j]).maxCoeff() *
                             std::pow(kK * kU * ev.kappa_rate_scale[j], 2);
      }
      if (rod.clamped) {
        elastic_bound +=
            0.5 * rod.D_root * rod.CM_root.maxCoeff() * std::pow(kK * kU * ev.root_kappa_scale, 2);
        dissipation_bound += rod.D_root * rod.CM_root.cwiseProduct(rod.tauM_root).maxCoeff() *
                             std::pow(kK * kU * ev.root_kappa_rate_scale, 2);
      }
      const Energies en = energies<kInternal>(b, r);
      EXPECT_LE(en.elastic, elastic_bound) << "rod " << r;
      EXPECT_LE(en.dissipation, dissipation_bound) << "rod " << r;
      EXPECT_GT(en.kinetic, 0);  // it does move
    }
    // The case is what it claims: relative rotations of about 1 rad, and the
    // plain difference would have failed by many orders of magnitude.
    EXPECT_GT(min_relative_rotation, 0.75);
    EXPECT_LT(max_relative_rotation, 1.3);
    EXPECT_GT(plain_over_tolerance, 1e10);

    // ... and the check can fail: 1 µm/s of non-rigid velocity on one node
    // gives viscous forces far above the tolerance.
    b.state.node_v[0][b.node_index(1, 5)] += 1e-6;
    const ForceArrays<double> g = batch_forces<kInternal>(b);
    const ref::Evaluation ev = ref::evaluate(extract_rod(b, 1), kInternal, true);
    EXPECT_GT((get3(g.force, b.node_index(1, 5))).norm(), 1e3 * kK * kU * ev.force_scale[5]);
  }
}

// ---- (b) orthonormal frames --------------------------------------------------

double orthonormality_error(const RodBatch<double>& b) {
  double worst = 0;
  for (int r = 0; r < b.rod_count(); ++r)
    for (int e = 0; e < b.elements(r); ++e) {
      const M3 q = get_frame(b, b.elem_index(r, e));
      worst = std::max(worst, (q * q.transpose() - M3::Identity()).cwiseAbs().maxCoeff());
    }
  return worst;
}

// A free curly rod tumbling at about 60 rad/s (10 turns in 1 s: the rigid
// velocity field of Ω about a point of the rod, with element angular
// velocities perturbed by up to ±15 rad/s), stepped 10,000
// times (the default step, Kelvin–Voigt on). Each drift multiplies Q by a
// Rodrigues rotation: ≈ 2u of non-orthonormality per entry per product,
// 2·10⁴ products. Rounding errors accumulating like a random walk give
// ≈ √(2·10⁴)·2u ≈ 3e-14; a systematic drift (an exp that is not orthogonal
// to round-off, e.g. inconsistent a, b coefficients) would give up to
// 2·10⁴·2u ≈ 4.4e-12 and fail the 1e-12 bound.
TEST(Properties, FramesStayOrthonormalWhileTumbling) {
  RodSpec s = curly_rod(12, 0.3, 0.4, 0.2, false, 5);
  Random rnd(6);
  const V3 Omega = 60 * rnd.unit();
  s.angular_velocities.clear();
  s.velocities.clear();
  const V3 c = Eigen::Map<const V3>(s.nodes[6].data());
  for (const Vec3& x : s.nodes) s.velocities.push_back(vec(Omega.cross(Eigen::Map<const V3>(x.data()) - c)));
  for (int e = 0; e < s.elements(); ++e) {
    const M3 q = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(s.frames[e].data());
    s.angular_velocities.push_back(vec(q * Omega + rnd.box(15.0)));
  }
  RodBatch<double> b = build_batch<double>({s});
  M3 q_prev = get_frame(b, b.elem_index(0, 0));
  double worst = 0, turned = 0;
  const double dt = 1e-4;
  for (int i = 1; i <= 10000; ++i) {
    step(b, dt);
    if (i % 100 == 0) {
      worst = std::max(worst, orthonormality_error(b));
      // element 0 turns by ≈ 0.6 rad per 100 steps (< π, so the angle of the
      // relative rotation is the angle turned)
      const M3 q = get_frame(b, b.elem_index(0, 0));
      turned += Eigen::AngleAxisd(q * q_prev.transpose()).angle();
      q_prev = q;
    }
  }
  std::printf("  max |Q Q^T - I| over 10,000 steps: %.3g; element 0 turned by %.1f rad\n", worst, turned);
  EXPECT_LT(worst, 1e-12);
  EXPECT_FALSE(find_non_finite(b).found);
  EXPECT_GT(turned, 30);  // it really tumbled (≈ 60 rad/s for 1 s)
}

// ---- (c) permutation ------------------------------------------------------------

std::vector<RodSpec> mixed_rods() {
  std::vector<RodSpec> specs = {
      curly_rod(5, 0.2, 0.3, 0.1, true, 11), curly_rod(9, 0.3, 0.25, 0.2, false, 12),
      curly_rod(17, 0.4, 0.2, 0.1, true, 13), curly_rod(3, 0.1, 0.5, 0.3, false, 14),
      curly_rod(30, 0.3, 0.1, 0.05, true, 15)};
  Random rnd(16);
  for (RodSpec& s : specs) {
    for (int j = 0; j <= s.elements(); ++j) s.velocities.push_back(vec(rnd.box(0.3)));
    for (int e = 0; e < s.elements(); ++e) s.angular_velocities.push_back(vec(rnd.box(3.0)));
    if (s.clamped_root) s.velocities[0] = {0, 0, 0};
  }
  return specs;
}

// Point forces and couples on every node and element (deterministic per rod).
template <class T>
void set_loads(RodBatch<T>& b, int r, int which_rod) {
  Random rnd(100 + which_rod);
  for (int j = 0; j <= b.elements(r); ++j) b.set_node_force(r, j, vec(rnd.box(0.01)));
  for (int e = 0; e < b.elements(r); ++e) b.set_element_couple(r, e, vec(rnd.box(1e-4)));
}

std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

// Every state entry of rod ra in a equals that of rod rb in b, bit for bit.
void expect_same_rod(const RodBatch<double>& a, int ra, const RodBatch<double>& b, int rb) {
  const int n = a.elements(ra);
  ASSERT_EQ(n, b.elements(rb));
  int differ = 0;
  for (int j = 0; j <= n; ++j)
    for (int d = 0; d < 3; ++d) {
      differ += bits(a.state.node_x[d][a.node_index(ra, j)]) != bits(b.state.node_x[d][b.node_index(rb, j)]);
      differ += bits(a.state.node_v[d][a.node_index(ra, j)]) != bits(b.state.node_v[d][b.node_index(rb, j)]);
    }
  for (int e = 0; e < n; ++e) {
    for (int i = 0; i < 9; ++i)
      differ += bits(a.state.elem_Q[i][a.elem_index(ra, e)]) != bits(b.state.elem_Q[i][b.elem_index(rb, e)]);
    for (int d = 0; d < 3; ++d)
      differ += bits(a.state.elem_w[d][a.elem_index(ra, e)]) != bits(b.state.elem_w[d][b.elem_index(rb, e)]);
  }
  EXPECT_EQ(differ, 0) << "rod " << ra << " vs rod " << rb << ": entries that differ";
}

template <Viscous kV>
void check_permutation() {
  const std::vector<RodSpec> specs = mixed_rods();
  const std::vector<int> perm = {2, 4, 0, 3, 1};  // batch b holds specs[perm[i]] at i
  std::vector<RodSpec> permuted;
  for (int p : perm) permuted.push_back(specs[p]);
  RodBatch<double> a = build_batch<double>(specs, {0.3, -9.81, 0.1});
  RodBatch<double> b = build_batch<double>(permuted, {0.3, -9.81, 0.1});
  // the rods really sit at different slot offsets (and SIMD lanes) in the two batches
  int moved = 0;
  for (int i = 0; i < b.rod_count(); ++i) moved += (b.rods[i].offset % 8) != (a.rods[perm[i]].offset % 8);
  EXPECT_GE(moved, 3);
  for (int r = 0; r < a.rod_count(); ++r) set_loads(a, r, r);
  for (int i = 0; i < b.rod_count(); ++i) set_loads(b, i, perm[i]);

  // generalized forces and energies of the initial state
  const ForceArrays<double> fa = batch_forces<kAllTerms>(a), fb = batch_forces<kAllTerms>(b);
  for (int i = 0; i < b.rod_count(); ++i) {
    const int r = perm[i];
    int differ = 0;
    for (int j = 0; j <= a.elements(r); ++j)
      for (int d = 0; d < 3; ++d)
        differ += bits(fa.force[d][a.node_index(r, j)]) != bits(fb.force[d][b.node_index(i, j)]);
    for (int e = 0; e < a.elements(r); ++e)
      for (int d = 0; d < 3; ++d)
        differ += bits(fa.couple[d][a.elem_index(r, e)]) != bits(fb.couple[d][b.elem_index(i, e)]);
    EXPECT_EQ(differ, 0) << "generalized forces of rod " << r;
    const Energies ea = energies(a, r), eb = energies(b, i);
    EXPECT_EQ(bits(ea.kinetic), bits(eb.kinetic));
    EXPECT_EQ(bits(ea.elastic), bits(eb.elastic));
    EXPECT_EQ(bits(ea.potential), bits(eb.potential));
    EXPECT_EQ(bits(ea.dissipation), bits(eb.dissipation));
  }
  // 100 steps of 1e-6 s: inside the explicit viscous limit of these rods
  // (2/(τS ω_max²) ≈ 2.5e-6 s for the shear/rotary mode of an element)
  for (int s = 0; s < 100; ++s) {
    step<kAllTerms, kV>(a, 1e-6);
    step<kAllTerms, kV>(b, 1e-6);
  }
  ASSERT_FALSE(find_non_finite(a).found);
  for (int i = 0; i < b.rod_count(); ++i) expect_same_rod(a, perm[i], b, i);
  // and the rods moved, so equality is not that of two untouched copies
  EXPECT_NE(a.position(2, 10)[0], specs[2].nodes[10][0]);
}

TEST(Properties, PermutingRodsPermutesResultsImplicitViscous) { check_permutation<Viscous::implicit>(); }
TEST(Properties, PermutingRodsPermutesResultsExplicitViscous) { check_permutation<Viscous::explicit_rate>(); }

// ---- (d) thread count ----------------------------------------------------------

// state_hash (include/manyrods/batch.h): FNV-1a over every real state entry.
// `copies` of the mixed rods: 4 make one segment, stepped on one thread
// whatever the thread count; 60 make three, the first and last stepped one
// per thread, then the middle one (host/core/step/schedule.h
// for_each_segment).
template <Viscous kV>
void check_threads(int copies, std::size_t segments) {
  std::vector<RodSpec> specs;
  for (int copy = 0; copy < copies; ++copy)
    for (const RodSpec& s : mixed_rods()) specs.push_back(s);
  RodBatch<double> one = build_batch<double>(specs, {0.3, -9.81, 0.1});
  ASSERT_GT(one.slots(), 4 * kGuard);  // several blocks, so two threads really split the work
  ASSERT_EQ(one.segments.size(), segments);
  for (int r = 0; r < one.rod_count(); ++r) set_loads(one, r, r);
  RodBatch<double> two = one;
  const std::uint64_t h0 = state_hash(one);
  for (int s = 0; s < 200; ++s) {
    step<kAllTerms, kV>(one, 1e-6, Exec{1});
    step<kAllTerms, kV>(two, 1e-6, Exec{2});
  }
  const std::uint64_t h1 = state_hash(one), h2 = state_hash(two);
  std::printf("  %zu segment(s), state hash after 200 steps: 1 thread %016llx, 2 threads %016llx\n", segments,
              static_cast<unsigned long long>(h1), static_cast<unsigned long long>(h2));
  EXPECT_EQ(h1, h2);
  EXPECT_NE(h1, h0);  // the state changed
  // The hash sees a one-ulp change of one entry.
  two.state.elem_w[1][two.elem_index(7, 3)] = std::nextafter(two.state.elem_w[1][two.elem_index(7, 3)], 1e9);
  EXPECT_NE(state_hash(two), h1);
}

TEST(Properties, ThreadCountDoesNotChangeResultImplicitViscous) {
  check_threads<Viscous::implicit>(4, 1);
  check_threads<Viscous::implicit>(60, 3);
}
TEST(Properties, ThreadCountDoesNotChangeResultExplicitViscous) {
  check_threads<Viscous::explicit_rate>(4, 1);
  check_threads<Viscous::explicit_rate>(60, 3);
}

// Float steps flush subnormals to zero on every thread of the step
// (Exec::flush_subnormals, the default); afterwards the calling thread and
// the pool's threads compute subnormals again (the pool's threads start in
// the first step here, so they are born in its mode). 400 straight cantilevers along z in the plane y = 0 (several
// segments, so both threads step rods), every node moving at 1e-36 m/s
// along y: each drift adds ½h·v ≈ 5e-42 m to y = 0, a subnormal. Flushed,
// every y stays exactly 0 on every rod, whichever thread stepped it; with
// IEEE underflow the y's become subnormal, not 0.
TEST(Properties, FloatStepFlushesSubnormalsOnEveryThread) {
  std::vector<RodSpec> specs(400, cases::seed_cantilever(20));
  RodBatch<float> start = build_batch<float>(specs, {0, 0, 0});
  ASSERT_GT(start.segments.size(), 2u);  // the segments are shared out between threads
  for (int r = 0; r < start.rod_count(); ++r)
    for (int j = 1; j <= start.elements(r); ++j) start.set_velocity(r, j, {0, 1e-36, 0});
  const float dt = 1e-5f;
  auto run = [&](int threads, bool flush) {
    RodBatch<float> b = start;
    step_n(b, dt, 20, Exec{threads, nullptr, flush});
    return b;
  };
  auto y_range = [](const RodBatch<float>& b) {
    double lo = 1, hi = 0;  // smallest and largest |y| over the nodes off the root
    for (int r = 0; r < b.rod_count(); ++r)
      for (int j = 1; j <= b.elements(r); ++j) {
        const double y = std::abs(b.position(r, j)[1]);
        lo = std::min(lo, y);
        hi = std::max(hi, y);
      }
    return std::pair{lo, hi};
  };
  for (int threads : {1, 2}) {
    const RodBatch<float> flushed = run(threads, true), ieee = run(threads, false);
    const auto [flo, fhi] = y_range(flushed);
    const auto [ilo, ihi] = y_range(ieee);
    std::printf("  %d thread(s): |y| in [%g, %g] flushed, [%g, %g] IEEE\n", threads, flo, fhi, ilo, ihi);
    EXPECT_EQ(fhi, 0.0) << threads << " thread(s): a subnormal survived the flush";
    EXPECT_GT(ilo, 0.0) << threads << " thread(s): IEEE underflow should keep the subnormal y's";
    EXPECT_LT(ihi, double(std::numeric_limits<float>::min()));
  }
  EXPECT_EQ(state_hash(run(1, true)), state_hash(run(2, true)));
  // Afterwards this thread and the pool's threads compute subnormals again.
  volatile float tiny = 1e-30f;
  int subnormal_lost = 0;
#pragma omp parallel num_threads(2) reduction(+ : subnormal_lost)
  subnormal_lost += tiny * 1e-10f == 0.0f ? 1 : 0;
  EXPECT_EQ(subnormal_lost, 0);
  EXPECT_GT(tiny * 1e-10f, 0.0f);
}

// ---- (e) free fall (2d) -------------------------------------------------------

// A free curly rod (rest shape = initial shape) thrown with a uniform
// velocity v0 under gravity g falls rigidly: x_j(t) = x_j(0) + v0 t + ½ g t²,
// v_j = v0 + g t, frames unchanged, for 1000 steps of 1e-4 s.
//
// Position Verlet is exact for constant acceleration (x += ½h v; v += h g;
// x += ½h v gives x + h v + ½h² g), so only round-off remains:
//  * the updates themselves: each of the 2N drifts and N kicks rounds once,
//    at most N_ops·u·max|x| and N·u·max|v| accumulated (N = 1000);
//  * the rest strain evaluates to round-off, not zero (σ = Qe/l̂ − V0 with
//    e = x_{j+1} − x_j computed from positions of size |x|: ≈ u|x|/l̂), so
//    round-off-sized elastic forces act. The rod is a stable elastic system:
//    it responds with a static displacement ≈ strain·l̂ ≈ u·|x| and velocity
//    ≈ ω_max·u·|x|, with ω_max ≈ 2/h at most for a stable step.
// Hence |x − exact| ≤ 3N·u·max|x|, |v − exact| ≤ N·u·max|v| + (2/h)·u·max|x|,
// frames |Q − Q0| ≤ N·u·max|x|/l̂, and the shape (x_j − x_0) is preserved
// to the position bound. These are worst-case (linear) accumulations, so no
// extra factor k is applied; measured errors are about 0.1 of them (printed).
TEST(Properties, FreeFallIsRigid) {
  RodSpec s = curly_rod(10, 0.3, 0.6, 0.3, false, 21);
  const V3 v0(0.8, 2.5, -0.4), g(0.2, -9.81, 0.5);
  s.velocities.assign(s.elements() + 1, vec(v0));
  RodBatch<double> b = build_batch<double>({s}, vec(g));
  const int n = s.elements();
  const double h = 1e-4;
  const int N = 1000;
  std::vector<V3> x0(n + 1);
  std::vector<M3> q0(n);
  for (int j = 0; j <= n; ++j) x0[j] = get3(b.state.node_x, b.node_index(0, j));
  for (int e = 0; e < n; ++e) q0[e] = get_frame(b, b.elem_index(0, e));
  double max_x = 0, max_v = 0;
  double worst_x = 0, worst_v = 0, worst_shape = 0, worst_q = 0;  // in units of their bounds
  const double l = 0.3 / n;
  for (int i = 1; i <= N; ++i) {
    step(b, h);
    const double t = i * h;
    for (int j = 0; j <= n; ++j) {
      const V3 x = get3(b.state.node_x, b.node_index(0, j)), v = get3(b.state.node_v, b.node_index(0, j));
      max_x = std::max(max_x, x.norm());
      max_v = std::max(max_v, v.norm());
      const double bx = 3 * i * kU * max_x, bv = i * kU * max_v + 2 / h * kU * max_x;
      worst_x = std::max(worst_x, (x - (x0[j] + v0 * t + 0.5 * g * t * t)).cwiseAbs().maxCoeff() / bx);
      worst_v = std::max(worst_v, (v - (v0 + g * t)).cwiseAbs().maxCoeff() / bv);
      const V3 shape = x - get3(b.state.node_x, b.node_index(0, 0)), shape0 = x0[j] - x0[0];
      worst_shape = std::max(worst_shape, (shape - shape0).cwiseAbs().maxCoeff() / bx);
    }
    for (int e = 0; e < n; ++e)
      worst_q = std::max(
          worst_q, (get_frame(b, b.elem_index(0, e)) - q0[e]).cwiseAbs().maxCoeff() / (i * kU * max_x / l));
  }
  std::printf("  free fall, error / bound: x %.3g, v %.3g, shape %.3g, frames %.3g\n", worst_x, worst_v,
              worst_shape, worst_q);
  EXPECT_LE(worst_x, 1);
  EXPECT_LE(worst_v, 1);
  EXPECT_LE(worst_shape, 1);
  EXPECT_LE(worst_q, 1);
  // It fell: 1000 steps moved it by |v0 t + ½ g t²| ≈ 0.2 m.
  EXPECT_GT((get3(b.state.node_x, b.node_index(0, 0)) - x0[0]).norm(), 0.1);
}

}  // namespace
