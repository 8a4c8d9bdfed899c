// include/manyrods/isa.h — which compiled build of the step runs.
//
// A build configured with MANYRODS_ISA (e.g. "x86-64-v3;x86-64-v4") carries
// the step (step_n and step_pefrl for the library's Terms, float and
// double) once for the library's own instruction set — the "baseline" —
// and once for each listed x86-64 level. The first step picks the path:
//   - the environment variable MANYRODS_ISA, when set (a path name below,
//     or "auto"); a name the build lacks or the CPU cannot run is an error
//     (std::invalid_argument from the step, naming the paths there are);
//   - otherwise the highest listed level this CPU supports, or the baseline.
//     A -march=native build (MANYRODS_NATIVE) is already this machine's
//     best: there the baseline is chosen and the others run only when asked.
// select_step_path() changes it for the whole process (not while a step of
// another thread runs). Every path computes the same formulas; results differ
// between paths in the last bits (fused multiply–adds, the vector width), are
// bit-identical for any thread count on each path. docs/architecture.md
// "One build for every x86-64 CPU".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace manyrods {

struct StepPath {
  std::string name;    // "baseline", "x86-64-v2", "x86-64-v3" or "x86-64-v4"
  std::string target;  // what it was compiled for (-march=…)
  bool supported;      // this CPU can run it
  bool active;         // the path the step takes now
};

// Every path of this build, the baseline first.
std::vector<StepPath> step_paths();

// The name of the path the step takes (resolving the automatic choice, so it
// throws std::invalid_argument for a bad MANYRODS_ISA).
std::string active_step_path();

// Use path `name` from now on ("auto": the automatic choice above, which
// ignores MANYRODS_ISA). Throws std::invalid_argument for a name the build
// lacks or the CPU cannot run.
void select_step_path(const std::string& name);

// This machine's ceilings, which `manyrods bench` sets a step's throughput
// against: the FMA peak in FLOP/s (an FMA counts 2) of `threads` threads
// on the active step path's instruction set, the best of 5 bursts of about
// 0.05 s; and the STREAM triad's bandwidth in bytes/s over 3 × 32 Mi
// entries of T (far beyond the caches), the best of 5. Each takes about a
// second.
template <class T>
double peak_flops(int threads);
template <class T>
double triad_bandwidth(int threads);
// This machine's physical memory in bytes (0: not known), which the checks
// of what a batch, a sweep or the contact lists would need are made against.
std::uint64_t physical_memory();

}  // namespace manyrods
