// host/capi/c_api.cpp — the C API (include/manyrods/manyrods_c.h) over AnyBatch
// (include/manyrods/any_batch.h): a handle per batch, every call wrapped so
// that no exception crosses into C (guard: the exception's type becomes the
// mr_status, its message the thread's mr_last_error).
#include "manyrods/manyrods_c.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "manyrods/any_batch.h"
#include "manyrods/h5io.h"
#include "manyrods/material.h"
#include "manyrods/scene.h"
#include "manyrods/step.h"

#if !defined(MANYRODS_VERSION) || !defined(MANYRODS_VERSION_NUMBER)
#error "MANYRODS_VERSION and MANYRODS_VERSION_NUMBER (the project's version) must be defined by the build"
#endif
static_assert(MR_VERSION == MANYRODS_VERSION_NUMBER, "manyrods_c.h: MR_VERSION_* is not the project's version");
// mr_energies holds every entry of MANYRODS_ENERGY_FIELDS (copied by name in
// mr_batch_energies) and nothing else.
#define MANYRODS_ENERGY_COUNT(name, dataset, unit, written, doc) +1
static_assert(sizeof(mr_energies) == sizeof(double) * (0 MANYRODS_ENERGY_FIELDS(MANYRODS_ENERGY_COUNT)),
              "manyrods_c.h: mr_energies is not the list of include/manyrods/step.h MANYRODS_ENERGY_FIELDS");
#undef MANYRODS_ENERGY_COUNT
// mr_state_view and mr_loads_view end with a pointer per entry of
// MANYRODS_PUBLIC_ARRAYS of their group (filled by name below) and nothing else.
#define MANYRODS_COUNT_ARRAY(group, field, name, doc) +(std::string_view(#group) == "state" ? 1 : 0)
static_assert(sizeof(mr_state_view) ==
                  offsetof(mr_state_view, node_position) + sizeof(void*) * (0 MANYRODS_PUBLIC_ARRAYS(MANYRODS_COUNT_ARRAY)),
              "manyrods_c.h: mr_state_view is not the state entries of MANYRODS_PUBLIC_ARRAYS");
#undef MANYRODS_COUNT_ARRAY
#define MANYRODS_COUNT_ARRAY(group, field, name, doc) +(std::string_view(#group) == "loads" ? 1 : 0)
static_assert(sizeof(mr_loads_view) ==
                  offsetof(mr_loads_view, node_force) + sizeof(void*) * (0 MANYRODS_PUBLIC_ARRAYS(MANYRODS_COUNT_ARRAY)),
              "manyrods_c.h: mr_loads_view is not the loads entries of MANYRODS_PUBLIC_ARRAYS");
#undef MANYRODS_COUNT_ARRAY

struct mr_batch {
  manyrods::scene::AnyBatch b;
  int threads = 1;
  bool force_dt = false;
};

namespace {

using manyrods::InputError;
using manyrods::Mat3;
using manyrods::RodSpec;
using manyrods::Vec3;
using manyrods::scene::AnyBatch;

thread_local std::string last_error;

mr_status fail(mr_status s, std::string msg) {
  last_error = std::move(msg);
  return s;
}

// Runs f (returning void), turning exceptions into a status and message.
template <class F>
mr_status guard(F&& f) noexcept {
  try {
    f();
    return MR_OK;
  } catch (const manyrods::NonFiniteError& e) {
    return fail(MR_ERROR_NON_FINITE, e.what());
  } catch (const manyrods::scene::StaticError& e) {
    return fail(MR_ERROR_NO_EQUILIBRIUM, e.what());
  } catch (const InputError& e) {
    return fail(MR_ERROR_INPUT, e.what());
  } catch (const manyrods::scene::SceneError& e) {
    return fail(MR_ERROR_INPUT, e.what());
  } catch (const manyrods::h5::H5Error& e) {
    return fail(MR_ERROR_IO, e.what());
  } catch (const std::bad_alloc&) {
    return fail(MR_ERROR_MEMORY, "out of memory");
  } catch (const std::exception& e) {
    return fail(MR_ERROR_INTERNAL, e.what());
  } catch (...) {
    return fail(MR_ERROR_INTERNAL, "an unknown error");
  }
}

#define MR_CHECK_ARG(cond, msg) \
  if (!(cond)) return fail(MR_ERROR_ARGUMENT, std::string(__func__) + ": " + (msg))

void set_end(RodSpec& r, bool root, mr_end e, std::size_t i) {
  if (e != MR_END_FREE && e != MR_END_CLAMPED && e != MR_END_PINNED)
    throw InputError("rod " + std::to_string(i) + ": " + (root ? "root" : "tip") + " is not an mr_end (got " +
                     std::to_string(int(e)) + ")");
  manyrods::set_end_hold(r, root ? manyrods::RodEnd::root : manyrods::RodEnd::tip,
                         e == MR_END_CLAMPED  ? std::optional(manyrods::HoldKind::clamped)
                         : e == MR_END_PINNED ? std::optional(manyrods::HoldKind::pinned)
                                              : std::nullopt);
}

manyrods::Section section_of(const mr_rod_desc& d, std::size_t i) {
  switch (d.shape) {
    case MR_CIRCLE: return manyrods::Section::circle(d.section_a);
    case MR_ELLIPSE: return manyrods::Section::ellipse(d.section_a, d.section_b);
    case MR_RECTANGLE: return manyrods::Section::rectangle(d.section_a, d.section_b);
    case MR_HOLLOW_CIRCLE: return manyrods::Section::hollow_circle(d.section_a, d.section_b);
  }
  throw InputError("rod " + std::to_string(i) + ": shape is not an mr_shape (got " + std::to_string(int(d.shape)) + ")");
}

// A held end on the host motion `name` (NULL: static). Rods naming one
// driver share it: AnyBatch::from_rods merges host motions by name.
std::shared_ptr<const manyrods::RootMotion> driver(const char* name) {
  return name ? std::make_shared<manyrods::HostMotion>(name) : nullptr;
}

RodSpec rod_of(const mr_rod_desc& d, std::size_t i) {
  const std::string at = "rod " + std::to_string(i) + ": ";
  if (d.elements < 1) throw InputError(at + "elements must be >= 1 (got " + std::to_string(d.elements) + ")");
  if (!d.nodes) throw InputError(at + "nodes is NULL (elements + 1 points, x y z interleaved)");
  std::vector<Vec3> x(std::size_t(d.elements) + 1);
  for (std::size_t k = 0; k < x.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      x[k][c] = d.nodes[3 * k + c];
      if (!std::isfinite(x[k][c])) throw InputError(at + "node " + std::to_string(k) + " is not finite");
    }
  std::vector<Mat3> q(std::size_t(d.elements));
  if (d.frames) {
    for (std::size_t k = 0; k < q.size(); ++k)
      for (int c = 0; c < 9; ++c) q[k][c] = d.frames[9 * k + c];
  } else {
    const Vec3 n{d.first_normal[0], d.first_normal[1], d.first_normal[2]};
    try {
      q = RodSpec::parallel_transport_frames(x, n);
    } catch (const InputError& e) {
      throw InputError(at + e.what());
    }
  }
  RodSpec r = RodSpec::polyline(std::move(x), std::move(q));
  r.name = "rod " + std::to_string(i);
  r.section = section_of(d, i);
  r.material.density = d.density;
  r.material.youngs_modulus = d.youngs_modulus;
  r.material.poisson_ratio = d.poisson_ratio;
  r.material.shear_modulus = d.shear_modulus;
  if (d.tau_shear != 0 || d.tau_extension != 0)
    r.damping = manyrods::Damping::shear_extension(d.tau_shear, d.tau_extension);
  set_end(r, true, d.root, i);
  set_end(r, false, d.tip, i);
  r.root_motion = driver(d.root_driver);
  r.tip_motion = driver(d.tip_driver);
  if (r.root_motion && d.root == MR_END_FREE) throw InputError(at + "root_driver needs a held root (clamped or pinned)");
  if (r.tip_motion && d.tip == MR_END_FREE) throw InputError(at + "tip_driver needs a held tip (clamped or pinned)");
  r.stiff_implicit = d.stiff != 0;
  r.preload = d.preload != 0;
  if (d.section_scale) r.section_scale.assign(d.section_scale, d.section_scale + d.elements);
  return r;
}

// Rod r's nodes in the all-nodes order (the rods' nodes, one rod after another).
std::size_t first_node(const AnyBatch& b, int rod) {
  std::size_t n = 0;
  for (int r = 0; r < rod; ++r) n += std::size_t(b.elements(r)) + 1;
  return n;
}

template <class Out>
mr_status copy_positions(const mr_batch* b, Out* xyz, std::size_t count, const char* fn) {
  if (!b || !xyz) return fail(MR_ERROR_ARGUMENT, std::string(fn) + ": a NULL argument");
  const std::size_t nodes = std::size_t(b->b.node_count());
  if (count < nodes)
    return fail(MR_ERROR_ARGUMENT, std::string(fn) + ": room for " + std::to_string(count) + " nodes, the batch has " +
                                       std::to_string(nodes));
  b->b.visit([&](const auto& rb) {
    std::size_t o = 0;
    for (int r = 0; r < rb.rod_count(); ++r) {
      const int first = b->b.node_slot(r, 0), n = rb.elements(r) + 1;
      for (int i = 0; i < n; ++i, ++o)
        for (int c = 0; c < 3; ++c) xyz[3 * o + std::size_t(c)] = Out(rb.state.node_x[c][first + i]);
    }
  });
  return MR_OK;
}

template <class T>
mr_precision precision_of(const manyrods::RodBatch<T>&) {
  return std::is_same_v<T, float> ? MR_FLOAT : MR_DOUBLE;
}

template <class T, std::size_t N>
std::size_t stride_of(const std::array<manyrods::Array<T>, N>& a) {
  return std::size_t(a[1].data() - a[0].data());
}

}  // namespace

extern "C" {

const char* mr_last_error(void) { return last_error.c_str(); }
int mr_version(void) { return MR_VERSION; }
const char* mr_version_string(void) { return MANYRODS_VERSION; }
int mr_abi_version(void) { return MR_ABI_VERSION; }

mr_status mr_batch_create_from_scene(const char* path, mr_batch** out) {
  MR_CHECK_ARG(path && out, "a NULL argument");
  *out = nullptr;
  if (std::FILE* f = std::fopen(path, "rb")) std::fclose(f);
  else return fail(MR_ERROR_IO, std::string(path) + ": cannot read the scene file (" + std::strerror(errno) + ")");
  return guard([&] {
    auto b = std::make_unique<mr_batch>(mr_batch{AnyBatch::from_scene(manyrods::scene::load_scene(path)), 1});
    *out = b.release();
  });
}

void mr_default_rod_desc(mr_rod_desc* rod) {
  if (!rod) return;
  *rod = mr_rod_desc{};
  rod->elements = 10;
  rod->nodes = nullptr;
  rod->frames = nullptr;
  rod->shape = MR_CIRCLE;
  rod->section_a = 0.01;
  rod->section_b = 0.01;
  rod->density = 1000;
  rod->youngs_modulus = 1e6;
  rod->poisson_ratio = 0.5;
  rod->shear_modulus = std::numeric_limits<double>::quiet_NaN();
  rod->root = MR_END_CLAMPED;
  rod->tip = MR_END_FREE;
}

void mr_default_batch_settings(mr_batch_settings* s) {
  if (!s) return;
  *s = mr_batch_settings{};
  s->precision = MR_DOUBLE;
  s->gravity[2] = -9.81;
}

mr_status mr_batch_create(const mr_rod_desc* rods, size_t count, const mr_batch_settings* settings, mr_batch** out) {
  MR_CHECK_ARG(rods && out, "a NULL argument");
  MR_CHECK_ARG(count > 0, "a batch needs at least one rod (count = 0)");
  *out = nullptr;
  mr_batch_settings st;
  mr_default_batch_settings(&st);
  if (settings) st = *settings;
  MR_CHECK_ARG(st.precision == MR_DOUBLE || st.precision == MR_FLOAT, "precision is not an mr_precision");
  return guard([&] {
    std::vector<RodSpec> specs;
    specs.reserve(count);
    for (std::size_t i = 0; i < count; ++i) specs.push_back(rod_of(rods[i], i));
    const auto p = st.precision == MR_FLOAT ? manyrods::scene::Precision::float32 : manyrods::scene::Precision::float64;
    auto b = std::make_unique<mr_batch>(
        mr_batch{AnyBatch::from_rods(std::move(specs), p, {st.gravity[0], st.gravity[1], st.gravity[2]}), 1});
    *out = b.release();
  });
}

void mr_batch_destroy(mr_batch* b) { delete b; }

mr_status mr_batch_step(mr_batch* b, double dt, int count) {
  MR_CHECK_ARG(b, "a NULL batch");
  MR_CHECK_ARG(dt > 0 && std::isfinite(dt), "dt must be > 0 and finite (got " + std::to_string(dt) + ")");
  MR_CHECK_ARG(count >= 0, "count must be >= 0 (got " + std::to_string(count) + ")");
  return guard([&] { b->b.step(dt, count, b->threads, {}, 0.1, b->force_dt); });
}

mr_status mr_batch_set_force_dt(mr_batch* b, int force) {
  MR_CHECK_ARG(b, "a NULL batch");
  MR_CHECK_ARG(force == 0 || force == 1, "force must be 0 or 1 (got " + std::to_string(force) + ")");
  b->force_dt = force == 1;
  return MR_OK;
}

double mr_batch_dt(const mr_batch* b) {
  if (!b) return std::numeric_limits<double>::quiet_NaN();
  double dt = std::numeric_limits<double>::quiet_NaN();
  if (guard([&] { dt = b->b.scene_dt(); }) != MR_OK) return std::numeric_limits<double>::quiet_NaN();
  return dt;
}

double mr_batch_stable_dt(const mr_batch* b) {
  if (!b) return std::numeric_limits<double>::quiet_NaN();
  double dt = std::numeric_limits<double>::quiet_NaN();
  if (guard([&] { dt = b->b.stable_dt().elastic; }) != MR_OK)
    return std::numeric_limits<double>::quiet_NaN();
  return dt;
}

mr_status mr_batch_set_threads(mr_batch* b, int threads) {
  MR_CHECK_ARG(b, "a NULL batch");
  MR_CHECK_ARG(threads >= 1, "threads must be >= 1 (got " + std::to_string(threads) + ")");
  b->threads = threads;
  return MR_OK;
}

double mr_batch_time(const mr_batch* b) { return b ? b->b.time() : std::numeric_limits<double>::quiet_NaN(); }
int64_t mr_batch_steps(const mr_batch* b) { return b ? b->b.steps() : -1; }
uint64_t mr_batch_state_hash(const mr_batch* b) { return b ? b->b.state_hash() : 0; }

mr_status mr_batch_energies(const mr_batch* b, int rod, mr_energies* out) {
  MR_CHECK_ARG(b && out, "a NULL argument");
  MR_CHECK_ARG(rod >= -1 && rod < b->b.rod_count(),
               "rod " + std::to_string(rod) + " out of range (-1 or 0 … " + std::to_string(b->b.rod_count() - 1) + ")");
  return guard([&] {
    const auto e = b->b.energies(rod);
#define MANYRODS_ENERGY_COPY(name, dataset, unit, written, doc) out->name = e.name;
    MANYRODS_ENERGY_FIELDS(MANYRODS_ENERGY_COPY)
#undef MANYRODS_ENERGY_COPY
  });
}

mr_status mr_batch_save(const mr_batch* b, const char* path) {
  MR_CHECK_ARG(b && path, "a NULL argument");
  return guard([&] { b->b.save(path); });
}

mr_status mr_batch_solve_static(mr_batch* b, double time, mr_static_result* result) {
  MR_CHECK_ARG(b, "a NULL batch");
  return guard([&] {
    manyrods::StaticOptions opt;
    opt.hold_time = time;
    opt.threads = b->threads;
    const manyrods::StaticResult r = b->b.solve_static(opt);
    if (result) {
      result->converged = r.converged;
      result->iterations = r.iterations;
      result->load_increments = r.load_increments;
      result->residual_force = r.residual_force;
      result->residual_couple = r.residual_couple;
      result->failed_rod = r.failed_rod;
      result->failed_node = r.failed_node;
      result->load_reached = r.load_reached;
      result->mechanism = r.mechanism;
      result->warm_rods = r.warm_rods;
      result->sticking = r.sticking;
      result->slipping = r.slipping;
    }
    b->b.check_static(r);
  });
}

mr_status mr_batch_preload(mr_batch* b, int* rods, int* contacts) {
  MR_CHECK_ARG(b, "a NULL batch");
  return guard([&] {
    const manyrods::PreloadResult r = b->b.preload();
    if (rods) *rods = r.rods;
    if (contacts) *contacts = r.contacts;
  });
}

mr_status mr_batch_hold_reactions(const mr_batch* b, mr_hold_reaction* out, size_t* count) {
  MR_CHECK_ARG(b && count, "a NULL argument");
  MR_CHECK_ARG(out || *count == 0, "out is NULL with a capacity > 0");
  std::vector<manyrods::HoldReaction> h;
  const mr_status st = guard([&] { h = b->b.hold_reactions(); });
  if (st != MR_OK) return st;
  const std::size_t capacity = *count;
  *count = h.size();
  if (out == nullptr) return MR_OK;
  MR_CHECK_ARG(capacity >= h.size(), "capacity " + std::to_string(capacity) + " is short of the " +
                                         std::to_string(h.size()) + " holds (count now says how many)");
  for (std::size_t i = 0; i < h.size(); ++i) {
    out[i].rod = h[i].rod;
    out[i].node = h[i].node;
    out[i].clamped = h[i].clamped;
    for (int a = 0; a < 3; ++a) out[i].force[a] = h[i].force[a], out[i].moment[a] = h[i].moment[a];
  }
  return MR_OK;
}

size_t mr_batch_rod_count(const mr_batch* b) { return b ? std::size_t(b->b.rod_count()) : 0; }
size_t mr_batch_node_count(const mr_batch* b) { return b ? std::size_t(b->b.node_count()) : 0; }

mr_status mr_batch_rod_nodes(const mr_batch* b, size_t rod, size_t* first, size_t* count) {
  MR_CHECK_ARG(b && first && count, "a NULL argument");
  MR_CHECK_ARG(rod < std::size_t(b->b.rod_count()),
               "rod " + std::to_string(rod) + " out of range (the batch has " + std::to_string(b->b.rod_count()) + ")");
  *first = first_node(b->b, int(rod));
  *count = std::size_t(b->b.elements(int(rod))) + 1;
  return MR_OK;
}

mr_status mr_batch_copy_positions_f32(const mr_batch* b, float* xyz, size_t count) {
  return copy_positions(b, xyz, count, __func__);
}
mr_status mr_batch_copy_positions_f64(const mr_batch* b, double* xyz, size_t count) {
  return copy_positions(b, xyz, count, __func__);
}

mr_status mr_batch_state_view(const mr_batch* b, mr_state_view* out) {
  MR_CHECK_ARG(b && out, "a NULL argument");
  b->b.visit([&](const auto& rb) {
    out->precision = precision_of(rb);
    out->slots = std::size_t(rb.slots());
    out->component_stride = stride_of(rb.state.node_x);
#define MANYRODS_C_VIEW(group, field, name, doc) MANYRODS_C_VIEW_##group(field, name)
#define MANYRODS_C_VIEW_state(field, name) out->name = rb.state.field[0].data();
#define MANYRODS_C_VIEW_loads(field, name)
    MANYRODS_PUBLIC_ARRAYS(MANYRODS_C_VIEW)
#undef MANYRODS_C_VIEW_state
#undef MANYRODS_C_VIEW_loads
  });
  return MR_OK;
}

mr_status mr_batch_rod_slots(const mr_batch* b, size_t rod, size_t* first_slot, int* elements) {
  MR_CHECK_ARG(b && first_slot && elements, "a NULL argument");
  MR_CHECK_ARG(rod < std::size_t(b->b.rod_count()),
               "rod " + std::to_string(rod) + " out of range (the batch has " + std::to_string(b->b.rod_count()) + ")");
  *first_slot = std::size_t(b->b.node_slot(int(rod), 0));
  *elements = b->b.elements(int(rod));
  return MR_OK;
}

mr_status mr_batch_loads_view(mr_batch* b, mr_loads_view* out) {
  MR_CHECK_ARG(b && out, "a NULL argument");
  b->b.visit([&](auto& rb) {
    out->precision = precision_of(rb);
    out->slots = std::size_t(rb.slots());
    out->component_stride = stride_of(rb.loads.node_force);
#define MANYRODS_C_VIEW_state(field, name)
#define MANYRODS_C_VIEW_loads(field, name) out->name = rb.loads.field[0].data();
    MANYRODS_PUBLIC_ARRAYS(MANYRODS_C_VIEW)
#undef MANYRODS_C_VIEW_state
#undef MANYRODS_C_VIEW_loads
#undef MANYRODS_C_VIEW
  });
  return MR_OK;
}

void mr_pose_identity(mr_pose* pose) {
  if (!pose) return;
  *pose = mr_pose{{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
}

size_t mr_batch_driver_count(const mr_batch* b) { return b ? std::size_t(b->b.driver_count()) : 0; }

const char* mr_batch_driver_name(const mr_batch* b, size_t driver) {
  if (!b || driver >= std::size_t(b->b.driver_count())) return nullptr;
  return b->b.driver_name(int(driver)).c_str();
}

mr_status mr_batch_find_driver(const mr_batch* b, const char* name, size_t* driver) {
  MR_CHECK_ARG(b && name && driver, "a NULL argument");
  return guard([&] { *driver = std::size_t(b->b.find_driver(name)); });
}

mr_status mr_batch_set_driver_pose_about(mr_batch* b, size_t driver, const mr_pose* pose, const double pivot[3],
                                         double time) {
  MR_CHECK_ARG(b && pose && pivot, "a NULL argument");
  MR_CHECK_ARG(driver < std::size_t(b->b.driver_count()), "driver " + std::to_string(driver) +
                                                              " out of range (the batch has " +
                                                              std::to_string(b->b.driver_count()) + " drivers)");
  return guard([&] {
    manyrods::Pose p;
    std::copy(pose->rotation, pose->rotation + 9, p.rotation.begin());
    std::copy(pose->translation, pose->translation + 3, p.translation.begin());
    b->b.set_driver_pose(int(driver), p, time, {pivot[0], pivot[1], pivot[2]});  // (turned about it there)
  });
}

mr_status mr_batch_set_driver_pose(mr_batch* b, size_t driver, const mr_pose* pose, double time) {
  const double origin[3] = {0, 0, 0};
  return mr_batch_set_driver_pose_about(b, driver, pose, origin, time);
}

}  // extern "C"
