// include/manyrods/step.h — stepping a batch: step<Terms>(batch, dt, exec),
// generalized_forces, energies, find_non_finite (implemented in host/step.h).
#pragma once

#include "host/step.h"
