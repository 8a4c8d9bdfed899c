// host/core/step/schedule.h — the segment schedule: which thread runs which slots
// (docs/architecture.md "The segment schedule").
//
// The batch's slots are cut into segments when it is built
// (include/manyrods/batch.h Segment): runs of whole rods, small enough
// ("fused", ≤ kSegmentSlots) to stay in L2 while a step runs all its stages
// on them, or one long rod each. Threads take whole fused segments, so each
// slot is computed by the same instructions whatever the thread count;
// segments that are not fused are stepped stage by stage with all threads.
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

#include <omp.h>

#include "host/core/step/fp_env.h"
#include "manyrods/batch.h"
#include "manyrods/step.h"

namespace manyrods {

// Whether for_each_segment steps a batch of these segments one at a time
// (one or two of them: even and odd ones would not run side by side), each
// with its implicit solve shared out over the threads (its plan cut for
// that, host/core/step/implicit_plan.h plan_segment).
inline bool segments_alone(const std::vector<Segment>& segments) { return segments.size() <= 2; }

// The whole batch as one range of slots and rods.
template <class T>
Segment whole(const RodBatch<T>& b) {
  return {0, b.slots(), 0, b.rod_count(), false};
}

// Runs run(segment, exec, thread) on every segment: the fused ones in
// parallel, every other one at a time (even, then odd: no slot is read while
// another thread writes it; segments only read their neighbours' root
// ghost nodes, which never move — a driven root moves node 0 and the clamp
// frame of its own rods), `thread` being the OpenMP thread number; then
// the big ones one by one with all threads (thread = 0). Where the fused
// segments run one at a time (one or two of them), each gets
// Exec::solve_threads = ex.threads: its implicit solve shares out its lane
// groups (host/core/step/implicit_solve.h), its other stages stay on one
// thread (a parallel region per stage costs more than their work).
template <class T, class F>
void for_each_segment(RodBatch<T>& b, const Exec& ex, F&& run) {
  const int n = int(b.segments.size());
  Exec serial = ex;  // every option of the caller's, on one thread
  serial.threads = 1;
  // segments one at a time: the implicit solve of each may use all threads
  const bool parallel = ex.threads > 1 && !segments_alone(b.segments);
  serial.solve_threads = parallel ? 1 : std::max(ex.threads, 1);
  if (ex.profile) ex.profile->reserve(ex.threads);
  const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's, for every thread (host/core/step/fp_env.h)
  for (int parity = 0; parity < 2; ++parity) {
    if (!parallel) {  // (no region: one nested in it would start its threads anew, ~50 µs)
      for (int i = parity; i < n; i += 2)
        if (b.segments[i].fused) run(b.segments[i], serial, 0);
      continue;
    }
#pragma omp parallel num_threads(ex.threads)
    {
      const RegionFpScope fp(mode);
#pragma omp for schedule(static, 1)
      for (int i = parity; i < n; i += 2)
        if (b.segments[i].fused) run(b.segments[i], serial, omp_get_thread_num());
    }
  }
  for (const Segment& r : b.segments)
    if (!r.fused) run(r, ex, 0);
}

// Runs f() as stage s of a step, timed into ex.profile when there is one
// (include/manyrods/profile.h), on behalf of thread `thread`; the wall time
// counts ex.threads times (thread-seconds) when all threads run the stage.
template <class F>
inline void timed(const Exec& ex, int thread, Stage s, F&& f) {
  if (!ex.profile) {
    f();
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  f();
  const std::chrono::duration<double> d = std::chrono::steady_clock::now() - t0;
  ex.profile->add(thread, s, d.count() * double(ex.threads > 1 ? ex.threads : 1));
}

}  // namespace manyrods
