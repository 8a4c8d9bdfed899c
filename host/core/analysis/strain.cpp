// host/core/analysis/strain.cpp — the largest strain of a rod
// (include/manyrods/strain.h): |σ| per element (kernels/strains.h
// element_strain) and |κ − U0|·width/2 per joint (voronoi_strain).
#include "manyrods/strain.h"

#include <cmath>

#include "kernels/strains.h"
#include "kernels/views.h"

namespace manyrods {

template <class T>
StrainPeak strain_peak(const RodBatch<T>& b, int rod, double width) {
  const ModelView<T> m = b.model_view();
  const ConstStateView<T> s = b.state_view();
  StrainPeak p;
  auto take = [&](double v, int where, bool bend) {
    if (!(v <= p.value)) {  // NaN propagates
      p.value = v;
      p.where = where;
      p.bending = bend;
    }
    if (!bend && !(v <= p.stretch)) {
      p.stretch = v;
      p.stretch_element = where;
    }
  };
  const int n = b.elements(rod);
  for (int e = 0; e < n; ++e) {
    const vec3<T> sigma = element_strain(b.elem_index(rod, e), m, s).sigma;
    take(std::sqrt(double(dot(sigma, sigma))), e, false);
  }
  for (int j = 0; j + 1 < n; ++j) {
    const int k = b.vor_index(rod, j);
    const vec3<T> dk = voronoi_strain(k, m, s).kappa - load3(m.vor_rest_curvature, k);
    take(std::sqrt(double(dot(dk, dk))) * width / 2, j, true);
  }
  return p;
}

template <class T>
double max_strain(const RodBatch<T>& b, int rod, double width) {
  return strain_peak(b, rod, width).value;
}

template StrainPeak strain_peak<float>(const RodBatch<float>&, int, double);
template StrainPeak strain_peak<double>(const RodBatch<double>&, int, double);
template double max_strain<float>(const RodBatch<float>&, int, double);
template double max_strain<double>(const RodBatch<double>&, int, double);

}  // namespace manyrods
