// include/manyrods/strain.h — the largest strain of a rod in its present
// state: how far it is from the model's small-strain range (docs/model.md
// "Validity"). Used by the validity monitor, sweeps' max_strain column and
// the strain observable.
#pragma once

#include "manyrods/batch.h"

namespace manyrods {

// Largest strain of rod `rod`: max over its elements of |σ| (shear and
// stretch, the library's element_strain) and over its joints of
// |κ − U0|·width/2 (bending and twist at the section's outer fibre).
template <class T>
double max_strain(const RodBatch<T>& b, int rod, double width);

// The same with where it is: `where` the element (stretch, shear) or the
// interior joint j (bending, twist; between elements j and j+1), and the
// largest |σ| alone with its element.
struct StrainPeak {
  double value = 0;
  int where = 0;
  bool bending = false;
  double stretch = 0;
  int stretch_element = 0;
};
template <class T>
StrainPeak strain_peak(const RodBatch<T>& b, int rod, double width);

}  // namespace manyrods
