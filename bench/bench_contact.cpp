// bench/bench_contact.cpp — what contact costs (Google Benchmark;
// bench/RESULTS.md "Contact").
//
// BM_contact_<scene>_<variant>/threads: one Position Verlet step per
// iteration of the same batch with and without contact, in one run, so that
// the ratio is measured on one machine at one time. items_per_second =
// element-steps per second; counters: contacts (in touch at the end of the
// warm-up), candidates per element (rod–rod lists), contacts_per_s
// (contacts × steps per second), sim_s_per_s, rebuilds_per_step, and the state
// hash in the label; stage_<name>: each stage's share of the step
// (bench/stage_counters.h, 64 steps after the timed loop).
//   headstiff: 1,000 stiff hairs (bench/scenes.h hair, stiff_implicit, double,
//              at the frame-rate step 1/240 s) on a 32 × 32 grid of roots 0.5 mm
//              apart, horizontal, falling onto a head sphere below them:
//              off | head (with rod–rod contact see groom: this grid piles
//              into one bundle whose rebuilds test thousands of pairs)
//   groom:     1,000 stiff hairs (the same hair) rooted on a 70° cap of a
//              head (Fibonacci lattice, 5.6 mm apart), leaning down the head,
//              falling onto it and onto each other (warm-up 0.5 s), at 5e-4 s
//              (hair–hair contact limits the step): off | head | head_rod
//   bundle16, bundle64: the same with 4 × 4 and 8 × 8 fibers (the side-by-side
//              with PyElastica, one thread as it has)
//   bundle:    1,024 fibers × 32 elements (r = 0.25 mm, E = 10 MPa, 0.1 m)
//              twisted into a bundle (one turn per 0.2 m), clamped at the top,
//              hanging: off | rod (rod–rod contact between every fiber)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "contact_scenes.h"
#include "scenes.h"
#include "stage_counters.h"

using namespace manyrods;
using namespace manyrods::bench;

namespace {

constexpr Terms kStiffOff = kAllTerms;

template <Terms kT>
void run_contact(benchmark::State& state, const std::string& scene, const std::string& variant) {
  const int threads = int(state.range(0));
  const Exec ex{threads};
  const bool hair = scene == "headstiff" || scene == "groom";
  const int side = scene == "bundle16" ? 4 : scene == "bundle64" ? 8 : 32;
  RodBatch<double> b = build_batch<double>(
      scene == "groom" ? groom() : scene == "headstiff" ? hair_grid() : twisted_bundle(side), {0, 0, -9.81});
  // the stiff hairs on a head alone at the frame-rate step 1/240 s (they
  // have no stable-step limit); the groom, whose hairs meet each other, at
  // 5e-4 s (at 1/240 s their whipping tips reach 0.1 m a step, and the
  // lists overflow: docs/model.md "Stiff rods", contact at large steps); the
  // fibers at half their stable step
  const double dt =
      scene == "groom" ? 5e-4 : scene == "headstiff" ? 1.0 / 240 : 0.5 * stable_dt<kStiffOff>(b).elastic;
  if (variant != "off") set_contact(b, contact_for(scene, variant));
  // warm up into contact: the hairs' tips reach the head (0.5 s, 0.08 s), the fibers settle
  step_n<kT>(b, dt, scene == "groom" ? 1000 : hair ? 20 : 100, ex);
  const ContactStats cs = contact_stats(b);
  const std::int64_t rebuilt = cs.rebuilds;
  for (auto _ : state) step_n<kT>(b, dt, 1, ex);
  state.counters["rebuilds_per_step"] = double(contact_stats(b).rebuilds - rebuilt) / double(state.iterations());
  state.SetItemsProcessed(state.iterations() * b.element_count());
  double candidates = 0, most = 0;
  if (b.contact.on && b.contact.neighbour_count.size() > 0)
    for (int k = 0; k < b.slots(); ++k) {
      candidates += b.contact.neighbour_count[k];
      most = std::max(most, double(b.contact.neighbour_count[k]));
    }
  state.counters["candidates_max"] = most;
  state.counters["contacts"] = double(cs.contacts);
  state.counters["max_penetration_m"] = cs.max_penetration;
  state.counters["candidates_per_element"] = candidates / double(b.element_count());
  state.counters["contacts_per_s"] =
      benchmark::Counter(double(state.iterations()) * double(cs.contacts), benchmark::Counter::kIsRate);
  state.counters["sim_s_per_s"] = benchmark::Counter(double(state.iterations()) * dt, benchmark::Counter::kIsRate);
  char label[96];
  std::snprintf(label, sizeof label, "hash=%016llx dt=%.3g", (unsigned long long)state_hash(b), dt);
  state.SetLabel(label);
  stage_counters<kT>(state, b, dt, ex);
}

void BM_contact_headstiff_off(benchmark::State& s) { run_contact<kStiffOff>(s, "headstiff", "off"); }
void BM_contact_headstiff_head(benchmark::State& s) { run_contact<kColliders>(s, "headstiff", "head"); }
void BM_contact_groom_off(benchmark::State& s) { run_contact<kStiffOff>(s, "groom", "off"); }
void BM_contact_groom_head(benchmark::State& s) { run_contact<kColliders>(s, "groom", "head"); }
void BM_contact_groom_head_rod(benchmark::State& s) { run_contact<kAllContact>(s, "groom", "head_rod"); }
void BM_contact_bundle_off(benchmark::State& s) { run_contact<kStiffOff>(s, "bundle", "off"); }
void BM_contact_bundle_rod(benchmark::State& s) { run_contact<kRodContact>(s, "bundle", "rod"); }
// the bundles of the side-by-side with PyElastica's RodRodContact (bench/RESULTS.md)
void BM_contact_bundle16_off(benchmark::State& s) { run_contact<kStiffOff>(s, "bundle16", "off"); }
void BM_contact_bundle16_rod(benchmark::State& s) { run_contact<kRodContact>(s, "bundle16", "rod"); }
void BM_contact_bundle64_off(benchmark::State& s) { run_contact<kStiffOff>(s, "bundle64", "off"); }
void BM_contact_bundle64_rod(benchmark::State& s) { run_contact<kRodContact>(s, "bundle64", "rod"); }

}  // namespace

BENCHMARK(BM_contact_headstiff_off)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_headstiff_head)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_groom_off)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_groom_head)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_groom_head_rod)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_bundle_off)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_bundle_rod)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_bundle16_off)->ArgName("threads")->Arg(1)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_bundle16_rod)->ArgName("threads")->Arg(1)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_bundle64_off)->ArgName("threads")->Arg(1)->UseRealTime()->MinTime(0.5);
BENCHMARK(BM_contact_bundle64_rod)->ArgName("threads")->Arg(1)->UseRealTime()->MinTime(0.5);
