// host/core/step/instantiate_float.cpp — the step templates the library holds for float
// batches (include/manyrods/step.h "Which Terms are compiled"); float and
// double are separate files so that they compile in parallel.
#include "host/core/step/integrators.h"

namespace manyrods {

MANYRODS_STEP_ALL_TERMS(, float)
template NonFinite find_non_finite<float>(const RodBatch<float>&);

}  // namespace manyrods
