// The partitioned solve of one long rod (kernels/viscous_implicit_partitioned.h,
// host/core/step/implicit_solve.h solve_partitioned) against the scalar kernel
// (kernels/viscous_implicit.h viscous_implicit_rod):
//   * with short partitions (k = 5 and 8 cells) on random curved, moving
//     rods — clamped and free roots, a clamped tip (fixed unknowns in the
//     last separator), stiff rods, joints beyond the small-rotation range,
//     every remainder r of the first partition (1, between, k), lane groups
//     of 4, 8 and 16 with repeated lanes — in float and double, with and
//     without the Kelvin–Voigt term: the velocities agree to round-off and
//     the residual is that of a backward-stable solve;
//   * 1 and 2 threads give the same bits;
//   * through the batch's plan (k = kPartitionCells): a long rod is
//     partitioned, solved to a backward-stable residual, and step_n gives the
//     same bits on 1 and 2 threads.
//
// Round-off bound (tests/test_implicit_lanes.cpp's header has the argument
// for the block elimination): the partitioned solve is the block Cholesky
// factorization of A with its unknowns reordered (each partition's interior
// first, the separators last), so Higham's bound for Cholesky (Accuracy and
// Stability of Numerical Algorithms, Thm 10.4) holds with |ΔA| ≤ γ·d dᵀ on
// the factor's fill: within a partition and its two separators (reach k + 1
// cells). γ_{3n+1} with n the longest inner product: a separator's row of
// the factor spans its partitions, n ≤ 6(k + 2), so k_part = 3·6(k + 2) + 1
// roundings, and 8 more for the assembly: 18k + 45. Against the scalar
// kernel (43 roundings, and the delta form's term in the scale), the
// difference is bounded by (18k + 45 + 43)·u·s.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "check.h"
#include "host/core/step/implicit_solve.h"
#include "implicit_rods.h"
#include "host/core/advanced.h"

using namespace manyrods;
using namespace manyrods::testing;

namespace {

constexpr Terms kNoKV{true, true, true, true, false, true, true};

double partitioned_limit(int k) { return 18.0 * k + 45; }

struct Case {
  int elements;
  bool clamped_root, clamped_tip, stiff;
  double tau, max_turn;
};

template <Terms kT, int W, class T>
__attribute__((noinline)) void partitioned(RodBatch<T>& b, T h, int threads, int k) {
  std::vector<T> buf(partition_values(b.rods[0].elements + 1, W, k), T(0));
  detail::solve_partitioned<kT, W>(b, h, Exec{threads}, b.rods[0], buf.data(), k);
}

template <Terms kT, class T, int W>
void partitioned_vs_scalar(unsigned seed, const Case& cs, int k, double h) {
  std::mt19937 rng(seed);
  RodSpec spec = random_rod(rng, cs.elements, cs.clamped_root, cs.tau, cs.stiff, cs.max_turn);
  spec.clamped_tip = cs.clamped_tip;
  RodBatch<T> b = build_batch<T>({spec});
  RodBatch<T> scalar = b, part = b, two = b;
  scalar.reserve_implicit_scratch(1);
  const T stiff_h = cs.stiff ? T(h) : T(0);
  const int first = b.rods[0].offset + 1, cells = b.rods[0].elements + 1;
  viscous_implicit_rod<kT>(first, cells, T(h), stiff_h, scalar.model_view(), scalar.state_view(),
                           scalar.implicit_scratch_view(0, 0));
  partitioned<kT, W>(part, T(h), 1, k);
  partitioned<kT, W>(two, T(h), 2, k);
  const std::string tag = std::string(sizeof(T) == 4 ? "float" : "double") + " W=" + std::to_string(W) +
                          " k=" + std::to_string(k) + " cells=" + std::to_string(cells) +
                          (kT.kelvin_voigt ? " KV" : " stiff only");
  {
    Checker ck(tag, sizeof(T) == 4 ? 0x1p-24 : 0x1p-53, partitioned_limit(k) + 43);
    compare_rod(ck, part, scalar, 0, solve_scale<kT>(b, 0, T(h), stiff_h), "partitioned vs scalar");
  }
  {
    Checker ck(tag + " residual", sizeof(T) == 4 ? 0x1p-24 : 0x1p-53, partitioned_limit(k));
    check_residual<T>(ck, rod_system<kT>(b, 0, T(h), stiff_h), rod_velocities(part, 0), k + 1, "partitioned");
  }
  if (kT.kelvin_voigt || cs.stiff) {  // the solve must do something (else A = M)
    double moved = 0;
    for (int c = 0; c < cells; ++c)
      moved = std::max(moved, std::abs(double(part.state.node_v[0][first + c]) - double(b.state.node_v[0][first + c])));
    EXPECT_GT(moved, 1e-5) << tag;
  }
  for (int c = 0; c < cells; ++c)
    for (int d = 0; d < 3; ++d) {
      ASSERT_EQ(part.state.node_v[d][first + c], two.state.node_v[d][first + c]) << tag << " 2 threads, cell " << c;
      ASSERT_EQ(part.state.elem_w[d][first + c], two.state.elem_w[d][first + c]) << tag << " 2 threads, cell " << c;
    }
}

// Rods whose cells leave the first partition r = 1, r = k and r in between,
// with the variants of the header.
template <Terms kT, class T, int W>
void kernel_cases(int k, double h, unsigned seed) {
  const int P = W + 3;  // two lane groups (the second one with repeated lanes)
  const int rs[] = {1, k / 2 + 1, k};
  for (int i = 0; i < 3; ++i) {
    const int cells = (P - 1) * k + rs[i];
    const Case cases[] = {
        {cells - 1, true, false, false, 0.02, 0.4},  // clamped root, damped
        {cells - 1, false, true, true, 0.005, 0.4},  // free root, clamped tip, stiff
        {cells - 1, true, true, false, 0.1, 2.5},    // both ends held, large turns (general path)
    };
    for (const Case& c : cases) partitioned_vs_scalar<kT, T, W>(seed++, c, k, h);
  }
}

}  // namespace

TEST(ImplicitPartitioned, KernelMatchesScalarDouble) {
  for (double h : {1e-5, 1e-3}) {
    kernel_cases<kAllTerms, double, 4>(8, h, 1);
    kernel_cases<kAllTerms, double, 8>(5, h, 20);
  }
  kernel_cases<kNoKV, double, 4>(8, 1e-4, 40);  // stiff rods only (Kelvin–Voigt off)
}

TEST(ImplicitPartitioned, KernelMatchesScalarFloat) {
  for (double h : {1e-5, 1e-3}) {
    kernel_cases<kAllTerms, float, 16>(5, h, 60);
    kernel_cases<kAllTerms, float, 8>(8, h, 80);
  }
  kernel_cases<kNoKV, float, 16>(8, 1e-4, 100);
}

namespace {

template <class T>
bool same_velocities(const RodBatch<T>& a, const RodBatch<T>& b) {
  for (int d = 0; d < 3; ++d)
    if (std::memcmp(a.state.node_v[d].data(), b.state.node_v[d].data(), sizeof(T) * a.state.node_v[d].size()) ||
        std::memcmp(a.state.elem_w[d].data(), b.state.elem_w[d].data(), sizeof(T) * a.state.elem_w[d].size()) ||
        std::memcmp(a.state.node_x[d].data(), b.state.node_x[d].data(), sizeof(T) * a.state.node_x[d].size()))
      return false;
  return true;
}

// A batch of one long damped rod (two lane groups of partitions) and a few
// short ones: the plan partitions the long rod only; its solve has a
// backward-stable residual; step_n is the same on 1 and 2 threads.
template <class T>
void long_rod_through_plan() {
  constexpr int W = kImplicitLanes<T>;
  const int elements = 2 * W * kPartitionCells - 100;  // 2 groups, the second one part-filled
  std::mt19937 rng(5);
  std::vector<RodSpec> specs{random_rod(rng, elements, true, 0.02, false, 0.05)};
  for (int i = 0; i < 3; ++i) specs.push_back(random_rod(rng, 20, true, 0.02, false, 0.3));
  RodBatch<T> b = build_batch<T>(specs, {0, 0, -9.81});
  int partitioned_groups = 0;
  for (const SolveGroup& g : b.workspace->solve_plan[1].groups)
    if (g.parts > 0) {
      ++partitioned_groups;
      EXPECT_EQ(b.workspace->solve_plan[1].rods[g.first], 0);
      EXPECT_EQ(g.parts, (elements + 1 + kPartitionCells - 1) / kPartitionCells);
    }
  EXPECT_EQ(partitioned_groups, 1);
  const T h = T(1e-4);
  RodBatch<T> solved = b;
  viscous_update<kAllTerms>(solved, h, Exec{1});
  {
    Checker ck(std::string(sizeof(T) == 4 ? "float" : "double") + " plan's long rod, residual",
               sizeof(T) == 4 ? 0x1p-24 : 0x1p-53, partitioned_limit(kPartitionCells));
    check_residual<T>(ck, rod_system<kAllTerms>(b, 0, h, T(0)), rod_velocities(solved, 0), kPartitionCells + 1,
                      "long rod");
  }
  const T dt = T(0.5 * stable_dt(b).elastic);
  RodBatch<T> two = b;
  step_n<kAllTerms>(b, dt, 3, Exec{1});
  step_n<kAllTerms>(two, dt, 3, Exec{2});
  EXPECT_TRUE(same_velocities(b, two)) << "1 and 2 threads differ";
}

}  // namespace

TEST(ImplicitPartitioned, LongRodThroughPlanDouble) { long_rod_through_plan<double>(); }
TEST(ImplicitPartitioned, LongRodThroughPlanFloat) { long_rod_through_plan<float>(); }
