// host/core/step/fp_env.cpp — the floating-point mode's per-thread
// bookkeeping (fp_env.h), one definition for every build of the step.
#include "host/core/step/fp_env.h"

namespace manyrods::detail {

thread_local unsigned t_outside_mode = 0;
thread_local int t_step_depth = 0;

}  // namespace manyrods::detail
