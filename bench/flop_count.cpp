// bench/flop_count.cpp — floating-point operations per element-step, counted
// from the code: the kernels are instantiated with a number type that counts
// every +, −, ×, ÷ and √ (a fused multiply-add counts as its × and its +,
// as peak FLOP/s counts it). One interior slot of a clamped rod is counted on
// the branch-free (vectorized) paths, which every slot takes unless a joint
// or a drift turns by more than ½ rad.
//
// usage: manyrods-flops   (prints a table; bench/RESULTS.md quotes it)
#include <algorithm>
#include <cstdio>
#include <vector>

#include "kernels/viscous_implicit_partitioned.h"
#include "host/core/advanced.h"

namespace {

struct Count {
  long add = 0, mul = 0, div = 0, sqrt = 0;  // sqrt: also sin, cos, atan2
  long total() const { return add + mul + div + sqrt; }
};
Count g;

// A double that counts the arithmetic done on it.
struct F {
  double v = 0;
  F() = default;
  F(double x) : v(x) {}  // NOLINT: literals T(1) etc. in the kernels
  friend F operator+(F a, F b) { ++g.add; return a.v + b.v; }
  friend F operator-(F a, F b) { ++g.add; return a.v - b.v; }
  friend F operator*(F a, F b) { ++g.mul; return a.v * b.v; }
  friend F operator/(F a, F b) { ++g.div; return a.v / b.v; }
  friend F operator-(F a) { return -a.v; }  // sign flip: free
  F& operator+=(F b) { ++g.add; v += b.v; return *this; }
  F& operator-=(F b) { ++g.add; v -= b.v; return *this; }
  friend bool operator<(F a, F b) { return a.v < b.v; }
  friend bool operator<=(F a, F b) { return a.v <= b.v; }
  friend bool operator>(F a, F b) { return a.v > b.v; }
  friend bool operator>=(F a, F b) { return a.v >= b.v; }
  friend bool operator==(F a, F b) { return a.v == b.v; }
  friend F sqrt(F a) { ++g.sqrt; return std::sqrt(a.v); }
  // general (large-angle) paths only; counted as one operation each
  friend F sin(F a) { ++g.sqrt; return std::sin(a.v); }
  friend F cos(F a) { ++g.sqrt; return std::cos(a.v); }
  friend F atan2(F a, F b) { ++g.sqrt; return std::atan2(a.v, b.v); }
};

using namespace manyrods;

// Copies of a double batch's arrays as F, and views on them.
struct Mirror {
  std::vector<std::vector<F>> store;
  const F* add(const Array<double>& a, int slots) {
    std::vector<F> v(slots + 2 * kGuard);
    for (int k = -kGuard; k < slots + kGuard; ++k) v[k + kGuard] = a[k];
    store.push_back(std::move(v));
    return store.back().data() + kGuard;
  }
  F* add_mut(const Array<double>& a, int slots) { return const_cast<F*>(add(a, slots)); }
};

template <Terms kT>
void count(const char* name) {
  // 6 elements are counted (kernels on the first 7 cells); the rod is
  // 4 × 64 long for the partitioned solve
  constexpr int kParts = 4, kLong = kParts * 64;
  RodSpec s = RodSpec::straight({0, 0, 0}, {1, 0.2, 0.1}, {0, 0, 1}, 0.3 * kLong / 6, kLong);
  s.section = Section::rectangle(0.01, 0.01);
  s.material = {1000, 1e6, 0.3};
  s.damping = Damping::shear_extension(0.02, 0.02);
  s.clamped_root = true;
  auto b = build_batch<double>({s}, {0, 0, -9.81});
  for (int j = 1; j <= 6; ++j) b.set_velocity(0, j, {0.01 * j, -0.02, 0.03});
  for (int e = 0; e < 6; ++e) b.set_angular_velocity(0, e, {0.3, -0.1 * e, 0.2});
  const int S = b.slots();
  Mirror mr;
  mr.store.reserve(200);
  ModelView<F> m{};
  m.node_mass = mr.add(b.model.node_mass, S);
  m.node_inv_mass = mr.add(b.model.node_inv_mass, S);
  m.elem_rest_length = mr.add(b.model.elem_rest_length, S);
  m.vor_rest_length = mr.add(b.model.vor_rest_length, S);
  for (int i = 0; i < 3; ++i) {
    m.elem_stiffness[i] = mr.add(b.model.elem_stiffness[i], S);
    m.elem_rest_strain[i] = mr.add(b.model.elem_rest_strain[i], S);
    m.elem_tau[i] = mr.add(b.model.elem_tau[i], S);
    m.elem_inertia[i] = mr.add(b.model.elem_inertia[i], S);
    m.elem_inv_inertia[i] = mr.add(b.model.elem_inv_inertia[i], S);
    m.vor_stiffness[i] = mr.add(b.model.vor_stiffness[i], S);
    m.vor_rest_curvature[i] = mr.add(b.model.vor_rest_curvature[i], S);
    m.vor_tau[i] = mr.add(b.model.vor_tau[i], S);
  }
  m.gravity = {F(0), F(0), F(-9.81)};
  StateView<F> st{};
  ScratchView<F> sc{};
  LoadsView<F> l{};
  for (int i = 0; i < 3; ++i) {
    st.node_x[i] = mr.add_mut(b.state.node_x[i], S);
    st.node_v[i] = mr.add_mut(b.state.node_v[i], S);
    st.elem_w[i] = mr.add_mut(b.state.elem_w[i], S);
    sc.elem_force[i] = mr.add_mut(b.scratch.elem_force[i], S);
    sc.elem_couple[i] = mr.add_mut(b.scratch.elem_couple[i], S);
    sc.vor_moment[i] = mr.add_mut(b.scratch.vor_moment[i], S);
    sc.vor_kxm[i] = mr.add_mut(b.scratch.vor_kxm[i], S);
    l.node_force[i] = mr.add(b.loads.node_force[i], S);
    l.elem_couple[i] = mr.add(b.loads.elem_couple[i], S);
  }
  for (int i = 0; i < 9; ++i) st.elem_Q[i] = mr.add_mut(b.state.elem_Q[i], S);
  const int k = b.elem_index(0, 3);  // an interior element, node and joint
  const F h = 1e-5;
  auto measure = [&](auto&& f) {
    g = {};
    f();
    return g;
  };
  const Count drift = measure([&] {
    kinematic_node(k, F(0.5) * h, st);
    kinematic_element_small(k, F(0.5) * h, st);
  });
  const Count res = measure([&] {
    element_stage<kT>(k, m, as_const(st), sc);
    voronoi_stage_small<kT>(k, m, as_const(st), sc);
  });
  const Count kick = measure([&] {
    dynamic_node<kT>(k, h, m, l, as_const(sc), st);
    dynamic_element<kT>(k, h, m, l, as_const(sc), st);
  });
  const long total = 2 * drift.total() + res.total() + kick.total();
  long visc = 0, visc_lanes = 0, visc_lanes_div = 0, visc_parts = 0;
  if constexpr (kT.kelvin_voigt) {
    ImplicitScratchView<F> isc{};
    std::vector<std::vector<F>> arrays(42, std::vector<F>(S + 2 * kGuard));
    for (int i = 0; i < 36; ++i) isc.G[i] = arrays[i].data() + kGuard;
    for (int i = 0; i < 6; ++i) isc.g[i] = arrays[36 + i].data() + kGuard;
    const Count v = measure([&] { viscous_implicit_rod<kT>(b.rods[0].offset + 1, 7, h, F(0), m, st, isc); });
    visc = v.total() / 7;  // per cell (node + element)
    // the rod-per-lane kernel: 8 lanes on the same rod (the count does not
    // depend on the lane count), per lane and cell of the rod; it also runs
    // the rod's root ghost cell (1 in 8 here, 1 in 33 for hair)
    constexpr int kW = 8;
    std::vector<std::vector<F>> lane_arrays(63, std::vector<F>(kW * 8));  // cells + the root ghost cell
    ImplicitScratchView<F> lsc{};
    for (int i = 0; i < 36; ++i) lsc.G[i] = lane_arrays[i].data();
    for (int i = 0; i < 6; ++i) lsc.g[i] = lane_arrays[36 + i].data();
    for (int i = 0; i < 21; ++i) lsc.L[i] = lane_arrays[42 + i].data();
    int first[kW], cells[kW];
    F stiff_h[kW];
    for (int l = 0; l < kW; ++l) first[l] = b.rods[0].offset + 1, cells[l] = 7, stiff_h[l] = F(0);
    const Count vl = measure([&] { viscous_implicit_lanes<kT, kW>(first, cells, h, stiff_h, m, st, lsc); });
    visc_lanes = vl.total() / (7 * kW);
    visc_lanes_div = (vl.div + vl.sqrt) / (7 * kW);
    // the partitioned solve of one long rod (kernels/viscous_implicit_partitioned.h):
    // k = 64 cells per partition, one partition per lane (kW lanes), per cell
    // of the rod: both passes of the lanes, and the separators' system
    constexpr int k = 64;
    std::vector<std::vector<F>> part_arrays(78, std::vector<F>(kW * (k + 1)));
    std::vector<std::vector<F>> out_arrays(kPartitionOut, std::vector<F>(kParts + 1));
    std::vector<F> work(78 * (kParts + 1));
    std::vector<std::vector<F>> xs(6, std::vector<F>(kParts + 1));
    PartitionScratchView<F> psc{};
    for (int i = 0; i < 36; ++i) psc.e.G[i] = part_arrays[i].data();
    for (int i = 0; i < 6; ++i) psc.e.g[i] = part_arrays[36 + i].data();
    for (int i = 0; i < 36; ++i) psc.H[i] = part_arrays[42 + i].data();
    for (int i = 0; i < kPartitionOut; ++i) psc.out[i] = out_arrays[i].data();
    F* x[6];
    for (int i = 0; i < 6; ++i) x[i] = xs[i].data();
    int part[kW];
    for (int l = 0; l < kW; ++l) part[l] = std::min(l, kParts - 1);  // (lanes beyond the rod repeat its last partition)
    const int rod_cells = kParts * k, first_cell = b.rods[0].offset + 1;
    const Count pf = measure([&] { partitioned_forward<kT, kW>(first_cell, rod_cells, k, part, h, F(0), m, st, psc); });
    const Count pr = measure([&] { partitioned_reduced(first_cell, rod_cells, k, m, st, psc, x, work.data()); });
    const Count pb = measure([&] { partitioned_back<kW>(first_cell, rod_cells, k, part, st, psc, x); });
    visc_parts = (pf.total() + pb.total()) / (kW * k) + pr.total() / rod_cells;
  }
  std::printf("%-22s drift %4ld  resultants %4ld  kick %4ld  step %4ld FLOP per element-step (div %ld, sqrt %ld)",
              name, drift.total(), res.total(), kick.total(), total,
              2 * drift.div + res.div + kick.div, 2 * drift.sqrt + res.sqrt + kick.sqrt);
  if (visc)
    std::printf("; implicit viscous solve %ld per element (rod per lane: %ld, of which %ld div/sqrt; "
                "one long rod in partitions: %ld)",
                visc, visc_lanes, visc_lanes_div, visc_parts);
  std::printf("\n");
}

}  // namespace

int main() {
  count<Terms{true, true, true, true, false, true, true}>("no Kelvin-Voigt");
  count<kAllTerms>("Kelvin-Voigt");
  std::printf("(explicit KV: the step column; implicit KV: the step column without the viscous rates plus the solve)\n");
}
