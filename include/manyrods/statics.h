// include/manyrods/statics.h — solve_static(batch): Newton equilibrium of the
// discrete rods under their loads (implemented in host/statics.h; needs Eigen).
#pragma once

#include "host/statics.h"
