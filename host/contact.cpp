// host/contact.cpp — giving a batch its colliders (set_contact), placing them
// for a step, the rod–rod broad phase, and contact statistics
// (include/manyrods/contact.h, docs/contact.md).
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <sstream>

#include "host/contact_stage.h"
#include "kernels/views.h"
#include "manyrods/material.h"

namespace manyrods {
namespace {

const char* kind_name(ColliderKind k) {
  switch (k) {
    case ColliderKind::plane: return "plane";
    case ColliderKind::sphere: return "sphere";
    case ColliderKind::capsule: return "capsule";
    default: return "mesh";
  }
}

std::string collider_label(const ContactSpec& spec, std::size_t i) {
  std::ostringstream os;
  os << "collider " << i;
  if (!spec.colliders[i].name.empty()) os << " ('" << spec.colliders[i].name << "')";
  os << ", " << kind_name(spec.colliders[i].kind);
  return os.str();
}

void check_friction(const Friction& f, const std::string& where) {
  auto bad = [&](const std::string& what) { throw InputError(where + ": friction " + what); };
  auto finite_nonneg = [](double x) { return std::isfinite(x) && x >= 0; };
  if (!finite_nonneg(f.static_coefficient)) bad("static coefficient must be a finite number >= 0");
  if (!finite_nonneg(f.kinetic_coefficient)) bad("kinetic coefficient must be a finite number >= 0");
  if (f.kinetic_coefficient > f.static_coefficient)
    bad("kinetic coefficient (" + std::to_string(f.kinetic_coefficient) + ") exceeds the static one (" +
        std::to_string(f.static_coefficient) + ")");
  const bool sa = f.static_axial >= 0, ka = f.kinetic_axial >= 0;
  if (!std::isfinite(f.static_axial) || !std::isfinite(f.kinetic_axial) || (f.static_axial < 0 && f.static_axial != -1) ||
      (f.kinetic_axial < 0 && f.kinetic_axial != -1))
    bad("axial coefficients must be >= 0 (or -1: isotropic)");
  if (sa != ka) bad("give both axial coefficients (static and kinetic) or neither");
  if (sa && f.kinetic_axial > f.static_axial) bad("kinetic axial coefficient exceeds the static axial one");
}

void check_collider(const ContactSpec& spec, std::size_t i) {
  const Collider& c = spec.colliders[i];
  const std::string where = "contact: " + collider_label(spec, i);
  auto finite = [](const Vec3& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); };
  auto bad = [&](const std::string& what) { throw InputError(where + ": " + what); };
  switch (c.kind) {
    case ColliderKind::plane:
      if (!finite(c.point) || !finite(c.normal)) bad("point and normal must be finite");
      if (!(std::hypot(c.normal[0], c.normal[1], c.normal[2]) > 0)) bad("normal must not be zero");
      break;
    case ColliderKind::sphere:
      if (!finite(c.center)) bad("center must be finite");
      if (!(c.radius > 0 && std::isfinite(c.radius))) bad("radius must be > 0");
      break;
    case ColliderKind::capsule:
      if (!finite(c.a) || !finite(c.b)) bad("a and b must be finite");
      if (!(c.radius > 0 && std::isfinite(c.radius))) bad("radius must be > 0");
      break;
    case ColliderKind::mesh:
      if (!c.grid || c.grid->phi.empty()) bad("has no distance grid (load_mesh_grid)");
      break;
  }
  check_friction(c.friction, where);
  if (c.motion) c.motion->validate();
}

void check_spec(const ContactSpec& spec, int rods) {
  for (std::size_t i = 0; i < spec.colliders.size(); ++i) check_collider(spec, i);
  check_friction(spec.friction, "contact");
  if (!(spec.hardness > 0 && std::isfinite(spec.hardness)))
    throw InputError("contact: hardness must be > 0 (got " + std::to_string(spec.hardness) + ")");
  if (!(spec.damping_ratio >= 0 && std::isfinite(spec.damping_ratio)))
    throw InputError("contact: damping_ratio must be >= 0 (got " + std::to_string(spec.damping_ratio) + ")");
  if (!(spec.skin >= 0 && std::isfinite(spec.skin)))
    throw InputError("contact: skin must be >= 0 (0: automatic)");
  if (spec.capacity < 1) throw InputError("contact: capacity must be >= 1");
  if (!spec.rod_friction.empty() && int(spec.rod_friction.size()) != rods)
    throw InputError("contact: rod_friction has " + std::to_string(spec.rod_friction.size()) + " entries for " +
                     std::to_string(rods) + " rods");
  if (spec.rod_has_friction.size() != spec.rod_friction.size())
    throw InputError("contact: rod_has_friction and rod_friction differ in length");
  for (std::size_t r = 0; r < spec.rod_friction.size(); ++r)
    if (spec.rod_has_friction[r]) check_friction(spec.rod_friction[r], "contact: rod " + std::to_string(r));
}

template <class T>
void to4(const Friction& f, T* out) {
  out[0] = T(f.static_coefficient);
  out[1] = T(f.kinetic_coefficient);
  out[2] = T(f.static_axial);
  out[3] = T(f.kinetic_axial);
}

using E3 = Eigen::Vector3d;
using EM3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
E3 e3(const Vec3& v) { return {v[0], v[1], v[2]}; }
EM3 em3(const Mat3& m) { return Eigen::Map<const EM3>(m.data()); }

template <class T>
void put(T* dst, const E3& v) {
  for (int i = 0; i < 3; ++i) dst[i] = T(v[i]);
}

// Checks that no element starts inside a collider by more than 1 % of its radius.
template <class T>
void check_start_outside(RodBatch<T>& b) {
  ContactData<T>& c = b.contact;
  if (c.spec.colliders.empty()) return;
  std::vector<ColliderFrame<T>> frames(c.spec.colliders.size());
  place_colliders(c, b.state.time, 0.0, frames.data());
  const ConstStateView<T> s = std::as_const(b).state_view();
  for (int r = 0; r < b.rod_count(); ++r)
    for (int e = 0; e < b.elements(r); ++e) {
      const int k = b.elem_index(r, e);
      const T rad = c.elem_radius[k];
      for (std::size_t i = 0; i < frames.size(); ++i) {
        const Touch<T> t = deepest_touch(frames[i], load3(s.node_x, k), load3(s.node_x, k + 1), rad);
        if (t.gap < T(-0.01) * rad) {
          std::ostringstream os;
          os.precision(6);
          os << "contact: rod " << r << " ('" << b.rods[r].name << "') node " << (t.s < T(0.5) ? e : e + 1)
             << " starts inside " << collider_label(c.spec, i) << ": overlap " << double(-t.gap)
             << " m, more than 1 % of the rod's radius " << double(rad)
             << " m (move the rod or the collider; docs/contact.md \"Starting states\")";
          throw InputError(os.str());
        }
      }
    }
}

// No two elements that may touch start overlapping (by more than 1 % of
// their radii): held rods could never separate, and free ones would be
// thrown apart in the first step. Builds the first lists.
template <class T>
void check_start_apart(RodBatch<T>& b) {
  ContactData<T>& c = b.contact;
  if (!(c.spec.rod_rod || c.spec.self)) return;
  update_neighbours(b, T(0), Exec{1});
  const ConstStateView<T> s = std::as_const(b).state_view();
  for (int r = 0; r < b.rod_count(); ++r)
    for (int e = 0; e < b.elements(r); ++e) {
      const int k = b.elem_index(r, e);
      for (int j = 0; j < c.neighbour_count[k]; ++j) {
        const int kb = c.neighbours[std::size_t(k) * std::size_t(c.spec.capacity) + std::size_t(j)];
        if (kb < k) continue;
        const T gap =
            pair_geometry(k, kb, s.node_x, c.elem_radius.data(), pair_near(k, kb, c.elem_rod.data(), c.rod_near.data())).gap;
        if (!(gap < T(-0.01) * (c.elem_radius[k] + c.elem_radius[kb]))) continue;
        const int rb = c.elem_rod[kb];
        std::ostringstream os;
        os.precision(6);
        os << "contact: rod " << r << " ('" << b.rods[r].name << "') element " << e << " starts overlapping rod "
           << rb << " ('" << b.rods[rb].name << "') element " << kb - b.rods[rb].offset - 1 << " by "
           << double(-gap) << " m, more than 1 % of their radii (move the rods apart; docs/contact.md \"Starting states\")";
        throw InputError(os.str());
      }
    }
}

}  // namespace

template <class T>
void place_colliders(const ContactData<T>& c, double t, double h, ColliderFrame<T>* out) {
  for (std::size_t i = 0; i < c.spec.colliders.size(); ++i) {
    const Collider& col = c.spec.colliders[i];
    ColliderFrame<T>& f = out[i];
    f = ColliderFrame<T>{};
    f.kind = int(col.kind);
    EM3 R = EM3::Identity();
    E3 cm = E3::Zero();
    if (col.motion) {
      f.moving = h > 0 ? 1 : 0;
      const Pose mid = col.motion->at(t + 0.5 * h);
      R = em3(mid.rotation);
      cm = e3(mid.translation);
      if (h > 0) {
        const Pose a = col.motion->at(t), e = col.motion->at(t + h);
        const EM3 A = (em3(e.rotation) - em3(a.rotation)) * R.transpose() / h;
        for (int j = 0; j < 9; ++j) f.A[j] = T(A(j / 3, j % 3));
        put(f.u, E3((e3(e.translation) - e3(a.translation)) / h));
      }
    }
    for (int j = 0; j < 9; ++j) f.R[j] = T(R(j / 3, j % 3));
    put(f.c, cm);
    const auto lab = [&](const Vec3& x) { return E3(R * e3(x) + cm); };
    switch (col.kind) {
      case ColliderKind::plane:
        put(f.p, lab(col.point));
        put(f.n, E3(R * e3(col.normal).normalized()));
        break;
      case ColliderKind::sphere: put(f.p, lab(col.center)); break;
      case ColliderKind::capsule:
        put(f.p, lab(col.a));
        put(f.q, lab(col.b));
        break;
      case ColliderKind::mesh: {
        const DistanceGrid& g = *col.grid;
        f.phi = g.phi.data();
        f.nx = g.n[0];
        f.ny = g.n[1];
        f.nz = g.n[2];
        put(f.origin, e3(g.origin));
        f.spacing = T(g.spacing);
        break;
      }
    }
    f.radius = T(col.radius);
    to4(col.friction, f.mu);
  }
}

template <class T>
void set_contact(RodBatch<T>& b, const ContactSpec& spec) {
  check_spec(spec, b.rod_count());
  ContactData<T> c;
  c.on = true;
  c.spec = spec;
  const std::size_t n = std::size_t(b.slots());
  c.elem_radius.resize(n, T(0));
  c.elem_rod.resize(n, -1);
  c.elem_count.resize(n, 0);
  c.elem_count_lo.resize(n, 0);
  c.elem_count_hi.resize(n, 0);
  c.work.resize(n, T(0));
  c.neighbour_count.resize(n, 0);
  c.elem_skin.resize(n, T(0));
  for (int d = 0; d < 3; ++d) {
    c.elem_p0[d].resize(n, T(0));
    c.elem_p1[d].resize(n, T(0));
    c.elem_l[d].resize(n, T(0));
    c.node_x_ref[d].resize(n, T(0));
  }
  if (spec.rod_rod || spec.self) c.neighbours.resize(n * std::size_t(spec.capacity), -1);
  c.rod_mu.assign(4 * std::size_t(b.rod_count()), T(0));
  c.rod_mu_own.assign(std::size_t(b.rod_count()), 0);
  c.rod_near.assign(std::size_t(b.rod_count()), 1);
  for (int r = 0; r < b.rod_count(); ++r) {
    const RodInfo& info = b.rods[r];
    const bool own = !spec.rod_friction.empty() && spec.rod_has_friction[r];
    to4(own ? spec.rod_friction[r] : spec.friction, c.rod_mu.data() + 4 * r);
    c.rod_mu_own[r] = own ? 1 : 0;
    double lmin = 1e300;
    for (int e = 0; e < info.elements; ++e) {
      const int k = b.elem_index(r, e);
      c.elem_radius[k] = T(info.contact_radius);
      c.elem_rod[k] = r;
      lmin = std::min(lmin, double(b.model.elem_rest_length[k]));
      c.max_radius = std::max(c.max_radius, info.contact_radius);
    }
    // the tightest loop a tube of radius r can make has radius r: elements
    // less than half its circumference (π r) apart along the rod touch at
    // the chord of that loop (kernels/contact.h near_contact_distance)
    c.rod_near[r] = 1 + int(std::ceil(std::numbers::pi * info.contact_radius / lmin));
  }
  b.contact = std::move(c);
  check_start_outside(b);
  check_start_apart(b);
}

// Element k's share of a pair's contact range: the kernel's
// δ_ab = h (1 + 2ζ/Ω)(v_a + v_b) + ½ (r_a + r_b) = need_a + need_b
// (kernels/contact.h element_contacts), v_k its fastest node.
template <class T>
double contact_need(const ContactData<T>& c, const ConstStateView<T>& s, int k, double reach) {
  return reach * double(contact_detail::max_speed(s, k)) + 0.5 * double(c.elem_radius[k]);
}

// how far element k's nodes moved since the last build
template <class T>
double moved_since_build(const ContactData<T>& c, const ConstStateView<T>& s, int k) {
  double m = 0;
  for (int i = k; i <= k + 1; ++i) {
    const vec3<T> d = load3(s.node_x, i) - vec3<T>{c.node_x_ref[0][i], c.node_x_ref[1][i], c.node_x_ref[2][i]};
    m = std::max(m, double(norm(d)));
  }
  return m;
}

template <class T>
void update_neighbours(RodBatch<T>& b, T h, const Exec& ex) {
  ContactData<T>& c = b.contact;
  if (!(c.spec.rod_rod || c.spec.self)) return;
  const ConstStateView<T> s = std::as_const(b).state_view();
  const int n = b.slots();
  const double reach = double(h) * (1 + 2 * c.spec.damping_ratio / c.spec.hardness);
  // The lists stay valid while every element's nodes moved less than its
  // skin's margin: a pair left out at the build had gap ≥ s_a + s_b, so now
  // gap ≥ s_a + s_b − moved_a − moved_b ≥ need_a + need_b = δ_ab.
  if (c.built) {
    int stale = 0;
    const RegionFpMode mode = RegionFpMode::of_caller();  // the caller's (host/fp_env.h)
#pragma omp parallel num_threads(ex.threads) reduction(max : stale) if (ex.threads > 1)
    {
      const RegionFpScope fp(mode);
#pragma omp for
      for (int k = 0; k < n; ++k)
        if (c.elem_rod[k] >= 0 && moved_since_build(c, s, k) + contact_need(c, s, k, reach) > double(c.elem_skin[k]))
          stale = 1;
    }
    if (!stale) return;
  }
  // Each element's reach s_k: its contact range now plus a margin for the
  // motion until the next build (ContactSpec::skin, by default half its
  // radius, and at least 2 h (1 + 2ζ/Ω) v_k, some two steps of its motion:
  // one element's speed widens its own list, not everyone's). Pairs with
  // gap < s_a + s_b are kept (at rest: 2 r for equal radii).
  std::vector<double> reach_of;  // the s_k of the real elements, for the threshold
  double lmax = 0;
  for (int k = 0; k < n; ++k) {
    if (c.elem_rod[k] < 0) continue;
    const double v = double(contact_detail::max_speed(s, k)), r = double(c.elem_radius[k]);
    const double margin = std::max(c.spec.skin > 0 ? c.spec.skin : 0.5 * r, 2 * reach * v);
    c.elem_skin[k] = T(contact_need(c, s, k, reach) + margin);
    reach_of.push_back(double(c.elem_skin[k]));
    lmax = std::max(lmax, double(norm(load3(s.node_x, k + 1) - load3(s.node_x, k))));
  }
  if (reach_of.empty()) return;
  // Elements reaching beyond the 99th percentile are "wide" (whipping tips):
  // the grid's cell is sized for the others, a wide element searches as many
  // cells as its own reach needs and hands its pairs to its narrow partners.
  const double s_max = *std::max_element(reach_of.begin(), reach_of.end());
  const std::size_t q = (reach_of.size() * 99) / 100;
  std::nth_element(reach_of.begin(), reach_of.begin() + std::ptrdiff_t(q), reach_of.end());
  const double s_thr = reach_of[q];
  // The grid holds element midpoints. A partner b with gap < s_a + s_b has
  // its closest point within s_a + s_b + r_a + r_b of a's segment and its
  // midpoint ½ l_b beyond that: per axis inside a's bounding box grown by
  // D_a = s_a + s_b,max + r_a + r_max + ½ l_max. Each element visits the
  // cells that box covers (a long, thin element visits a slab, not a cube),
  // row by row along x.
  auto mid = [&](int k, int axis) { return 0.5 * (double(s.node_x[axis][k]) + double(s.node_x[axis][k + 1])); };
  double gmin[3] = {1e300, 1e300, 1e300}, gmax[3] = {-1e300, -1e300, -1e300};
  int real = 0;
  for (int k = 0; k < n; ++k) {
    if (c.elem_rod[k] < 0) continue;
    ++real;
    for (int a = 0; a < 3; ++a) {
      gmin[a] = std::min(gmin[a], mid(k, a));
      gmax[a] = std::max(gmax[a], mid(k, a));
    }
  }
  // a dense grid over the midpoints' bounding box, at most ~4 cells per
  // element (coarser cells only add candidates the tests drop)
  double cell = 0.5 * (lmax + 2 * c.max_radius + 2 * s_thr);
  std::int64_t dim[3];
  for (;;) {
    double total = 1;
    for (int a = 0; a < 3; ++a) {
      dim[a] = std::int64_t(std::floor((gmax[a] - gmin[a]) / cell)) + 1;
      total *= double(dim[a]);
    }
    if (total <= 4.0 * real + 64) break;
    cell *= 1.25;
  }
  const double inv = 1 / cell;
  auto cell_at = [&](double x, int a) {
    const double i = std::floor((x - gmin[a]) * inv);
    return i >= 0 ? (i < double(dim[a] - 1) ? std::int64_t(i) : dim[a] - 1) : std::int64_t(0);  // NaN: 0
  };
  auto index = [&](std::int64_t x, std::int64_t y, std::int64_t z) { return std::size_t((z * dim[1] + y) * dim[0] + x); };
  auto wide = [&](int k) { return double(c.elem_skin[k]) > s_thr; };
  // counting sort by cell, each cell's elements in slot order
  c.cell_start.assign(std::size_t(dim[0] * dim[1] * dim[2]) + 1, 0);
  c.cell_slot.resize(std::size_t(real));
  std::vector<std::size_t> cell_of(std::size_t(n), 0);
  for (int k = 0; k < n; ++k) {
    if (c.elem_rod[k] < 0) continue;
    cell_of[std::size_t(k)] = index(cell_at(mid(k, 0), 0), cell_at(mid(k, 1), 1), cell_at(mid(k, 2), 2));
    ++c.cell_start[cell_of[std::size_t(k)] + 1];
  }
  for (std::size_t i = 1; i < c.cell_start.size(); ++i) c.cell_start[i] += c.cell_start[i - 1];
  {
    std::vector<int> fill(c.cell_start.begin(), c.cell_start.end() - 1);
    for (int k = 0; k < n; ++k)
      if (c.elem_rod[k] >= 0) c.cell_slot[std::size_t(fill[cell_of[std::size_t(k)]]++)] = k;
  }
  std::array<std::vector<double>, 3> cell_mid;  // the midpoints in grid order (the box test streams them)
  for (int a = 0; a < 3; ++a) {
    cell_mid[a].resize(std::size_t(real));
    for (int i = 0; i < real; ++i) cell_mid[a][std::size_t(i)] = mid(c.cell_slot[std::size_t(i)], a);
  }
  // element a's partners b with gap < s_a + s_b among the midpoints in its
  // box (a narrow a: the narrow b; a wide a: all b)
  auto gather = [&](int k, auto&& take) {
    const int ra = c.elem_rod[k];
    const double D = double(c.elem_skin[k]) + (wide(k) ? s_max : s_thr) + double(c.elem_radius[k]) + c.max_radius +
                     0.5 * lmax;
    double lo[3], hi[3];
    std::int64_t c0[3], c1[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(double(s.node_x[a][k]), double(s.node_x[a][k + 1])) - D;
      hi[a] = std::max(double(s.node_x[a][k]), double(s.node_x[a][k + 1])) + D;
      c0[a] = cell_at(lo[a], a);
      c1[a] = cell_at(hi[a], a);
    }
    for (std::int64_t cz = c0[2]; cz <= c1[2]; ++cz)
      for (std::int64_t cy = c0[1]; cy <= c1[1]; ++cy) {
        const int first = c.cell_start[index(c0[0], cy, cz)], last = c.cell_start[index(c1[0], cy, cz) + 1];
        for (int i = first; i < last; ++i) {
          const std::size_t u = std::size_t(i);
          if (!(cell_mid[0][u] >= lo[0] && cell_mid[0][u] <= hi[0] && cell_mid[1][u] >= lo[1] &&
                cell_mid[1][u] <= hi[1] && cell_mid[2][u] >= lo[2] && cell_mid[2][u] <= hi[2]))
            continue;
          const int kb = c.cell_slot[u], rb = c.elem_rod[kb];
          if (!wide(k) && wide(kb)) continue;  // handed over by kb
          if (!rod_pair_allowed(k, ra, kb, rb, c.spec.rod_rod, c.spec.self)) continue;
          // (the gap at r_a + r_b: a near pair's is larger, so the list holds it early)
          const T gap = pair_geometry(std::min(k, kb), std::max(k, kb), s.node_x, c.elem_radius.data()).gap;
          if (double(gap) < double(c.elem_skin[k]) + double(c.elem_skin[kb])) take(kb);
        }
      }
  };
  const int cap = c.spec.capacity;
  std::vector<int> count(std::size_t(n), 0);  // candidates found (may exceed cap)
  auto list = [&](int k) { return c.neighbours.data() + std::size_t(k) * std::size_t(cap); };
  const RegionFpMode mode = RegionFpMode::of_caller();
#pragma omp parallel num_threads(ex.threads) if (ex.threads > 1)
  {
    const RegionFpScope fp(mode);
#pragma omp for schedule(dynamic, kGuard)
    for (int k = 0; k < n; ++k) {
      int m = 0;
      if (c.elem_rod[k] >= 0)
        gather(k, [&](int kb) {
          if (m < cap) list(k)[m] = kb;
          ++m;
        });
      count[std::size_t(k)] = m;
    }
  }
  // the wide elements' narrow partners, handed over in (partner, wide) order
  std::vector<std::pair<int, int>> handed;
  for (int k = 0; k < n; ++k) {
    if (c.elem_rod[k] < 0 || !wide(k)) continue;
    const int m = std::min(count[std::size_t(k)], cap);
    for (int j = 0; j < m; ++j)
      if (!wide(list(k)[j])) handed.push_back({list(k)[j], k});
  }
  std::sort(handed.begin(), handed.end());
  for (const auto& [kb, k] : handed) {
    int& m = count[std::size_t(kb)];
    if (m < cap) list(kb)[m] = k;
    ++m;
  }
  // each list in slot order: the contact sums do not depend on the grid,
  // the skins or when the lists were built (docs/contact.md)
  int overflow = n;  // the first element whose list overflowed
  for (int k = 0; k < n; ++k) {
    if (count[std::size_t(k)] > cap) overflow = std::min(overflow, k);
    c.neighbour_count[k] = std::min(count[std::size_t(k)], cap);
    std::sort(list(k), list(k) + c.neighbour_count[k]);
  }
  if (overflow < n) {
    const int r = c.elem_rod[overflow];
    std::ostringstream os;
    os << "contact: element " << overflow - b.rods[r].offset - 1 << " of rod " << r << " ('" << b.rods[r].name
       << "') has " << count[std::size_t(overflow)] << " rod-rod candidates within its skin ("
       << double(c.elem_skin[overflow]) << " m), more than the capacity " << cap << ", at step " << b.state.steps
       << " (t = " << b.state.time << " s): raise the capacity ([contact] capacity) or lower the skin";
    throw std::runtime_error(os.str());
  }
  for (int d = 0; d < 3; ++d)
    for (int k = 0; k < n; ++k) c.node_x_ref[d][k] = s.node_x[d][k];
  c.built = true;
  ++c.rebuilds;
}

template <class T>
ContactStats contact_stats(const RodBatch<T>& b, int rod_begin, int rod_end) {
  ContactStats st;
  const ContactData<T>& c = b.contact;
  if (!c.on) return st;
  st.rebuilds = c.rebuilds;
  std::vector<ColliderFrame<T>> frames(c.spec.colliders.size());
  place_colliders(c, b.state.time, 0.0, frames.data());
  const ConstStateView<T> s = b.state_view();
  auto note = [&](T gap, int r, int e) {
    if (!(gap < T(0))) return;
    ++st.contacts;
    if (double(-gap) > st.max_penetration) {
      st.max_penetration = double(-gap);
      st.rod = r;
      st.element = e;
    }
  };
  if (rod_end < 0) rod_end = b.rod_count();
  for (int r = rod_begin; r < rod_end; ++r)
    for (int e = 0; e < b.elements(r); ++e) {
      const int k = b.elem_index(r, e);
      const vec3<T> x0 = load3(s.node_x, k), x1 = load3(s.node_x, k + 1);
      for (const ColliderFrame<T>& f : frames) note(deepest_touch(f, x0, x1, c.elem_radius[k]).gap, r, e);
      if (!c.built) continue;
      for (int j = 0; j < c.neighbour_count[k]; ++j) {
        const int kb = c.neighbours[std::size_t(k) * std::size_t(c.spec.capacity) + std::size_t(j)];
        if (kb < k) continue;  // each pair once, in the stage's order (lo = k)
        note(pair_geometry(k, kb, s.node_x, c.elem_radius.data(), pair_near(k, kb, c.elem_rod.data(), c.rod_near.data())).gap,
             r, e);
      }
    }
  return st;
}

#define MANYRODS_CONTACT_INSTANTIATE(T)                                                        \
  template void place_colliders<T>(const ContactData<T>&, double, double, ColliderFrame<T>*); \
  template void set_contact<T>(RodBatch<T>&, const ContactSpec&);                             \
  template void update_neighbours<T>(RodBatch<T>&, T, const Exec&);                           \
  template ContactStats contact_stats<T>(const RodBatch<T>&, int, int);
MANYRODS_CONTACT_INSTANTIATE(float)
MANYRODS_CONTACT_INSTANTIATE(double)

}  // namespace manyrods
