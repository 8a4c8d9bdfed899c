// host/core/model/view_of.h — a kernel view's pointer from a batch array:
// view_of(dst, array) for one array (nullptr when it is empty) and for one
// array per component. Used for the views of the field lists
// (host/core/model/batch.cpp), the fluid's (host/core/step/fluid_stage.h)
// and contact's (host/core/step/contact_stage.h).
#pragma once

#include <array>
#include <cstddef>

#include "manyrods/array.h"

namespace manyrods {

template <class P, class T>
void view_of(P& dst, const Array<T>& a) {
  dst = a.size() ? const_cast<T*>(a.data()) : nullptr;
}
template <class P, class T, std::size_t N>
void view_of(P (&dst)[N], const std::array<Array<T>, N>& a) {
  for (std::size_t i = 0; i < N; ++i) view_of(dst[i], a[i]);
}

}  // namespace manyrods
