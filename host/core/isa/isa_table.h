// host/core/isa/isa_table.h — the table of step functions one build of the step
// exports (host/core/isa/isa_variant.cpp) and the baseline dispatches to (host/core/isa/isa.cpp,
// the prologue of step_n and step_pefrl in host/core/step/integrators.h).
//
// Slots: step_n for every Terms of MANYRODS_PLAIN_TERMS then
// MANYRODS_CONTACT_TERMS (include/manyrods/step.h), step_pefrl (Euler order
// 4) for MANYRODS_PLAIN_TERMS; Viscous::implicit only, which is what the
// library holds. Other Terms are never dispatched. Plus the FMA peak's loop.
#pragma once

#include <cstdint>
#include <iterator>

#include "manyrods/step.h"

namespace manyrods::isa {

#define MANYRODS_ISA_TERMS_ITEM(unused, TERMS) TERMS,
inline constexpr Terms kStepNTerms[] = {MANYRODS_PLAIN_TERMS(MANYRODS_ISA_TERMS_ITEM, _)
                                            MANYRODS_CONTACT_TERMS(MANYRODS_ISA_TERMS_ITEM, _)};
inline constexpr Terms kPefrlTerms[] = {MANYRODS_PLAIN_TERMS(MANYRODS_ISA_TERMS_ITEM, _)};
#undef MANYRODS_ISA_TERMS_ITEM

template <class T>
struct StepFns {
  void (*step_n[std::size(kStepNTerms)])(RodBatch<T>&, T, std::int64_t, const Exec&);
  void (*step_pefrl[std::size(kPefrlTerms)])(RodBatch<T>&, T, const Exec&);
  // the FMA peak's loop on this instruction set (host/core/isa/roofline.h), which
  // `manyrods bench` measures the step against
  double (*fma_burst)(int threads, int inner, volatile T* sink);
};

struct StepTable {
  StepFns<float> f32;
  StepFns<double> f64;
};

template <class T>
constexpr const StepFns<T>& fns(const StepTable& t) {
  if constexpr (sizeof(T) == 4)
    return t.f32;
  else
    return t.f64;
}

template <std::size_t N>
constexpr int slot(const Terms (&list)[N], Terms t) {
  for (std::size_t i = 0; i < N; ++i)
    if (terms_mask(list[i]) == terms_mask(t)) return int(i);
  return -1;
}

// The table the step dispatches to; nullptr while the baseline's own code
// runs (host/core/isa/isa.cpp). The first call makes the automatic choice and throws
// std::invalid_argument for a bad MANYRODS_ISA.
const StepTable* active_table();

}  // namespace manyrods::isa
