// host/core/step/parallel_tasks.cpp — independent set-up tasks on the
// OpenMP threads in the caller's floating-point mode
// (include/manyrods/step.h parallel_tasks; the mode: fp_env.h).
#include "host/core/step/fp_env.h"
#include "manyrods/step.h"

namespace manyrods {

void parallel_tasks(std::size_t count, const std::function<void(std::size_t)>& task) {
  const RegionFpMode mode = RegionFpMode::of_caller();
#pragma omp parallel
  {
    const RegionFpScope fp(mode);
#pragma omp for schedule(dynamic)
    for (std::size_t i = 0; i < count; ++i) task(i);
  }
}

}  // namespace manyrods
