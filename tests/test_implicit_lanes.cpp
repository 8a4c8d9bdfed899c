// The rod-per-lane implicit viscous solve (kernels/viscous_implicit_lanes.h)
// against the scalar one (kernels/viscous_implicit.h viscous_implicit_rod),
// the reference it must reproduce to round-off:
//   * kernel against kernel on random curved, moving rods: clamped and free
//     roots, stiff rods (stiff_h = h), an undamped lane (τ = 0), joints that
//     turn by more than the small-rotation range (the general-path fallback),
//     lanes of equal and of different lengths, in float and double, with and
//     without the Kelvin–Voigt term; and a rod's result is the same bit for
//     bit whatever group (lengths, other rods, copies of itself) it is in;
//   * a batch of mixed lengths (equal-length groups, mixed-length groups,
//     a last group filled with copies, undamped rods, a rod longer than a
//     segment: the partitioned solve) stepped with step_n
//     against the same stages with the scalar solve, step by step; and
//     step_n on 1 and 2 threads bit for bit;
//   * a batch of one segment, whose solve shares its groups (or their
//     halves) over the threads: 1, 2 and 3 threads bit for bit.
//
// Round-off bound (the reasoning of tests/reference.h "Round-off scales"):
// both kernels solve A u = b, A = M + hD symmetric positive definite (fixed
// unknowns: identity rows), by block elimination with Cholesky factors. Each
// computed solution is the exact solution of (A + ΔA) û = b + Δb with
// |ΔA_ij| ≤ k·u·d_i·d_j, d_i = √A_ii, and |Δb| ≤ k·u·|b|: the assembly terms
// are Σ_l x_li w_l y_lj with w ≥ 0, bounded by √(A_ii A_jj) (Cauchy–Schwarz),
// and so are the entries of the Cholesky factors' |L||Lᵀ| (Higham, Accuracy
// and Stability of Numerical Algorithms, §10.1). To first order
//   |û − u| ≤ k·u·s,  s = |A⁻¹| (d dᵀ|u| + |b| + |A − M||u⁻|),
// and the two kernels differ by at most twice that. The last term is the
// delta form's (kernels/viscous_implicit.h: the right-hand side is
// −hD u⁻ = −(A − M)u⁻, computed with |Δb| ≤ k·u·|A − M||u⁻|, and u⁺ = u⁻ + Δu
// rounds once more, within |b|'s share); stiff lanes solve A u⁺ = M u⁻
// directly, for which the term only adds slack. k counts the roundings
// along the longest path of one kernel: assembly ≤ 8 (3-factor products, 3-term
// sums, ≤ 4 contributions and the mass), elimination 7 (6-term sums),
// Cholesky 7, the two triangular solves 14, back substitution 7: 43; the
// difference of two kernels: 2·43 ≈ 90, and the limit is k = 100. s is
// computed here from the dense A (Eigen, double) of each rod.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "check.h"
#include "implicit_rods.h"
#include "host/core/advanced.h"

using namespace manyrods;
using namespace manyrods::testing;

namespace {

constexpr double kLimit = 100;  // see the header
constexpr Terms kNoKV{true, true, true, true, false, true, true};

// W random rods: lane 0 clamped, lane 1 free, lane 2 undamped, lane 3 stiff,
// lane 4 with joints up to 2.5 rad (general path), lanes 2 and 5 with a
// clamped tip, the others random (clamped or not, stiff or not, turns up to 0.4 rad). Lane l has elements[l] elements.
std::vector<RodSpec> lane_rods(std::mt19937& rng, int W, const std::vector<int>& elements) {
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<RodSpec> rods;
  for (int l = 0; l < W; ++l) {
    const bool clamped = l == 0 || (l > 4 && u(rng) < 0.5);
    const bool stiff = l == 3 || (l > 4 && u(rng) < 0.3);
    const double tau = l == 2 ? 0 : std::pow(10.0, -3 + 2 * u(rng));  // 1e-3 … 0.1 s
    const double turn = l == 4 ? 2.5 : 0.4;
    rods.push_back(random_rod(rng, elements[l], l == 1 ? false : clamped, tau, stiff, turn));
    rods.back().clamped_tip = l == 5 || l == 2;  // held at the tip only (2) or maybe at both ends (5)
  }
  return rods;
}

// The lanes kernel on batch b, always through this one compiled copy: two
// inlined copies may contract a·b + c into FMAs differently (the library's
// implicit stage, host/core/step/implicit_solve.h, calls it from one place too).
template <Terms kT, int W, class T>
__attribute__((noinline)) void lanes_solve(RodBatch<T>& b, const int* first, const int* cells, T h,
                                           const T* stiff_h) {
  viscous_implicit_lanes<kT, W>(first, cells, h, stiff_h, b.model_view(), b.state_view(),
                                b.implicit_scratch_view(0, 0));
}

// `mixed`: lanes of 3 different lengths (elements, elements − 2,
// elements − 5), else all `elements` long.
template <Terms kT, class T, int W>
void kernel_vs_scalar(unsigned seed, int elements, double h, bool mixed = false) {
  std::mt19937 rng(seed);
  std::vector<int> n(W, elements);
  if (mixed)
    for (int l = 0; l < W; ++l) n[l] = elements - (l % 3 == 1 ? 2 : l % 3 == 2 ? 5 : 0);
  RodBatch<T> b = build_batch<T>(lane_rods(rng, W, n));
  RodBatch<T> scalar = b, lanes = b;
  scalar.reserve_implicit_scratch(1);
  // the kernel needs W·(cells + 1) cells (stiff and other rods sit in
  // separate segments, so a segment's worth may be less)
  lanes.reserve_implicit_scratch(1, W * (elements + 2));
  int first[W], cells[W];
  T stiff_h[W];
  for (int l = 0; l < W; ++l) {
    first[l] = b.rods[l].offset + 1;
    cells[l] = n[l] + 1;
    stiff_h[l] = b.rods[l].stiff_implicit ? T(h) : T(0);
    viscous_implicit_rod<kT>(first[l], cells[l], T(h), stiff_h[l], scalar.model_view(), scalar.state_view(),
                             scalar.implicit_scratch_view(0, 0));
  }
  lanes_solve<kT, W>(lanes, first, cells, T(h), stiff_h);
  Checker ck(std::string(sizeof(T) == 4 ? "float" : "double") + " W=" + std::to_string(W) +
                 (kT.kelvin_voigt ? " KV" : " stiff only") + (mixed ? " mixed" : "") + " h=" + std::to_string(h),
             unit_roundoff<T>(), kLimit);
  double moved = 0;  // the solve must do something: u⁺ ≠ u⁻ on damped lanes
  for (int l = 0; l < W; ++l) {
    compare_rod(ck, lanes, scalar, l, solve_scale<kT>(b, l, T(h), stiff_h[l]), "lane " + std::to_string(l));
    for (int c = 0; c < cells[l]; ++c)
      moved = std::max(moved, std::abs(double(scalar.state.node_v[0][first[l] + c]) -
                                       double(b.state.node_v[0][first[l] + c])));
  }
  EXPECT_GT(moved, 1e-4);
  // the undamped, non-stiff lane (lane 2) with the Kelvin–Voigt term: A = M,
  // u⁺ = u⁻ up to the roundings of M u⁻ and of the Cholesky solve (≤ 6)
  if (!b.rods[2].stiff_implicit)
    for (int c = 0; c < n[2]; ++c) {
      const int k = first[2] + c;
      EXPECT_NEAR(double(lanes.state.elem_w[0][k]), double(b.state.elem_w[0][k]),
                  8 * unit_roundoff<T>() * std::abs(double(b.state.elem_w[0][k])) + 1e-30);
    }
  // a rod's result does not depend on its group: rod 4 (and rod 1, shorter
  // in a mixed group) alone in every lane (copies), bit for bit
  for (int r : {1, 4}) {
    RodBatch<T> alone = b;
    alone.reserve_implicit_scratch(1, W * (elements + 2));
    int f1[W], c1[W];
    T h1[W];
    for (int l = 0; l < W; ++l) f1[l] = first[r], c1[l] = cells[r], h1[l] = stiff_h[r];
    lanes_solve<kT, W>(alone, f1, c1, T(h), h1);
    for (int c = 0; c < cells[r]; ++c)
      for (int d = 0; d < 3; ++d) {
        const int k = first[r] + c;
        ASSERT_EQ(alone.state.node_v[d][k], lanes.state.node_v[d][k]) << "rod " << r << " cell " << c;
        ASSERT_EQ(alone.state.elem_w[d][k], lanes.state.elem_w[d][k]) << "rod " << r << " cell " << c;
      }
  }
}

}  // namespace

TEST(ImplicitLanes, KernelMatchesScalarDouble) {
  for (unsigned seed = 1; seed <= 4; ++seed)
    for (double h : {1e-5, 1e-3}) {
      kernel_vs_scalar<kAllTerms, double, 8>(seed, 9, h);
      kernel_vs_scalar<kAllTerms, double, 16>(seed + 10, 6, h);
      kernel_vs_scalar<kAllTerms, double, 8>(seed + 20, 11, h, true);
    }
  kernel_vs_scalar<kNoKV, double, 8>(31, 12, 1e-4);  // stiff rods only (Kelvin–Voigt explicit or off)
  kernel_vs_scalar<kNoKV, double, 8>(32, 12, 1e-4, true);
}

TEST(ImplicitLanes, KernelMatchesScalarFloat) {
  for (unsigned seed = 1; seed <= 4; ++seed)
    for (double h : {1e-5, 1e-3}) {
      kernel_vs_scalar<kAllTerms, float, 16>(seed, 9, h);
      kernel_vs_scalar<kAllTerms, float, 8>(seed + 10, 6, h);
      kernel_vs_scalar<kAllTerms, float, 16>(seed + 20, 11, h, true);
    }
  kernel_vs_scalar<kNoKV, float, 16>(31, 12, 1e-4);
  kernel_vs_scalar<kNoKV, float, 16>(32, 12, 1e-4, true);
}

namespace {

// Prescribed velocities (a driven hold besides the reference one, whose
// value the solve must keep: kernels/viscous_implicit_lanes.h kLift).
// W random rods (lane_rods) with interior holds (clamped: the node and both
// elements' frames; pinned: the node) besides their held roots and tips;
// every fixed unknown of lanes 0 … W−2 gets a random non-zero value, as
// driven holds have (the root ghost's clamp frame stays at rest: the solve
// runs relative to a driven root's motion, which leaves it at rest). The
// reference is the dense system with those values moved to the right-hand
// side by Eigen in double (rod_system with `prescribed`: independent of the
// kernels' lifting), solved by LU. Against it, within the header's
// round-off bound (the scale with the lifted couplings): the lane kernel
// with kLift at W lanes and at 1 lane, and the scalar kernel (delta form for
// rods that are not stiff, direct form for stiff ones). The fixed unknowns
// keep their values exactly (identity rows: no rounding touches them).
// Lane W−1's fixed unknowns stay at rest (the case of every rod without
// prescribed velocities).
template <Terms kT, class T, int W>
void prescribed_vs_dense(unsigned seed, int elements, double h) {
  std::mt19937 rng(seed);
  std::vector<RodSpec> specs = lane_rods(rng, W, std::vector<int>(W, elements));
  for (int l = 0; l < W; ++l) {
    if (l % 3 != 2) specs[l].holds.push_back({elements / 2, l % 2 ? HoldKind::clamped : HoldKind::pinned, nullptr});
    if (l % 4 == 1) specs[l].holds.push_back({elements / 2 + 2, HoldKind::pinned, nullptr});
  }
  RodBatch<T> b = build_batch<T>(specs);
  std::uniform_real_distribution<double> u(-1, 1);
  const int cells = elements + 1;
  int fixed_count = 0;
  for (int l = 0; l + 1 < W; ++l)
    for (int c = 0; c < cells; ++c) {
      const int k = b.rods[l].offset + 1 + c;
      for (int d = 0; d < 3; ++d) {
        if (b.model.node_inv_mass[k] == T(0)) b.state.node_v[d][k] = T(0.1 * u(rng)), ++fixed_count;
        if (b.model.elem_inv_inertia[d][k] == T(0)) b.state.elem_w[d][k] = T(2 * u(rng)), ++fixed_count;
      }
    }
  ASSERT_GT(fixed_count, 3 * W);
  int first[W], n[W];
  T stiff_h[W];
  for (int l = 0; l < W; ++l) {
    first[l] = b.rods[l].offset + 1;
    n[l] = cells;
    stiff_h[l] = b.rods[l].stiff_implicit ? T(h) : T(0);
  }
  auto prepared = [&]() {
    RodBatch<T> x = b;
    x.reserve_implicit_scratch(1, W * (elements + 2));
    return x;
  };
  RodBatch<T> lanes = prepared(), one = prepared(), scalar = prepared();
  viscous_implicit_lanes<kT, W, false, true>(first, n, T(h), stiff_h, lanes.model_view(), lanes.state_view(),
                                             lanes.implicit_scratch_view(0, 0));
  for (int l = 0; l < W; ++l) {
    viscous_implicit_lanes<kT, 1, false, true>(first + l, n + l, T(h), stiff_h + l, one.model_view(),
                                               one.state_view(), one.implicit_scratch_view(0, 0));
    viscous_implicit_rod<kT>(first[l], cells, T(h), stiff_h[l], scalar.model_view(), scalar.state_view(),
                             scalar.implicit_scratch_view(0, 0));
  }
  const std::string tag = std::string(sizeof(T) == 4 ? "float" : "double") + " W=" + std::to_string(W) +
                          (kT.kelvin_voigt ? " KV" : " stiff only") + " h=" + std::to_string(h);
  Checker ck_lanes("prescribed lanes " + tag, unit_roundoff<T>(), kLimit);
  Checker ck_one("prescribed 1 lane " + tag, unit_roundoff<T>(), kLimit);
  Checker ck_scalar("prescribed scalar " + tag, unit_roundoff<T>(), kLimit);
  for (int l = 0; l < W; ++l) {
    const RodSystem sys = rod_system<kT>(b, l, T(h), stiff_h[l], true);
    const Eigen::VectorXd want = Eigen::MatrixXd(sys.A).partialPivLu().solve(sys.rhs);
    const Eigen::VectorXd scale = solve_scale<kT>(b, l, T(h), stiff_h[l], true);
    const Eigen::VectorXd got[3] = {rod_velocities(lanes, l), rod_velocities(one, l), rod_velocities(scalar, l)};
    Checker* ck[3] = {&ck_lanes, &ck_one, &ck_scalar};
    for (int i = 0; i < 6 * cells; ++i) {
      const int c = i / 6;
      for (int v = 0; v < 3; ++v)
        ck[v]->num(got[v](i), want(i), scale(i), where("cell", l, c) + " unknown " + std::to_string(i % 6));
      const int k = first[l] + c;
      const T minv = i % 6 < 3 ? b.model.node_inv_mass[k] : b.model.elem_inv_inertia[i % 6 - 3][k];
      if (minv == T(0)) {
        for (int v = 0; v < 3; ++v)
          EXPECT_EQ(got[v](i), sys.uminus(i)) << "a fixed unknown keeps its value: lane " << l << " unknown " << i;
      }
    }
  }
}

}  // namespace

TEST(ImplicitLanes, PrescribedVelocitiesMatchTheDenseSolveDouble) {
  for (unsigned seed = 1; seed <= 3; ++seed)
    for (double h : {1e-5, 1e-3}) prescribed_vs_dense<kAllTerms, double, 8>(seed + 40, 10, h);
  prescribed_vs_dense<kNoKV, double, 8>(51, 12, 1e-4);  // stiff rods only
}

TEST(ImplicitLanes, PrescribedVelocitiesMatchTheDenseSolveFloat) {
  for (unsigned seed = 1; seed <= 3; ++seed)
    for (double h : {1e-5, 1e-3}) prescribed_vs_dense<kAllTerms, float, 16>(seed + 60, 10, h);
}

namespace {

// A batch of mixed lengths: groups and remainders of several element counts,
// interleaved, undamped rods (no solve), stiff rods, and one rod longer than a
// segment (a segment of its own).
std::vector<RodSpec> mixed_rods(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<RodSpec> rods;
  // {elements, rods}; 140 elements: too long for 16 float lanes in a
  // segment's buffer, 8 lanes (the half-width kernel) run them
  const int counts[][2] = {{12, 37}, {7, 21}, {30, 9}, {12, 5}, {3, 18}, {7, 4}, {140, 3}};
  for (const auto& [n, count] : counts)
    for (int i = 0; i < count; ++i) {
      const double tau = u(rng) < 0.1 ? 0 : std::pow(10.0, -3 + 2 * u(rng));
      rods.push_back(random_rod(rng, n, u(rng) < 0.7, tau, u(rng) < 0.2, 0.3));
      rods.back().clamped_tip = i % 3 == 1;  // some held at both ends
    }
  rods.push_back(random_rod(rng, kSegmentSlots + 50, true, 0.02, false, 0.02));
  return rods;
}

// One step: `lanes` by step_n (rod-per-lane solve where the groups allow),
// against the same stages with the scalar solve on a copy taken before the
// step (step_n, host/core/step/integrators.h); velocities to the round-off bound of the header,
// positions and frames to what that difference moves them in the last drift.
template <class T>
void step_matches_scalar(RodBatch<T>& lanes, T dt, int threads, Checker& ck_u, Checker& ck_x, int step_no) {
  constexpr Terms kExplicit{true, true, true, true, false, true, true};
  const Exec ex{threads};
  RodBatch<T> scalar = lanes;
  step_n<kAllTerms>(lanes, dt, 1, ex);
  drift(scalar, T(0.5) * dt, ex);
  for (const Segment& sg : scalar.segments) {  // as step_n (stiff segments: the bending correction)
    compute_resultants<kExplicit>(scalar, ex, sg, T(-kStiffBendingC) * dt);
    segment_kick<kExplicit>(scalar, dt, ex, sg);
  }
  const RodBatch<T> before = scalar;  // u⁻ at the frozen geometry
  viscous_update<kAllTerms, 1>(scalar, dt, ex);
  drift(scalar, T(0.5) * dt, ex);
  for (int r = 0; r < lanes.rod_count(); ++r) {
    const RodInfo& rod = lanes.rods[r];
    const std::string tag = "step " + std::to_string(step_no);
    if (rod.elements > kSegmentSlots) {
      // alone in its segment: the partitioned solve (tests/test_implicit_partitioned.cpp
      // has its bound); too long for the dense scale, so its residual, and the
      // last drift x = x⁻ + ½h v⁺ (one rounding of the sum and one of the product)
      const int k = kPartitionCells;
      const Eigen::VectorXd u = rod_velocities(lanes, r);
      Checker ck(tag + " long rod residual", unit_roundoff<T>(), 18.0 * k + 45);
      check_residual<T>(ck, rod_system<kAllTerms>(before, r, dt, T(0)), u, k + 1, "long rod");
      for (int j = 0; j <= rod.elements; ++j)
        for (int d = 0; d < 3; ++d) {
          const int at = lanes.node_index(r, j);
          const double x0 = double(before.state.node_x[d][at]) + 0.5 * double(dt) * u(6 * j + d);
          ck_x.num(lanes.state.node_x[d][at], x0, 2 * std::abs(x0) / kLimit + 1e-300, tag + " " + where("x of node", r, j));
        }
      continue;
    }
    const bool solved = rod.stiff_implicit || rod.damped;
    const Eigen::VectorXd s = solved ? solve_scale<kAllTerms>(before, r, dt, rod.stiff_implicit ? dt : T(0))
                                     : Eigen::VectorXd::Zero(6 * (rod.elements + 1));
    compare_rod(ck_u, lanes, scalar, r, s, tag);
    // last drift: x += ½h v, Q ← exp(−½h ω) Q: the velocity difference moved
    // by ½h, plus one rounding of the sums (2u·|x|, 8u per frame entry)
    for (int c = 0; c <= rod.elements; ++c) {
      const int k = rod.offset + 1 + c;
      const double sv = std::max({s(6 * c), s(6 * c + 1), s(6 * c + 2)});
      const double sw = std::max({s(6 * c + 3), s(6 * c + 4), s(6 * c + 5)});
      for (int d = 0; d < 3; ++d) {
        const double x = std::abs(double(scalar.state.node_x[d][k]));
        ck_x.num(lanes.state.node_x[d][k], scalar.state.node_x[d][k], 0.5 * double(dt) * sv + 2 * x / kLimit,
                 tag + " " + where("x of node", r, c));
      }
      if (c < rod.elements)
        for (int i = 0; i < 9; ++i)
          ck_x.num(lanes.state.elem_Q[i][k], scalar.state.elem_Q[i][k], 0.5 * double(dt) * sw + 8 / kLimit,
                   tag + " " + where("Q of element", r, c));
    }
  }
}

template <class T>
bool same_state(const RodBatch<T>& a, const RodBatch<T>& b) {
  auto eq = [](const Array<T>& x, const Array<T>& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), sizeof(T) * x.size()) == 0;
  };
  for (int d = 0; d < 3; ++d)
    if (!eq(a.state.node_x[d], b.state.node_x[d]) || !eq(a.state.node_v[d], b.state.node_v[d]) ||
        !eq(a.state.elem_w[d], b.state.elem_w[d]))
      return false;
  for (int i = 0; i < 9; ++i)
    if (!eq(a.state.elem_Q[i], b.state.elem_Q[i])) return false;
  return true;
}

template <class T>
void mixed_batch() {
  RodBatch<T> b = build_batch<T>(mixed_rods(7), {0, 0, -9.81});
  const T dt = T(0.5 * stable_dt(b).elastic);
  const std::string name = sizeof(T) == 4 ? "float" : "double";
  Checker ck_u(name + " mixed batch, velocities", unit_roundoff<T>(), kLimit);
  Checker ck_x(name + " mixed batch, positions and frames", unit_roundoff<T>(), kLimit);
  for (int i = 0; i < 4; ++i) {
    RodBatch<T> two = b;
    step_matches_scalar(b, dt, 1, ck_u, ck_x, i);
    step_n<kAllTerms>(two, dt, 1, Exec{2});
    EXPECT_TRUE(same_state(b, two)) << "step " << i << ": 1 and 2 threads differ";
  }
}

}  // namespace

TEST(ImplicitLanes, MixedBatchStepMatchesScalarDouble) { mixed_batch<double>(); }
TEST(ImplicitLanes, MixedBatchStepMatchesScalarFloat) { mixed_batch<float>(); }

namespace {

// A batch of one segment (a calibration's generation, a small sweep): its
// stages run on one thread, its solve shares out its lane groups over the
// threads, and its plan cuts one or three full groups into halves for that
// (host/core/step/implicit_plan.h plan_segment). `count` rods of 20
// elements, damped, clamped or free; stiff ones in a float batch (their
// solve in double, kImplicitLanes<double> lanes at a time). 20 steps on 1, 2
// and 3 threads give the same state bit for bit (a regression reference:
// exact).
template <class T>
void small_batch_on_threads(int count, bool stiff) {
  std::mt19937 rng(40 + unsigned(count));
  std::vector<RodSpec> specs;
  for (int i = 0; i < count; ++i) specs.push_back(random_rod(rng, 20, i % 4 != 3, 2e-3, stiff, 0.3));
  const RodBatch<T> b0 = build_batch<T>(specs, {0, 0, -9.81});
  ASSERT_EQ(b0.segments.size(), 1u);
  // (stiff rods have no elastic step limit: their stable_dt is unbounded)
  const T dt = T(stiff ? 1e-4 : 0.5 * stable_dt(b0).elastic);
  std::uint64_t one = 0;
  for (int threads : {1, 2, 3}) {
    RodBatch<T> b = b0;
    step_n<kAllTerms>(b, dt, 20, Exec{threads});
    ASSERT_TRUE(std::isfinite(double(b.state.node_x[2][b.node_index(0, 20)])));
    const std::uint64_t h = state_hash(b);
    if (threads == 1) one = h;
    EXPECT_EQ(h, one) << (sizeof(T) == 4 ? "float, " : "double, ") << count << " rods" << (stiff ? " (stiff)" : "")
                      << ": 1 and " << threads << " threads differ";
  }
}

}  // namespace

TEST(ImplicitLanes, ABatchOfOneSegmentIsBitIdenticalOnAnyThreadCount) {
  for (int count : {3, 8, 11, 13, 16, 24}) {
    small_batch_on_threads<double>(count, false);
    small_batch_on_threads<float>(count, false);
  }
  for (int count : {16, 24}) small_batch_on_threads<float>(count, true);
}
