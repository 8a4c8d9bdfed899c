// host/core/step/instantiate_contact_float.cpp — the step templates with contact the
// library holds for float batches (include/manyrods/step.h
// MANYRODS_STEP_CONTACT_TERMS), in a file of their own to compile in parallel.
#include "host/core/step/integrators.h"

namespace manyrods {

MANYRODS_STEP_CONTACT_TERMS(, float)

}  // namespace manyrods
