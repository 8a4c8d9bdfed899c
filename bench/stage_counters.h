// bench/stage_counters.h — where a benchmarked step's time goes: after the
// timed loop, 64 more steps with a Profile (include/manyrods/profile.h);
// each stage's share of the step's thread-seconds becomes a counter
// stage_<name> (0…1), every stage in every row (the CSV reporter needs the
// same counters in every row; 0 where a stage did not run).
#pragma once

#include <benchmark/benchmark.h>

#include <string>

#include "host/core/advanced.h"

namespace manyrods::bench {

template <Terms kT, Viscous kV = Viscous::implicit, class T>
void stage_counters(benchmark::State& state, RodBatch<T>& b, T dt, const Exec& ex) {
  Profile profile;
  step_n<kT, kV>(b, dt, 64, Exec{ex.threads, &profile, ex.flush_subnormals});
  const StageTimes st = profile.total();
  for (int i = 0; i < kStageCount; ++i)
    state.counters[std::string("stage_") + stage_name(Stage(i))] = st.seconds[std::size_t(i)] / st.total();
}

}  // namespace manyrods::bench
