// host/core/advanced.h — the step, statics and stable-step templates
// for any compile-time Terms and Viscous treatment, and the stage functions
// themselves (host/core/step/stages.h, host/core/step/implicit_solve.h, …), for code built against
// the source tree: the tests, the benchmarks, or a project that adds
// manyrods with add_subdirectory and links manyrods::advanced.
//
// The installed package does not have this header: it holds the library's
// compiled combinations (include/manyrods/step.h "Which Terms are
// compiled"), which need no Eigen and no kernel headers. Code that includes
// this header compiles the kernels itself, so it should use the library's
// flags (-O3, -fno-math-errno; the manyrods::advanced target carries them).
#pragma once

#include "host/core/step/diagnostics.h"
#include "host/core/step/integrators.h"
#include "host/core/analysis/stable_dt.h"
#include "host/core/analysis/statics.h"
#include "manyrods/manyrods.h"
