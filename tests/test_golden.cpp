// tests/test_golden.cpp — the committed answer of two fixed batches: any
// unintended change of a result fails here, whatever test would otherwise
// miss it (Box2D's determinism test is the model).
//
// The batches: a damped seed cantilever bending under gravity, a damped
// rod of 7 elements, a damped stiff hair and a cantilever on a shaking,
// nodding root (Position Verlet, 200 steps as four step_n blocks); the
// cantilever and the short rod (PEFRL, 100 steps). Each in double and float,
// at half the batch's stable_dt.
//
// Two checks:
//   1. Every tip position equals the committed one to the round-off a
//      different compiler or CPU may add: 10 ulps of T (relative to the rod
//      length L) per step, accumulated linearly — these damped rods do not
//      amplify a perturbation. The float and double runs of the same batch
//      differ by at most 9e-9 m after 200 steps (the stiff hair, whose solve
//      runs in double; 2.1e-7 m when it ran in float; 6e-9 m for the
//      cantilevers): 0.001 float ulps·L per step, far inside the bound; a
//      changed formula moves the tips by far more (they travel millimetres
//      in these steps).
//   2. The state hash (state_hash) equals the committed one, bit for bit,
//      with IEEE subnormals (Exec::flush_subnormals = false; (1) is checked
//      with the flush as well, the default for float).
//      It is compared where the build matches one that recorded it: GCC 12
//      on x86-64 with -march=native (MANYRODS_NATIVE, the default) and
//        - AVX2 and FMA without AVX-512 (the AMD EPYC machine of
//          bench/RESULTS.md), or
//        - AVX-512 (the AMD EPYC and Intel machines this project's CI and development
//          run on; the step's loops 8 or 16 lanes wide with 512-bit vectors).
//      Both recorded the same hashes (the AVX-512 ones on 2026-12-04: the
//      lane loops do the same operations per entry whatever their width, and
//      both fuse a·b + c the same way). Another compiler version or
//      instruction set (x86-64-v2 has no FMA; another libm rounds sin and
//      exp differently) changes last bits but no physics; there the test
//      prints the hash, says it was not compared, and checks (1) only. On a
//      recording build the hash must not change: a change means the answer
//      changed, and if that is intended the table below is renewed
//      (MANYRODS_GOLDEN_PRINT=1 prints it); should the two recording builds
//      ever disagree, the table gets a column per build.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <type_traits>
#include <vector>

#include "cases.h"
#include "manyrods/manyrods.h"

using namespace manyrods;

namespace {

struct Golden {
  const char* name;
  std::uint64_t hash;
  std::vector<Vec3> tips;  // last node of every rod
};

// Recorded on the build named above; see the file comment. (A build of this
// tree with -march=znver3 -DMANYRODS_NATIVE=OFF on an Intel machine gives the
// same hashes: it re-recorded the table when a float batch's stiff rods
// moved their solve to double and a double rod alone in its lane group
// moved from the scalar kernel to the one-lane kernel; the tips moved by
// round-off. Re-recorded when stiff rods' bending joined their implicit
// solve: only the stiff hair changed, its tip by 5.7e-10 m in double, the
// O(h³) per step of the midpoint-corrected bending at this step; the
// other rods are bit-identical. Hashes renewed, tips kept, when the lane
// solve eliminated with L⁻¹U instead of Â⁻¹U: the damped rods' tips moved
// by round-off, at most 2e-16 m in double and 1.2e-10 m (one ulp) in float.)
const Golden kGolden[] = {
    {"verlet/double", 0xbcb66e9b430f2a3bull, {{-0.00268747138277532, 0, 0.29984743310568507}, {-0.0027060124332927015, 0, 0.2998478086546883}, {0.19998464885572262, 0.5, -0.0011098151368830382}, {-0.0026814553664182977, 0, 0.29981555022094708}, }},
    {"verlet/float", 0x72fdfa6825125713ull, {{-0.0026874653995037079, 0, 0.29984742403030396}, {-0.0027060089632868767, 0, 0.299847811460495}, {0.19998463988304138, 0.5, -0.0011098135728389025}, {-0.0026814478915184736, 0, 0.29981553554534912}, }},
    {"pefrl/double", 0xaaa29cc698904fbcull, {{-0.00068082175051153147, 0, 0.29992400625717397}, {-0.00068003737018821752, 0, 0.29992400229192706}, }},
    {"pefrl/float", 0x54f491d98b671344ull, {{-0.00068082078360021114, 0, 0.29992401599884033}, {-0.00068003631895408034, 0, 0.29992401599884033}, }},
};

// Which recorded hash this build must reproduce (MANYRODS_GOLDEN_NATIVE:
// tests/CMakeLists.txt, when the library is built with -march=native).
enum class Recording { none, avx2, avx512 };
#if defined(MANYRODS_GOLDEN_NATIVE) && defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12 && \
    defined(__x86_64__) && defined(__AVX512F__)
constexpr Recording kRecording = Recording::avx512;
#elif defined(MANYRODS_GOLDEN_NATIVE) && defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12 && \
    defined(__x86_64__) && defined(__AVX2__) && defined(__FMA__)
constexpr Recording kRecording = Recording::avx2;
#else
constexpr Recording kRecording = Recording::none;
#endif

// flush: Exec::flush_subnormals (the default; float only). The committed
// hashes are those of IEEE gradual underflow (flush = false).
template <class T>
Golden run(bool verlet, bool flush) {
  // gravity bends the cantilevers (along e3) and the hair (along e1)
  RodBatch<T> b = build_batch<T>(cases::golden_rods(verlet), {-9.81, 0, -4});
  const T dt = T(0.5 * stable_dt(b).elastic);
  if (verlet)
    for (int block = 0; block < 4; ++block) step_n(b, dt, 50, Exec{2, nullptr, flush});
  else
    for (int i = 0; i < 100; ++i) step_pefrl(b, dt, Exec{2, nullptr, flush});
  Golden g{"", state_hash(b), {}};
  for (int r = 0; r < b.rod_count(); ++r) g.tips.push_back(b.position(r, b.elements(r)));
  return g;
}

void print(const char* name, const Golden& g) {
  std::printf("    {\"%s\", 0x%016llxull, {", name, static_cast<unsigned long long>(g.hash));
  for (const Vec3& t : g.tips) std::printf("{%.17g, %.17g, %.17g}, ", t[0], t[1], t[2]);
  std::printf("}},\n");
}

template <class T>
void check(const char* name, bool verlet, int steps) {
  const Golden got = run<T>(verlet, false);
  const Golden* want = nullptr;
  for (const Golden& g : kGolden)
    if (std::string(g.name) == name) want = &g;
  ASSERT_NE(want, nullptr);
  if (std::getenv("MANYRODS_GOLDEN_PRINT")) print(name, got);
  ASSERT_EQ(got.tips.size(), want->tips.size()) << name << ": the golden table has another batch";
  const double tol = steps * 10 * double(std::numeric_limits<T>::epsilon()) * cases::kL;
  for (std::size_t r = 0; r < got.tips.size(); ++r)
    EXPECT_LE(cases::distance(got.tips[r], want->tips[r]), tol) << name << ": tip of rod " << r;
  const std::uint64_t golden = want->hash;
  std::printf("  %s: state hash %016llx (golden %016llx)%s\n", name, static_cast<unsigned long long>(got.hash),
              static_cast<unsigned long long>(golden),
              kRecording == Recording::none ? " — not compared: not a recording compiler/ISA"
              : kRecording == Recording::avx512 ? " — AVX-512 build"
                                                 : " — AVX2 build");
  if (kRecording != Recording::none) {
    EXPECT_EQ(got.hash, golden) << name << ": the answer changed bit for bit";
  }
  // 3. With subnormals flushed (the default) the tips stay within the same
  //    bound: a flushed value is below 1.2e-38, far below one ulp of a tip.
  if constexpr (std::is_same_v<T, float>) {  // (double steps do not flush)
    const Golden flushed = run<T>(verlet, true);
    for (std::size_t r = 0; r < flushed.tips.size(); ++r)
      EXPECT_LE(cases::distance(flushed.tips[r], want->tips[r]), tol) << name << ": flushed, tip of rod " << r;
    std::printf("  %s, subnormals flushed: state hash %016llx\n", name,
                static_cast<unsigned long long>(flushed.hash));
  }
}

}  // namespace

TEST(Golden, PositionVerletDouble) { check<double>("verlet/double", true, 200); }
TEST(Golden, PositionVerletFloat) { check<float>("verlet/float", true, 200); }
TEST(Golden, PefrlDouble) { check<double>("pefrl/double", false, 100); }
TEST(Golden, PefrlFloat) { check<float>("pefrl/float", false, 100); }
