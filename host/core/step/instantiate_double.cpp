// host/core/step/instantiate_double.cpp — the step templates the library holds for double
// batches (include/manyrods/step.h "Which Terms are compiled"); float and
// double are separate files so that they compile in parallel.
#include "host/core/step/integrators.h"

namespace manyrods {

MANYRODS_STEP_ALL_TERMS(, double)
template NonFinite find_non_finite<double>(const RodBatch<double>&);

}  // namespace manyrods
