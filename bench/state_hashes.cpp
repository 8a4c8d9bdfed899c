// bench/state_hashes.cpp — the states of every benchmark configuration after
// 20 steps (step) and after 64 more (one step_n call), as FNV-1a hashes of
// their positions, velocities, frames and angular velocities: run it before
// and after a change that must not change any answer, and diff the output
// (bench/RESULTS.md "Before and after the architecture renovation"). The
// hash is written out here, not taken from the library, so that the same
// function can be compiled against an older tree.
#include <cstdio>
#include <cstring>
#include "contact_scenes.h"
#include "scenes.h"
using namespace manyrods;
using namespace manyrods::bench;
template <class T>
std::uint64_t fnv(const RodBatch<T>& b) {
  std::uint64_t h = 14695981039346656037ull;
  auto mix = [&](T v) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &v, sizeof(T));
    for (unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
  };
  for (int r = 0; r < b.rod_count(); ++r) {
    for (int j = 0; j <= b.elements(r); ++j) {
      const int k = b.node_index(r, j);
      for (int d = 0; d < 3; ++d) { mix(b.state.node_x[d][k]); mix(b.state.node_v[d][k]); }
    }
    for (int e = 0; e < b.elements(r); ++e) {
      const int k = b.elem_index(r, e);
      for (int i = 0; i < 9; ++i) mix(b.state.elem_Q[i][k]);
      for (int d = 0; d < 3; ++d) mix(b.state.elem_w[d][k]);
    }
  }
  return h;
}
constexpr Terms kNoKV{true, true, true, true, false, true, true};
template <class T, Terms kT, Viscous kV>
void one(const char* scene, bool kv, const char* tag, int threads) {
  const Exec ex{threads};
  Scene sc = make_scene(scene, kv);
  RodBatch<T> b = build_batch<T>(sc.rods, sc.gravity);
  const StableDt lim = stable_dt<kT>(b);
  const T dt = T(0.5 * (kT.kelvin_voigt && kV == Viscous::explicit_rate ? std::min(lim.elastic, lim.explicit_viscous) : lim.elastic));
  for (int i = 0; i < 20; ++i) step<kT, kV>(b, dt, ex);
  const std::uint64_t h20 = fnv(b);
  step_n<kT, kV>(b, dt, 64, ex);
  std::printf("%-10s %-6s %-12s t%d  %016llx %016llx\n", scene, sizeof(T) == 4 ? "float" : "double", tag, threads,
              (unsigned long long)h20, (unsigned long long)fnv(b));
  std::fflush(stdout);
}
// The contact benchmarks' batches (bench/bench_contact.cpp) after their
// warm-up into contact, then 20 steps and 64 more; the contact stage's
// variants: colliders only (temporally blocked) and rod–rod contact.
template <Terms kT>
void contact(const char* scene, const char* variant, int warm, int threads) {
  const Exec ex{threads};
  const std::string sc = scene;
  const int side = sc == "bundle16" ? 4 : 32;
  RodBatch<double> b = build_batch<double>(
      sc == "groom" ? groom() : sc == "headstiff" ? hair_grid() : twisted_bundle(side), {0, 0, -9.81});
  const double dt = 0.5 * stable_dt<kAllTerms>(b).elastic;
  set_contact(b, contact_for(sc, variant));
  step_n<kT>(b, dt, warm, ex);
  for (int i = 0; i < 20; ++i) step<kT>(b, dt, ex);
  const std::uint64_t h20 = fnv(b);
  step_n<kT>(b, dt, 64, ex);
  std::printf("%-10s %-6s %-12s t%d  %016llx %016llx\n", scene, "double", variant, threads, (unsigned long long)h20,
              (unsigned long long)fnv(b));
  std::fflush(stdout);
}
int main() {
  for (const char* s : {"hair", "cable", "long", "mixed", "fibers"}) {
    one<float, kAllTerms, Viscous::implicit>(s, true, "kv", 2);
    one<double, kAllTerms, Viscous::implicit>(s, true, "kv", 2);
    one<float, kNoKV, Viscous::implicit>(s, false, "nokv", 2);
    one<double, kNoKV, Viscous::implicit>(s, false, "nokv", 2);
    one<float, kAllTerms, Viscous::explicit_rate>(s, true, "kvexplicit", 2);
  }
  for (const char* s : {"hairstiff", "hairturn"}) {
    one<float, kAllTerms, Viscous::implicit>(s, true, "kv", 2);
    one<double, kAllTerms, Viscous::implicit>(s, true, "kv", 2);
    one<double, kAllTerms, Viscous::implicit>(s, true, "kv", 1);
  }
  contact<kColliders>("headstiff", "head", 300, 2);
  contact<kRodContact>("bundle16", "rod", 100, 1);
  contact<kRodContact>("bundle16", "rod", 100, 2);
  contact<kAllContact>("groom", "head_rod", 1800, 2);
}
