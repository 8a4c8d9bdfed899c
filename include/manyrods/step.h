// include/manyrods/step.h — stepping a batch: step<Terms>(batch, dt, exec)
// (Position Verlet), step_pefrl (PEFRL), generalized_forces, energies,
// find_non_finite (implemented in host/step.h); advance (many steps with a
// non-finite watch, NonFiniteError; host/run.h).
#pragma once

#include "host/step.h"
#include "host/run.h"
