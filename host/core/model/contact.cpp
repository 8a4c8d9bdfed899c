// host/core/model/contact.cpp — giving a batch its colliders (set_contact: validation,
// the per-element contact data, the starting-state checks), placing the
// colliders for a step, and contact statistics (include/manyrods/contact.h,
// docs/contact.md). The rod–rod broad phase is host/core/step/broad_phase.cpp.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "host/core/step/contact_stage.h"
#include "host/core/step/implicit_plan.h"
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
  if (spec.max_capacity < spec.capacity)
    throw InputError("contact: max_capacity (" + std::to_string(spec.max_capacity) + ") must be >= capacity (" +
                     std::to_string(spec.capacity) + ")");
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
        const int kb = c.neighbours[std::size_t(k) * std::size_t(c.capacity) + std::size_t(j)];
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
  auto allocate = [n](auto& a, auto fill) {  // (one array, or one per component)
    if constexpr (requires { a.resize(n, fill); })
      a.resize(n, fill);
    else
      for (auto& component : a) component.resize(n, fill);
  };
#define MANYRODS_CONTACT_ALLOCATE_VIEW(type, name, view, components, fill, doc) allocate(c.name, type(fill));
#define MANYRODS_CONTACT_ALLOCATE_OWN(type, name, components, fill, doc) allocate(c.name, type(fill));
  MANYRODS_CONTACT_VIEW_FIELDS(MANYRODS_CONTACT_ALLOCATE_VIEW)
  MANYRODS_CONTACT_OWN_FIELDS(MANYRODS_CONTACT_ALLOCATE_OWN)
#undef MANYRODS_CONTACT_ALLOCATE_VIEW
#undef MANYRODS_CONTACT_ALLOCATE_OWN
  c.capacity = spec.capacity;
  c.list_growths = 0;
  c.solve_sweeps = c.solve_steps = c.solve_stalled = 0;
  c.solve_sweeps_max = 0;
  c.solve_impulses.assign(std::size_t(b.rod_count()), {});
  if (spec.rod_rod || spec.self) c.neighbours.resize(n * std::size_t(c.capacity), -1);
  c.rod_mu.assign(4 * std::size_t(b.rod_count()), T(0));
  c.rod_mu_own.assign(std::size_t(b.rod_count()), 0);
  c.rod_near.assign(std::size_t(b.rod_count()), 1);
  c.rod_stiff.assign(std::size_t(b.rod_count()), 0);
  for (auto& in : c.rod_in_solve) in.assign(std::size_t(b.rod_count()), 0);
  for (int r = 0; r < b.rod_count(); ++r) {
    const RodInfo& info = b.rods[r];
    c.rod_stiff[r] = info.stiff_implicit ? 1 : 0;
    for (int kv = 0; kv < 2; ++kv) c.rod_in_solve[kv][r] = needs_implicit_solve(info, kv == 1) ? 1 : 0;
    const bool own = !spec.rod_friction.empty() && spec.rod_has_friction[r];
    to4(own ? spec.rod_friction[r] : spec.friction, c.rod_mu.data() + 4 * r);
    c.rod_mu_own[r] = own ? 1 : 0;
    double lmin = 1e300;
    for (int e = 0; e < info.elements; ++e) {
      const int k = b.elem_index(r, e);
      c.elem_radius[k] = T(info.element_radius(e));
      c.elem_rod[k] = r;
      lmin = std::min(lmin, double(b.model.elem_rest_length[k]));
      c.max_radius = std::max(c.max_radius, info.element_radius(e));
    }
    // the tightest loop a tube of radius r can make has radius r: elements
    // less than half its circumference (π r) apart along the rod touch at
    // the chord of that loop (kernels/contact.h near_contact_distance)
    double thickest = 0;
    for (int e = 0; e < info.elements; ++e) thickest = std::max(thickest, info.element_radius(e));
    c.rod_near[r] = 1 + int(std::ceil(std::numbers::pi * thickest / lmin));
  }
  b.contact = std::move(c);
  check_start_outside(b);
  check_start_apart(b);
}

template <class T>
ContactStats contact_stats(const RodBatch<T>& b, int rod_begin, int rod_end) {
  ContactStats st;
  const ContactData<T>& c = b.contact;
  if (!c.on) return st;
  st.rebuilds = c.rebuilds;
  st.list_capacity = c.capacity;
  st.list_growths = c.list_growths;
  st.solve_sweeps = c.solve_sweeps;
  st.solve_steps = c.solve_steps;
  st.solve_stalled = c.solve_stalled;
  st.solve_sweeps_max = c.solve_sweeps_max;
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
        const int kb = c.neighbours[std::size_t(k) * std::size_t(c.capacity) + std::size_t(j)];
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
  template ContactStats contact_stats<T>(const RodBatch<T>&, int, int);
MANYRODS_CONTACT_INSTANTIATE(float)
MANYRODS_CONTACT_INSTANTIATE(double)

}  // namespace manyrods
