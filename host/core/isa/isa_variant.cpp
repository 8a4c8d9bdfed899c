// host/core/isa/isa_variant.cpp — the step compiled for one more instruction set
// (include/manyrods/isa.h). CMake compiles this file once per level of
// MANYRODS_ISA with -march=<level>, -DMANYRODS_ISA_VARIANT and
// -DMANYRODS_ISA_ENTRY=manyrods_isa_table_<level>, then links the object
// with `ld -r --force-group-allocation` and makes every symbol but the entry
// local (objcopy --keep-global-symbol): the templates and inline functions
// compiled here for the wider instruction set (the kernels, and the standard
// library's and Eigen's inline code they use) can then never stand in for the
// baseline's copies, which run on any CPU. What this object calls outside
// itself (set-up, plans, profiling, the broad phase) is the baseline's.
#include "host/core/step/integrators.h"
#include "host/core/isa/isa_table.h"
#include "host/core/isa/roofline.h"

#ifndef MANYRODS_ISA_ENTRY
#error "compiled by CMake only (MANYRODS_ISA in CMakeLists.txt)"
#endif

namespace manyrods {
namespace {

#define MANYRODS_ISA_STEP_N(T, TERMS) &step_n<TERMS, Viscous::implicit, T>,
#define MANYRODS_ISA_PEFRL(T, TERMS) &step_pefrl<TERMS, Viscous::implicit, 4, T>,

template <class T>
constexpr isa::StepFns<T> step_fns() {
  return {{MANYRODS_PLAIN_TERMS(MANYRODS_ISA_STEP_N, T) MANYRODS_CONTACT_TERMS(MANYRODS_ISA_STEP_N, T)},
          {MANYRODS_PLAIN_TERMS(MANYRODS_ISA_PEFRL, T)},
          &roofline::fma_burst<T>};
}

constexpr isa::StepTable kTable{step_fns<float>(), step_fns<double>()};

}  // namespace
}  // namespace manyrods

extern "C" const manyrods::isa::StepTable* MANYRODS_ISA_ENTRY() { return &manyrods::kTable; }
