// host/core/analysis/analysis.cpp — the analysis templates the library holds: stable_dt
// solve_static and preload_rest_shape (include/manyrods/stable_dt.h, statics.h), the only
// parts of the library that use Eigen.
#include "host/core/analysis/stable_dt.h"
#include "host/core/analysis/preload.h"
#include "host/core/analysis/statics.h"

namespace manyrods {

MANYRODS_STABLE_DT_DECLARATIONS(, float)
MANYRODS_STABLE_DT_DECLARATIONS(, double)
template StaticResult solve_static<kAllTerms>(RodBatch<double>&, const StaticOptions&);
template StaticResult solve_static<kNoKelvinVoigt>(RodBatch<double>&, const StaticOptions&);
template StaticResult solve_static<kNoGravity>(RodBatch<double>&, const StaticOptions&);
template StaticResult solve_static<kNoKelvinVoigtNoGravity>(RodBatch<double>&, const StaticOptions&);
template std::vector<HoldReaction> hold_reactions<kAllTerms>(const RodBatch<double>&);
template std::vector<HoldReaction> hold_reactions<kNoKelvinVoigt>(const RodBatch<double>&);
template std::vector<HoldReaction> hold_reactions<kNoGravity>(const RodBatch<double>&);
template std::vector<HoldReaction> hold_reactions<kNoKelvinVoigtNoGravity>(const RodBatch<double>&);
template PreloadResult preload_rest_shape<kAllTerms>(RodBatch<double>&, int);
template PreloadResult preload_rest_shape<kNoKelvinVoigt>(RodBatch<double>&, int);
template PreloadResult preload_rest_shape<kNoGravity>(RodBatch<double>&, int);
template PreloadResult preload_rest_shape<kNoKelvinVoigtNoGravity>(RodBatch<double>&, int);

}  // namespace manyrods
