// kernels/cuda_check.cu — compiles every per-index kernel inside a __global__
// wrapper, in float and double, with all terms on and with all optional terms
// off. It exists so that host-only code (STL, exceptions, Eigen, allocation)
// cannot creep into kernels/: such code fails to compile here. Running the
// kernels on a GPU is a later step; nothing here is launched.
#include "kernels/contact.h"
#include "kernels/energy.h"
#include "kernels/viscous_implicit.h"
#include "kernels/viscous_implicit_lanes.h"

namespace manyrods {
namespace {

constexpr Terms kBare{false, false, true, false, false, false, false};

template <unsigned kMask, class T>
__global__ void stage_kernel(int slots, ModelView<T> m, ConstStateView<T> s, ScratchView<T> out) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  constexpr Terms kT = terms_from_mask(kMask);
  if (k >= slots) return;
  element_stage<kT>(k, m, s, out);
  voronoi_stage<kT>(k, m, s, out);
}

// kEulerOrder 2: Position Verlet's kick; 4: PEFRL's (host/core/step/integrators.h).
template <unsigned kMask, int kEulerOrder, class T>
__global__ void kick_kernel(int slots, T h, ModelView<T> m, LoadsView<T> l, ConstScratchView<T> sc,
                            StateView<T> s) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  constexpr Terms kT = terms_from_mask(kMask);
  if (k >= slots) return;
  dynamic_node<kT>(k, h, m, l, sc, s);
  dynamic_element<kT, kEulerOrder>(k, h, m, l, sc, s);
}

template <class T>
__global__ void drift_kernel(int slots, T h, StateView<T> s) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= slots) return;
  kinematic_node(k, h, s);
  kinematic_element(k, h, s);
}

template <unsigned kMask, class T>
__global__ void energy_kernel(int slots, ModelView<T> m, LoadsView<T> l, ConstStateView<T> s, T* out) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  constexpr Terms kT = terms_from_mask(kMask);
  if (k >= slots) return;
  out[k] = node_kinetic_energy(k, m, s) + element_kinetic_energy(k, m, s) +
           element_elastic_energy<kT>(k, m, s) + voronoi_elastic_energy<kT>(k, m, s) +
           element_dissipation<kT>(k, m, s) + voronoi_dissipation<kT>(k, m, s) +
           node_potential_energy<kT>(k, m, l, s);
}

template <unsigned kMask, class T>
__global__ void viscous_kernel(int rods, const int* first, const int* cells, T h, ModelView<T> m,
                               StateView<T> s, ImplicitScratchView<T> sc) {
  constexpr Terms kT = terms_from_mask(kMask);
  const int r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= rods) return;
  viscous_implicit_rod<kT>(first[r], cells[r], h, kT.kelvin_voigt ? T(0) : h, m, s, sc);
}

// One thread per group of kLanes rods: group g's rod l starts at
// first[g·kLanes + l] and has cells[g·kLanes + l] cells; its elimination
// buffer is the caller's, offset by g·stride entries (stride ≥ kLanes × its
// longest rod's cells).
template <unsigned kMask, int kLanes, class T>
__global__ void viscous_lanes_kernel(int groups, const int* first, const int* cells, T h, const T* stiff_h,
                                     ModelView<T> m, StateView<T> s, ImplicitScratchView<T> sc, int stride) {
  constexpr Terms kT = terms_from_mask(kMask);
  const int g = blockIdx.x * blockDim.x + threadIdx.x;
  if (g >= groups) return;
  ImplicitScratchView<T> mine = sc;
  for (int i = 0; i < 36; ++i) mine.G[i] += g * stride;
  for (int i = 0; i < 6; ++i) mine.g[i] += g * stride;
  viscous_implicit_lanes<kT, kLanes>(first + g * kLanes, cells + g * kLanes, h, stiff_h + g * kLanes, m, s, mine);
}

// Contact (kernels/contact.h): one thread per slot for each of its three
// passes (count, impulses, apply), as host/core/step/contact_stage.h runs them.
template <bool kColliders, bool kRods, class T>
__global__ void contact_kernel(int slots, int pass, T h, ModelView<T> m, StateView<T> s, ContactView<T> cv) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= slots) return;
  if (pass == 0) element_contacts<kColliders, kRods, false>(k, h, m, as_const(s), cv);
  else if (pass == 1) element_contacts<kColliders, kRods, true>(k, h, m, as_const(s), cv);
  else apply_contact(k, m, s, cv);
}

template <Terms kT, class T>
void instantiate() {
  constexpr unsigned mask = terms_mask(kT);
  (void)&stage_kernel<mask, T>;
  (void)&kick_kernel<mask, 2, T>;
  (void)&kick_kernel<mask, 4, T>;
  (void)&drift_kernel<T>;
  (void)&energy_kernel<mask, T>;
  (void)&viscous_kernel<mask, T>;
  (void)&viscous_lanes_kernel<mask, 8, T>;
  (void)&viscous_lanes_kernel<mask, 16, T>;
  (void)&contact_kernel<true, true, T>;
  (void)&contact_kernel<true, false, T>;
}

}  // namespace

void cuda_check_instantiate_all() {
  instantiate<kAllTerms, float>();
  instantiate<kAllTerms, double>();
  instantiate<kBare, float>();
  instantiate<kBare, double>();
}

}  // namespace manyrods
