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
//     segment: the scalar kernel) stepped with step_n
//     against the same stages with the scalar solve, step by step; and
//     step_n on 1 and 2 threads bit for bit.
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
#include "manyrods/advanced.h"

using namespace manyrods;
using namespace manyrods::testing;

namespace {

constexpr double kLimit = 100;  // see the header
constexpr Terms kNoKV{true, true, true, true, false, true, true};

template <class T>
constexpr double unit_roundoff() {
  return sizeof(T) == 4 ? 0x1p-24 : 0x1p-53;
}

// A rod along a random walk: element i turns from element i−1 by up to
// `max_turn` rad (bend) and twists by up to `max_turn` about its axis;
// random node velocities (≤ 0.1 m/s) and angular velocities (≤ 2 rad/s).
RodSpec random_rod(std::mt19937& rng, int n, bool clamped, double tau_s, bool stiff, double max_turn) {
  std::uniform_real_distribution<double> u(-1, 1), pos(0.8, 1.2);
  const double L = 0.3;
  std::vector<Vec3> nodes(n + 1);
  Eigen::Vector3d x(u(rng), u(rng), u(rng)), d(1, 0.2 * u(rng), 0.2 * u(rng));
  d.normalize();
  std::vector<Mat3> frames(n);
  Eigen::Vector3d d1 = d.unitOrthogonal();
  for (int i = 0; i <= n; ++i) {
    nodes[i] = {x.x(), x.y(), x.z()};
    if (i == n) break;
    if (i > 0) {  // turn d (and carry d1 along), then twist d1 about d
      Eigen::Vector3d axis = d.cross(Eigen::Vector3d(u(rng), u(rng), u(rng))).normalized();
      const Eigen::AngleAxisd bend(max_turn * std::abs(u(rng)), axis);
      d = (bend * d).normalized();
      d1 = bend * d1;
      d1 = (d1 - d1.dot(d) * d).normalized();
      d1 = Eigen::AngleAxisd(max_turn * u(rng), d) * d1;
    }
    const Eigen::Vector3d d2 = d.cross(d1);
    frames[i] = {d1.x(), d1.y(), d1.z(), d2.x(), d2.y(), d2.z(), d.x(), d.y(), d.z()};
    x += (L / n) * pos(rng) * d;
  }
  RodSpec s = RodSpec::polyline(nodes, frames);
  s.name = "random";
  s.section = Section::rectangle(0.01 * pos(rng), 0.01 * pos(rng));
  s.material = {1000 * pos(rng), 1e6 * std::pow(10.0, u(rng)), 0.3};
  // τE ≥ 0.87 τS keeps the bulk retardation time non-negative at ν = 0.3
  s.damping = tau_s > 0 ? Damping::shear_extension(tau_s, tau_s * (1.5 + 0.5 * u(rng))) : Damping::none();
  s.clamped_root = clamped;
  s.stiff_implicit = stiff;
  s.velocities.resize(n + 1);
  s.angular_velocities.resize(n);
  for (auto& v : s.velocities) v = {0.1 * u(rng), 0.1 * u(rng), 0.1 * u(rng)};
  for (auto& w : s.angular_velocities) w = {2 * u(rng), 2 * u(rng), 2 * u(rng)};
  return s;
}

// The dense system A u = b of rod `rod` exactly as viscous_implicit_rod
// builds it (same maps; in T, then to double), and its round-off scale
// s = |A⁻¹|(d dᵀ|u| + |b|) per unknown (6 per cell: v, ω).
template <Terms kT, class T>
Eigen::VectorXd solve_scale(const RodBatch<T>& b, int rod, T h, T stiff_h) {
  using namespace viscous_detail;
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> s = b.state_view();
  const int first = b.rods[rod].offset + 1, cells = b.rods[rod].elements + 1, N = 6 * cells;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(N, N);
  Eigen::VectorXd rhs(N), uminus(N), masses(N);
  struct Part {
    int at;
    mat3<T> map;
  };
  auto add = [&](const Part* parts, int count, vec3<T> w) {
    const double ww[3] = {double(w.x), double(w.y), double(w.z)};
    for (int p = 0; p < count; ++p)
      for (int q = 0; q < count; ++q)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) {
            double acc = 0;
            for (int l = 0; l < 3; ++l)
              acc += double(parts[p].map.m[3 * l + i]) * ww[l] * double(parts[q].map.m[3 * l + j]);
            A(parts[p].at + i, parts[q].at + j) += double(h) * acc;
          }
  };
  for (int c = 0; c < cells; ++c) {
    const int k = first + c;
    vec3<T> w;
    mat3<T> b1, b2, b3, c1, c2;
    element_maps<kT>(k, stiff_h, m, s, w, b1, b2, b3);
    if (c + 1 < cells) {  // the tip ghost element has no stiffness
      const Part e[3] = {{6 * c, b1}, {6 * c + 3, b2}, {6 * c + 6, b3}};
      add(e, 3, w);
      voronoi_maps<kT>(k + 1, stiff_h, m, s, w, c1, c2);
      const Part v[2] = {{6 * c + 3, c1}, {6 * c + 9, c2}};
      add(v, 2, w);
    }
    if (c == 0) {
      voronoi_maps<kT>(k, stiff_h, m, s, w, c1, c2);
      const Part v[1] = {{3, c2}};
      add(v, 1, w);
    }
    const double mass[6] = {double(m.node_mass[k]),       double(m.node_mass[k]),
                            double(m.node_mass[k]),       double(m.elem_inertia[0][k]),
                            double(m.elem_inertia[1][k]), double(m.elem_inertia[2][k])};
    const double u[6] = {double(s.node_v[0][k]), double(s.node_v[1][k]), double(s.node_v[2][k]),
                         double(s.elem_w[0][k]), double(s.elem_w[1][k]), double(s.elem_w[2][k])};
    for (int i = 0; i < 6; ++i) {
      uminus(6 * c + i) = u[i];
      masses(6 * c + i) = mass[i];
    }
    for (int i = 0; i < 6; ++i) {
      A(6 * c + i, 6 * c + i) += mass[i];
      rhs(6 * c + i) = mass[i] * u[i];
    }
  }
  Eigen::MatrixXd Avisc = A;  // A − M = hD
  Avisc.diagonal() -= masses;
  for (int c = 0; c < cells; ++c) {  // fixed unknowns: identity rows
    const int k = first + c;
    const T minv[6] = {m.node_inv_mass[k],       m.node_inv_mass[k],       m.node_inv_mass[k],
                       m.elem_inv_inertia[0][k], m.elem_inv_inertia[1][k], m.elem_inv_inertia[2][k]};
    for (int i = 0; i < 6; ++i)
      if (minv[i] == T(0)) {
        A.row(6 * c + i).setZero();
        A.col(6 * c + i).setZero();
        Avisc.row(6 * c + i).setZero();
        Avisc.col(6 * c + i).setZero();
        A(6 * c + i, 6 * c + i) = 1;
        rhs(6 * c + i) = 0;
      }
  }
  const Eigen::MatrixXd Ainv = A.inverse();
  const Eigen::VectorXd x = Ainv * rhs;
  const Eigen::VectorXd d = A.diagonal().cwiseSqrt();
  const double dx = d.dot(x.cwiseAbs());
  return Ainv.cwiseAbs() * (dx * d + rhs.cwiseAbs() + Avisc.cwiseAbs() * uminus.cwiseAbs());
}

// Compares the velocities of rod `rod` (cells c: node v, element ω) in `got`
// and `want` against k·u·scale.
template <class T>
void compare_rod(Checker& ck, const RodBatch<T>& got, const RodBatch<T>& want, int rod,
                 const Eigen::VectorXd& scale, const std::string& tag) {
  const int first = got.rods[rod].offset + 1, cells = got.rods[rod].elements + 1;
  for (int c = 0; c < cells; ++c) {
    const int k = first + c;
    for (int d = 0; d < 3; ++d) {
      ck.num(got.state.node_v[d][k], want.state.node_v[d][k], scale(6 * c + d),
             tag + " " + where("v of node", rod, c) + " dim " + std::to_string(d));
      ck.num(got.state.elem_w[d][k], want.state.elem_w[d][k], scale(6 * c + 3 + d),
             tag + " " + where("omega of cell", rod, c) + " dim " + std::to_string(d));
    }
  }
}

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
// implicit stage, host/implicit_solve.h, calls it from one place too).
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
// step (step_n, host/integrators.h); velocities to the round-off bound of the header,
// positions and frames to what that difference moves them in the last drift.
template <class T>
void step_matches_scalar(RodBatch<T>& lanes, T dt, int threads, Checker& ck_u, Checker& ck_x, int step_no) {
  constexpr Terms kExplicit{true, true, true, true, false, true, true};
  const Exec ex{threads};
  RodBatch<T> scalar = lanes;
  step_n<kAllTerms>(lanes, dt, 1, ex);
  drift(scalar, T(0.5) * dt, ex);
  compute_resultants<kExplicit>(scalar, ex);
  for (const Segment& sg : scalar.segments) segment_kick<kExplicit>(scalar, dt, ex, sg);  // as step_n
  const RodBatch<T> before = scalar;  // u⁻ at the frozen geometry
  viscous_update<kAllTerms, 1>(scalar, dt, ex);
  drift(scalar, T(0.5) * dt, ex);
  for (int r = 0; r < lanes.rod_count(); ++r) {
    const RodInfo& rod = lanes.rods[r];
    const std::string tag = "step " + std::to_string(step_no);
    if (rod.elements > kSegmentSlots) {  // alone in its segment: the scalar kernel in both
      for (int j = 0; j <= rod.elements; ++j)
        for (int d = 0; d < 3; ++d) {
          const int k = lanes.node_index(r, j);
          ASSERT_EQ(lanes.state.node_v[d][k], scalar.state.node_v[d][k]) << where("node", r, j);
          ASSERT_EQ(lanes.state.node_x[d][k], scalar.state.node_x[d][k]) << where("node", r, j);
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
