// python/src/module.cpp — the Python module manyrods._core (nanobind): scenes,
// rods, batches, and the batch's state as zero-copy NumPy views.
//
// Views. A field with N components (node_x: 3, elem_Q: 9) is one block of
// memory, component i at a fixed stride from component 0
// (include/manyrods/array.h resize_components), so a view is one strided
// NumPy array over the batch's own memory: shape (3, slots) or (3, 3,
// slots), indexed by slot (include/manyrods/batch.h "Slot layout";
// Batch.node_range / element_range give a rod's slice). The arrays never
// move while the batch lives (copies into them are in place), and each view
// holds a reference to its batch. State views are read-only: the setters
// keep the float batches' compensation (node_xc) and the frames'
// orthonormality right; load views (node_force, element_couple) are
// writable.
//
// Stepping releases the GIL; a long step is cut into chunks of whole
// non-finite-check intervals (so the result does not depend on them) of
// about 0.1 s each, and Ctrl-C (SIGINT) between chunks stops it with
// KeyboardInterrupt, the batch left at the last whole chunk.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "manyrods/any_batch.h"
#include "manyrods/h5io.h"
#include "manyrods/manyrods.h"
#include "manyrods/runner.h"
#include "manyrods/scene.h"
#include "manyrods/sweep.h"

namespace nb = nanobind;
using namespace nb::literals;
using manyrods::Mat3;
using manyrods::RodSpec;
using manyrods::Vec3;
using manyrods::scene::AnyBatch;
using manyrods::scene::Precision;
using manyrods::scene::Scene;

namespace {

// ---- small conversions -------------------------------------------------------

Vec3 vec3(const std::vector<double>& v, const char* what) {
  if (v.size() != 3) throw manyrods::InputError(std::string(what) + ": needs 3 values (got " + std::to_string(v.size()) + ")");
  return {v[0], v[1], v[2]};
}

Precision precision_of(const std::string& p) {
  if (p == "double" || p == "float64") return Precision::float64;
  if (p == "float" || p == "float32") return Precision::float32;
  throw manyrods::InputError("precision: \"double\" or \"float\" (got \"" + p + "\")");
}

manyrods::Integrator integrator_of(const std::string& i) {
  if (i == "position_verlet") return manyrods::Integrator::position_verlet;
  if (i == "pefrl") return manyrods::Integrator::pefrl;
  throw manyrods::InputError("integrator: \"position_verlet\" or \"pefrl\" (got \"" + i + "\")");
}

using Points = nb::ndarray<const double, nb::ndim<2>, nb::device::cpu>;
using Frames = nb::ndarray<const double, nb::ndim<3>, nb::device::cpu>;

std::vector<Vec3> points_of(const Points& a, const char* what) {
  if (a.shape(1) != 3)
    throw manyrods::InputError(std::string(what) + ": shape (n, 3) expected (got (" + std::to_string(a.shape(0)) +
                               ", " + std::to_string(a.shape(1)) + "))");
  std::vector<Vec3> out(a.shape(0));
  auto v = a.view();
  for (std::size_t i = 0; i < out.size(); ++i)
    for (int c = 0; c < 3; ++c) out[i][c] = v(i, c);
  return out;
}

std::vector<Mat3> frames_of(const Frames& a, const char* what) {
  if (a.shape(1) != 3 || a.shape(2) != 3)
    throw manyrods::InputError(std::string(what) + ": shape (n, 3, 3) expected (rows d1, d2, d3)");
  std::vector<Mat3> out(a.shape(0));
  auto v = a.view();
  for (std::size_t i = 0; i < out.size(); ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out[i][3 * r + c] = v(i, r, c);
  return out;
}

nb::ndarray<nb::numpy, double> points_array(const std::vector<Vec3>& p) {
  auto* data = new double[p.size() * 3];
  for (std::size_t i = 0; i < p.size(); ++i) std::memcpy(data + 3 * i, p[i].data(), 3 * sizeof(double));
  nb::capsule owner(data, [](void* q) noexcept { delete[] static_cast<double*>(q); });
  return nb::ndarray<nb::numpy, double>(data, {p.size(), 3}, owner);
}

nb::ndarray<nb::numpy, double> frames_array(const std::vector<Mat3>& f) {
  auto* data = new double[f.size() * 9];
  for (std::size_t i = 0; i < f.size(); ++i) std::memcpy(data + 9 * i, f[i].data(), 9 * sizeof(double));
  nb::capsule owner(data, [](void* q) noexcept { delete[] static_cast<double*>(q); });
  return nb::ndarray<nb::numpy, double>(data, {f.size(), 3, 3}, owner);
}

void set_hold(RodSpec& r, bool root, const std::string& kind) {
  bool& clamped = root ? r.clamped_root : r.clamped_tip;
  bool& pinned = root ? r.pinned_root : r.pinned_tip;
  clamped = pinned = false;
  if (kind == "clamped") clamped = true;
  else if (kind == "pinned") pinned = true;
  else if (kind != "free")
    throw manyrods::InputError(std::string(root ? "root" : "tip") + ": \"free\", \"clamped\" or \"pinned\" (got \"" +
                               kind + "\")");
}

std::string hold_of(const RodSpec& r, bool root) {
  if (root ? r.clamped_root : r.clamped_tip) return "clamped";
  if (root ? r.pinned_root : r.pinned_tip) return "pinned";
  return "free";
}

// ---- the batch ---------------------------------------------------------------

// A Python Batch: the AnyBatch and the thread count its calls use.
struct PyBatch {
  AnyBatch b;
  int threads = 1;
};

// One strided NumPy view of an N-component field (read-only unless `writable`).
template <class T, std::size_t N>
nb::object field_view(const std::array<manyrods::Array<T>, N>& a, int slots, bool writable, bool frame, nb::handle self) {
  const std::int64_t stride = a.size() > 1 ? std::int64_t(a[1].data() - a[0].data()) : 0;
  for (std::size_t i = 1; i < N; ++i)  // one block (include/manyrods/array.h resize_components)
    if (a[i].data() - a[0].data() != std::int64_t(i) * stride)
      throw std::logic_error("manyrods: a field's components are not one block");
  T* data = const_cast<T*>(a[0].data());
  std::vector<std::size_t> shape;
  std::vector<std::int64_t> strides;
  if (frame) {
    shape = {3, 3, std::size_t(slots)};
    strides = {3 * stride, stride, 1};
  } else {
    shape = {N, std::size_t(slots)};
    strides = {stride, 1};
  }
  if (writable) {
    nb::ndarray<nb::numpy, T> v(data, shape.size(), shape.data(), self, strides.data());
    return nb::cast(v, nb::rv_policy::reference);
  }
  nb::ndarray<nb::numpy, const T> v(data, shape.size(), shape.data(), self, strides.data());
  return nb::cast(v, nb::rv_policy::reference);
}

enum class Field { node_x, node_v, elem_Q, elem_w, node_force, elem_couple };

nb::object view(PyBatch& pb, Field f, nb::handle self) {
  return pb.b.visit([&](auto& b) -> nb::object {
    const int S = b.slots();
    switch (f) {
      case Field::node_x: return field_view(b.state.node_x, S, false, false, self);
      case Field::node_v: return field_view(b.state.node_v, S, false, false, self);
      case Field::elem_Q: return field_view(b.state.elem_Q, S, false, true, self);
      case Field::elem_w: return field_view(b.state.elem_w, S, false, false, self);
      case Field::node_force: return field_view(b.loads.node_force, S, true, false, self);
      case Field::elem_couple: return field_view(b.loads.elem_couple, S, true, false, self);
    }
    return nb::none();
  });
}

using Values = nb::ndarray<const double, nb::device::cpu>;

// The slots a setter writes: every rod's real nodes (elements), or one rod's.
struct Target {
  std::vector<int> slots;  // the slots written, in the values' last-axis order
  bool all = true;         // values are indexed by slot
};
Target target(const AnyBatch& b, std::optional<int> rod, bool nodes) {
  Target t;
  auto add = [&](int r) {
    const int n = b.elements(r) + (nodes ? 1 : 0);
    for (int j = 0; j < n; ++j) t.slots.push_back(nodes ? b.node_slot(r, j) : b.element_slot(r, j));
  };
  if (rod) {
    t.all = false;
    add(*rod);
  } else {
    for (int r = 0; r < b.rod_count(); ++r) add(r);
  }
  return t;
}

void check_values(const Values& v, std::initializer_list<std::size_t> lead, std::size_t last, const char* what) {
  std::string want = "(";
  for (std::size_t d : lead) want += std::to_string(d) + ", ";
  want += std::to_string(last) + ")";
  bool ok = v.ndim() == lead.size() + 1 && v.shape(v.ndim() - 1) == last;
  std::size_t i = 0;
  for (std::size_t d : lead) ok = ok && v.shape(i++) == d;
  if (!ok) throw manyrods::InputError(std::string(what) + ": shape " + want + " expected");
}

double value_at(const Values& v, std::size_t a, std::size_t b, std::size_t c, bool three) {
  const std::int64_t* st = v.stride_ptr();
  const double* p = v.data();
  return three ? p[a * st[0] + b * st[1] + c * st[2]] : p[a * st[0] + c * st[1]];
}

void set_vectors(PyBatch& pb, const Values& v, std::optional<int> rod, bool nodes, bool velocity, const char* what) {
  const Target t = target(pb.b, rod, nodes);
  const std::size_t last = t.all ? std::size_t(pb.b.slots()) : t.slots.size();
  check_values(v, {3}, last, what);
  for (std::size_t i = 0; i < t.slots.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double x = value_at(v, c, 0, t.all ? t.slots[i] : i, false);
      if (!std::isfinite(x))
        throw manyrods::InputError(std::string(what) + ": not finite at component " + std::to_string(c) + ", slot " +
                                   std::to_string(t.slots[i]));
    }
  pb.b.visit([&](auto& b) {
    using T = typename std::remove_reference_t<decltype(b)>::value_type;
    auto& dst = nodes ? (velocity ? b.state.node_v : b.state.node_x) : b.state.elem_w;
    for (std::size_t i = 0; i < t.slots.size(); ++i)
      for (int c = 0; c < 3; ++c) {
        dst[c][t.slots[i]] = T(value_at(v, c, 0, t.all ? t.slots[i] : i, false));
        // positions set from outside carry no round-off to compensate
        if (nodes && !velocity && b.state.node_xc[c].size() != 0) b.state.node_xc[c][t.slots[i]] = T(0);
      }
  });
}

void set_frames(PyBatch& pb, const Values& v, std::optional<int> rod) {
  const Target t = target(pb.b, rod, false);
  const std::size_t last = t.all ? std::size_t(pb.b.slots()) : t.slots.size();
  check_values(v, {3, 3}, last, "element_directors");
  const double tol = pb.b.float32() ? 1e-5 : 1e-10;
  for (std::size_t i = 0; i < t.slots.size(); ++i) {
    const std::size_t k = t.all ? t.slots[i] : i;
    double q[9];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) q[3 * r + c] = value_at(v, r, c, k, true);
    double err = 0;
    for (int r = 0; r < 3; ++r)
      for (int s = 0; s < 3; ++s) {
        double d = 0;
        for (int c = 0; c < 3; ++c) d += q[3 * r + c] * q[3 * s + c];
        err = std::max(err, std::abs(d - (r == s)));
      }
    const double det = q[0] * (q[4] * q[8] - q[5] * q[7]) - q[1] * (q[3] * q[8] - q[5] * q[6]) +
                       q[2] * (q[3] * q[7] - q[4] * q[6]);
    if (!(err <= tol) || !(det > 0))
      throw manyrods::InputError("element_directors: slot " + std::to_string(t.slots[i]) +
                                 " is not a proper orthonormal frame (|Q Qᵀ − I| = " + std::to_string(err) +
                                 ", det = " + std::to_string(det) + ")");
  }
  pb.b.visit([&](auto& b) {
    using T = typename std::remove_reference_t<decltype(b)>::value_type;
    for (std::size_t i = 0; i < t.slots.size(); ++i)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          b.state.elem_Q[3 * r + c][t.slots[i]] = T(value_at(v, r, c, t.all ? t.slots[i] : i, true));
  });
}

nb::dict energies_dict(const manyrods::Energies& e) {
  nb::dict d;
  d["kinetic"] = e.kinetic;
  d["elastic"] = e.elastic;
  d["potential"] = e.potential;
  d["dissipation"] = e.dissipation;
  d["contact_work"] = e.contact_work;
  d["total"] = e.total();
  return d;
}

// Steps with the GIL released; Ctrl-C between chunks (see the top).
void step_batch(PyBatch& pb, double dt, std::int64_t count) {
  bool interrupted = false;
  {
    nb::gil_scoped_release release;
    pb.b.step(dt, count, pb.threads,
              [&] {
                nb::gil_scoped_acquire acquire;
                if (PyErr_CheckSignals() != 0) interrupted = true;
                return !interrupted;
              },
              0.1);
  }
  if (interrupted) throw nb::python_error();
}

nb::dict run_result(const manyrods::scene::RunResult& r) {
  nb::dict d;
  d["dt"] = r.dt;
  d["steps"] = r.steps;
  d["time"] = r.time;
  d["frames"] = r.frames;
  d["elements"] = r.elements;
  d["interrupted"] = r.interrupted;
  d["wall_s"] = r.wall_s;
  d["element_steps_per_s"] = r.element_steps_per_s;
  d["state_hash"] = r.state_hash;
  d["validity"] = r.validity;
  nb::dict obs;  // a run's [[observables]], name -> value
  for (const auto& c : r.observables) obs[c.name.c_str()] = c.values[0];
  d["observables"] = obs;
  return d;
}

nb::dict columns(const std::vector<manyrods::h5::Column>& cols) {
  nb::dict d;
  for (const auto& c : cols) {
    auto* data = new double[c.values.size()];
    std::copy(c.values.begin(), c.values.end(), data);
    nb::capsule owner(data, [](void* q) noexcept { delete[] static_cast<double*>(q); });
    d[c.name.c_str()] = nb::cast(nb::ndarray<nb::numpy, double>(data, {c.values.size()}, owner));
  }
  return d;
}

volatile std::sig_atomic_t g_never = 0;  // RunOptions::interrupt for runs from Python

manyrods::scene::RunOptions run_options(const std::string& output, int threads, std::optional<double> duration,
                                        double checkpoint_every, bool progress) {
  manyrods::scene::RunOptions o;
  o.output = output;
  o.threads = threads;
  if (duration) o.duration = *duration;
  o.checkpoint_every = checkpoint_every;
  o.progress = progress;
  o.interrupt = &g_never;
  return o;
}

}  // namespace

NB_MODULE(_core, m) {
  m.doc() = "manyrods: many Cosserat rods with Kelvin–Voigt damping (the C++ library's Python module)";
  m.attr("__version__") = MANYRODS_VERSION;

  // ---- errors: InputError and SceneError -> ValueError, files -> OSError
  static nb::exception<manyrods::NonFiniteError> non_finite(m, "NonFiniteError", PyExc_RuntimeError);
  static nb::exception<manyrods::scene::ValidityError> validity(m, "ValidityError", PyExc_RuntimeError);
  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const manyrods::InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const manyrods::scene::SceneError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const manyrods::h5::H5Error& e) {
      PyErr_SetString(PyExc_OSError, e.what());
    }
  });

  // ---- sections, materials, damping (include/manyrods/material.h)
  nb::class_<manyrods::Section>(m, "Section", "A cross section; principal axes d1, d2 (m)")
      .def_static("circle", &manyrods::Section::circle, "radius"_a)
      .def_static("ellipse", &manyrods::Section::ellipse, "semi_axis_1"_a, "semi_axis_2"_a)
      .def_static("rectangle", &manyrods::Section::rectangle, "width_1"_a, "height_2"_a)
      .def_static("hollow_circle", &manyrods::Section::hollow_circle, "outer_radius"_a, "inner_radius"_a)
      .def_rw("a", &manyrods::Section::a)
      .def_rw("b", &manyrods::Section::b);

  nb::class_<manyrods::Material>(m, "Material", "Elastic material, SI units; give poisson_ratio or shear_modulus")
      .def(
          "__init__",
          [](manyrods::Material* t, double density, double youngs_modulus, double poisson_ratio, double shear_modulus) {
            new (t) manyrods::Material{density, youngs_modulus, poisson_ratio, shear_modulus};
          },
          "density"_a, "youngs_modulus"_a, "poisson_ratio"_a = NAN, "shear_modulus"_a = NAN)
      .def_rw("density", &manyrods::Material::density)
      .def_rw("youngs_modulus", &manyrods::Material::youngs_modulus)
      .def_rw("poisson_ratio", &manyrods::Material::poisson_ratio)
      .def_rw("shear_modulus", &manyrods::Material::shear_modulus);

  nb::class_<manyrods::Damping>(m, "Damping", "Kelvin–Voigt parameters (retardation times in s, or viscosities)")
      .def(nb::init<>())
      .def_static("none", &manyrods::Damping::none)
      .def_static("shear_bulk", &manyrods::Damping::shear_bulk, "tau_shear"_a, "tau_bulk"_a)
      .def_static("shear_extension", &manyrods::Damping::shear_extension, "tau_shear"_a, "tau_extension"_a)
      .def_static("viscosities", &manyrods::Damping::viscosities, "shear_viscosity"_a, "bulk_viscosity"_a);

  // ---- rods (include/manyrods/batch.h RodSpec)
  nb::class_<RodSpec>(m, "Rod", "One rod as the user describes it (double precision, SI units)")
      .def_static(
          "straight",
          [](const std::vector<double>& start, const std::vector<double>& direction, double length, int elements,
             std::optional<std::vector<double>> normal, const manyrods::Section& section,
             const manyrods::Material& material, const manyrods::Damping& damping, const std::string& root,
             const std::string& tip, bool stiff, const std::string& name) {
            const Vec3 d = vec3(direction, "direction");
            Vec3 n;
            if (normal) {
              n = vec3(*normal, "normal");
            } else {  // the axis least aligned with the rod
              int a = 0;
              for (int i = 1; i < 3; ++i)
                if (std::abs(d[i]) < std::abs(d[a])) a = i;
              n = {0, 0, 0};
              n[a] = 1;
            }
            if (!(elements >= 1)) throw manyrods::InputError("elements: must be >= 1 (got " + std::to_string(elements) + ")");
            RodSpec r = RodSpec::straight(vec3(start, "start"), d, n, length, elements);
            r.section = section;
            r.material = material;
            r.damping = damping;
            set_hold(r, true, root);
            set_hold(r, false, tip);
            r.stiff_implicit = stiff;
            r.name = name;
            return r;
          },
          "start"_a, "direction"_a, "length"_a, "elements"_a, nb::kw_only(), "normal"_a = nb::none(),
          "section"_a = manyrods::Section{}, "material"_a = manyrods::Material{}, "damping"_a = manyrods::Damping{},
          "root"_a = "clamped", "tip"_a = "free", "stiff"_a = false, "name"_a = "",
          "A straight rod from `start` along `direction` (d3), d1 along `normal` made orthogonal.")
      .def_static(
          "polyline",
          [](const Points& nodes, std::optional<Frames> frames, std::optional<std::vector<double>> first_normal,
             const manyrods::Section& section, const manyrods::Material& material, const manyrods::Damping& damping,
             const std::string& root, const std::string& tip, bool stiff, const std::string& name) {
            std::vector<Vec3> x = points_of(nodes, "nodes");
            if (x.size() < 2) throw manyrods::InputError("nodes: a rod needs at least 2 nodes (got " + std::to_string(x.size()) + ")");
            std::vector<Mat3> q;
            if (frames) {
              q = frames_of(*frames, "frames");
            } else {
              Vec3 t{x[1][0] - x[0][0], x[1][1] - x[0][1], x[1][2] - x[0][2]};
              Vec3 n{0, 0, 0};
              if (first_normal) {
                n = vec3(*first_normal, "first_normal");
              } else {
                int a = 0;
                for (int i = 1; i < 3; ++i)
                  if (std::abs(t[i]) < std::abs(t[a])) a = i;
                n[a] = 1;
              }
              q = RodSpec::parallel_transport_frames(x, n);
            }
            RodSpec r = RodSpec::polyline(std::move(x), std::move(q));
            r.section = section;
            r.material = material;
            r.damping = damping;
            set_hold(r, true, root);
            set_hold(r, false, tip);
            r.stiff_implicit = stiff;
            r.name = name;
            return r;
          },
          "nodes"_a, "frames"_a = nb::none(), nb::kw_only(), "first_normal"_a = nb::none(),
          "section"_a = manyrods::Section{}, "material"_a = manyrods::Material{}, "damping"_a = manyrods::Damping{},
          "root"_a = "clamped", "tip"_a = "free", "stiff"_a = false, "name"_a = "",
          "A rod along the polyline `nodes` (n+1, 3): its shape is the rest shape. `frames` (n, 3, 3), rows d1, d2, "
          "d3; default: parallel transport (twist-free) from `first_normal`.")
      .def_prop_rw(
          "root_driver",
          [](const RodSpec& r) -> std::optional<std::string> {
            if (auto h = std::dynamic_pointer_cast<const manyrods::HostMotion>(r.root_motion)) return h->name();
            return std::nullopt;
          },
          [](RodSpec& r, std::optional<std::string> name) {
            r.root_motion = name ? std::make_shared<manyrods::HostMotion>(*name) : nullptr;
          },
          "the host motion the held root follows, by name (Batch.set_driver_pose); None: static")
      .def_prop_rw(
          "tip_driver",
          [](const RodSpec& r) -> std::optional<std::string> {
            if (auto h = std::dynamic_pointer_cast<const manyrods::HostMotion>(r.tip_motion)) return h->name();
            return std::nullopt;
          },
          [](RodSpec& r, std::optional<std::string> name) {
            r.tip_motion = name ? std::make_shared<manyrods::HostMotion>(*name) : nullptr;
          },
          "the host motion the held tip follows, by name; None: static")
      .def_rw("name", &RodSpec::name)
      .def_rw("section", &RodSpec::section)
      .def_rw("material", &RodSpec::material)
      .def_rw("damping", &RodSpec::damping)
      .def_rw("stiff", &RodSpec::stiff_implicit)
      .def_rw("shear_stretch_scale", &RodSpec::shear_stretch_scale)
      .def_prop_rw(
          "root", [](const RodSpec& r) { return hold_of(r, true); },
          [](RodSpec& r, const std::string& k) { set_hold(r, true, k); }, "\"free\", \"clamped\" or \"pinned\"")
      .def_prop_rw(
          "tip", [](const RodSpec& r) { return hold_of(r, false); },
          [](RodSpec& r, const std::string& k) { set_hold(r, false, k); }, "\"free\", \"clamped\" or \"pinned\"")
      .def(
          "hold",
          [](RodSpec& r, int node, const std::string& kind) {
            manyrods::NodeHold h;
            h.node = node;
            if (kind == "clamped") h.kind = manyrods::HoldKind::clamped;
            else if (kind == "pinned") h.kind = manyrods::HoldKind::pinned;
            else throw manyrods::InputError("hold: kind \"clamped\" or \"pinned\" (got \"" + kind + "\")");
            r.holds.push_back(h);
          },
          "node"_a, "kind"_a = "clamped", "Hold interior node `node` (1 … n−1) in place (pinned) or also in orientation (clamped).")
      .def_prop_ro("elements", &RodSpec::elements)
      .def_prop_rw(
          "nodes", [](const RodSpec& r) { return nb::cast(points_array(r.nodes), nb::rv_policy::move); },
          [](RodSpec& r, const Points& a) { r.nodes = points_of(a, "nodes"); }, "(n+1, 3) centreline, m (a copy)")
      .def_prop_rw(
          "frames", [](const RodSpec& r) { return nb::cast(frames_array(r.frames), nb::rv_policy::move); },
          [](RodSpec& r, const Frames& a) { r.frames = frames_of(a, "frames"); }, "(n, 3, 3) element frames (a copy)")
      .def_prop_rw(
          "velocities", [](const RodSpec& r) { return nb::cast(points_array(r.velocities), nb::rv_policy::move); },
          [](RodSpec& r, const Points& a) { r.velocities = points_of(a, "velocities"); }, "(n+1, 3) initial, m/s")
      .def_prop_rw(
          "rest_curvature", [](const RodSpec& r) { return nb::cast(points_array(r.rest_curvature), nb::rv_policy::move); },
          [](RodSpec& r, const Points& a) { r.rest_curvature = points_of(a, "rest_curvature"); },
          "(n−1, 3) U0, 1/m (empty: the given shape is the rest shape)");

  // ---- batches
  nb::class_<PyBatch>(m, "Batch",
                      "Many rods in structure-of-arrays form. State views (node_position, node_velocity, "
                      "element_directors, element_omega) are read-only zero-copy NumPy arrays indexed by slot; "
                      "loads (node_force, element_couple) are writable.")
      .def(
          "__init__",
          [](PyBatch* t, const std::vector<RodSpec>& rods, const std::string& precision,
             const std::vector<double>& gravity, const std::string& integrator, int threads) {
            if (threads < 1) throw manyrods::InputError("threads: must be >= 1 (got " + std::to_string(threads) + ")");
            new (t) PyBatch{AnyBatch::from_rods(rods, precision_of(precision), vec3(gravity, "gravity"),
                                                integrator_of(integrator)),
                            threads};
          },
          "rods"_a, "precision"_a = "double", "gravity"_a = std::vector<double>{0, 0, 0},
          "integrator"_a = "position_verlet", "threads"_a = 1)
      .def_prop_rw(
          "threads", [](const PyBatch& p) { return p.threads; },
          [](PyBatch& p, int n) {
            if (n < 1) throw manyrods::InputError("threads: must be >= 1");
            p.threads = n;
          },
          "OpenMP threads of its calls (results do not depend on it)")
      .def_prop_ro("precision", [](const PyBatch& p) { return p.b.float32() ? "float" : "double"; })
      .def_prop_ro("rod_count", [](const PyBatch& p) { return p.b.rod_count(); })
      .def_prop_ro("slots", [](const PyBatch& p) { return p.b.slots(); })
      .def_prop_ro("node_count", [](const PyBatch& p) { return p.b.node_count(); })
      .def_prop_ro("time", [](const PyBatch& p) { return p.b.time(); }, "simulated time, s")
      .def_prop_ro("steps", [](const PyBatch& p) { return p.b.steps(); })
      .def_prop_ro("dt", [](const PyBatch& p) { return p.b.scene_dt(); },
                   "the scene's step (its dt or \"auto\"); rods built in code: 0.9 × stable_dt()['elastic']")
      .def("elements", [](const PyBatch& p, int rod) { return p.b.elements(rod); }, "rod"_a)
      .def(
          "node_range",
          [](const PyBatch& p, int rod) {
            const int first = p.b.node_slot(rod, 0);
            return nb::slice(first, first + p.b.elements(rod) + 1, 1);
          },
          "rod"_a, "The slots of rod `rod`'s nodes: batch.node_position[:, batch.node_range(r)] is (3, n+1)")
      .def(
          "element_range",
          [](const PyBatch& p, int rod) {
            const int first = p.b.element_slot(rod, 0);
            return nb::slice(first, first + p.b.elements(rod), 1);
          },
          "rod"_a, "The slots of rod `rod`'s elements")
      .def_prop_ro(
          "node_position", [](nb::handle self) { return view(nb::cast<PyBatch&>(self), Field::node_x, self); },
          "(3, slots) m, read-only view (set_node_position writes)")
      .def_prop_ro(
          "node_velocity", [](nb::handle self) { return view(nb::cast<PyBatch&>(self), Field::node_v, self); },
          "(3, slots) m/s, read-only view")
      .def_prop_ro(
          "element_directors", [](nb::handle self) { return view(nb::cast<PyBatch&>(self), Field::elem_Q, self); },
          "(3, 3, slots) frames, [i, :, k] = director d_(i+1) of slot k, read-only view")
      .def_prop_ro(
          "element_omega", [](nb::handle self) { return view(nb::cast<PyBatch&>(self), Field::elem_w, self); },
          "(3, slots) rad/s, material components, read-only view")
      .def_prop_ro(
          "node_force", [](nb::handle self) { return view(nb::cast<PyBatch&>(self), Field::node_force, self); },
          "(3, slots) N, lab frame: dead loads, a writable view")
      .def_prop_ro(
          "element_couple", [](nb::handle self) { return view(nb::cast<PyBatch&>(self), Field::elem_couple, self); },
          "(3, slots) N·m, lab frame: dead couples, a writable view")
      .def(
          "set_node_position",
          [](PyBatch& p, const Values& v, std::optional<int> rod) { set_vectors(p, v, rod, true, false, "node_position"); },
          "values"_a, "rod"_a = nb::none(),
          "Positions (3, slots), or (3, n+1) of one rod; ghosts are left alone, float compensation reset")
      .def(
          "set_node_velocity",
          [](PyBatch& p, const Values& v, std::optional<int> rod) { set_vectors(p, v, rod, true, true, "node_velocity"); },
          "values"_a, "rod"_a = nb::none())
      .def(
          "set_element_omega",
          [](PyBatch& p, const Values& v, std::optional<int> rod) { set_vectors(p, v, rod, false, false, "element_omega"); },
          "values"_a, "rod"_a = nb::none())
      .def("set_element_directors", &set_frames, "values"_a, "rod"_a = nb::none(),
           "Frames (3, 3, slots) or (3, 3, n); each must be a proper rotation (to 1e-10, float 1e-5)")
      .def(
          "positions",
          [](const PyBatch& p) {
            std::vector<double> x;
            p.b.visit([&](const auto& b) {
              for (int r = 0; r < b.rod_count(); ++r)
                for (int j = 0; j <= b.elements(r); ++j)
                  for (int c = 0; c < 3; ++c) x.push_back(double(b.state.node_x[c][b.node_index(r, j)]));
            });
            auto* data = new double[x.size()];
            std::copy(x.begin(), x.end(), data);
            nb::capsule owner(data, [](void* q) noexcept { delete[] static_cast<double*>(q); });
            return nb::ndarray<nb::numpy, double>(data, {x.size() / 3, 3}, owner);
          },
          "All nodes in rod order, (nodes, 3), a copy (the HDF5 frame layout)")
      .def(
          "step", [](PyBatch& p, double dt, std::int64_t count) { step_batch(p, dt, count); }, "dt"_a,
          "count"_a = 1,
          "`count` steps of length dt (GIL released; Ctrl-C stops between chunks). NonFiniteError names the first "
          "bad step.")
      .def(
          "advance",
          [](PyBatch& p, double duration, std::optional<double> dt) {
            const double h = dt ? *dt : p.b.scene_dt();
            if (!(duration >= 0) || !std::isfinite(duration))
              throw manyrods::InputError("advance: duration must be >= 0 and finite");
            if (!(h > 0)) throw manyrods::InputError("advance: dt must be > 0");
            const std::int64_t n = std::llround(duration / h);
            step_batch(p, h, n);
            return n;
          },
          "duration"_a, "dt"_a = nb::none(), "Advance by `duration` s in steps of dt (default: Batch.dt); returns the steps")
      .def(
          "energies", [](const PyBatch& p, int rod) { return energies_dict(p.b.energies(rod)); }, "rod"_a = -1,
          "kinetic, elastic, potential (J), dissipation (2·D_v, W), contact_work, total of a rod (-1: all)")
      .def(
          "stable_dt",
          [](const PyBatch& p) {
            const manyrods::StableDt s = p.b.stable_dt();
            nb::dict d;
            d["elastic"] = s.elastic;
            d["explicit_viscous"] = s.explicit_viscous;
            d["omega_max"] = s.omega_max;
            return d;
          },
          "The largest stable step (s) of what the batch integrates explicitly")
      .def(
          "solve_static",
          [](PyBatch& p, int load_steps, double tolerance) {
            manyrods::StaticOptions o;
            o.load_steps = load_steps;
            o.tolerance = tolerance;
            manyrods::StaticResult r;
            {
              nb::gil_scoped_release release;
              r = p.b.solve_static(o);
            }
            nb::dict d;
            d["converged"] = r.converged;
            d["iterations"] = r.iterations;
            d["last_update"] = r.last_update;
            return d;
          },
          "load_steps"_a = 10, "tolerance"_a = 1e-10, "Static equilibrium under the loads (double batches)")
      .def("state_hash", [](const PyBatch& p) { return p.b.state_hash(); },
           "FNV-1a hash of the state: equal hashes = bit-identical states")
      .def(
          "save", [](const PyBatch& p, const std::string& path) { p.b.save(path); }, "path"_a,
          "An HDF5 file (the run layout) with this state as its one frame and checkpoint")
      .def_prop_ro(
          "drivers",
          [](const PyBatch& p) {
            std::vector<std::string> v;
            for (int i = 0; i < p.b.driver_count(); ++i) v.push_back(p.b.driver_name(i));
            return v;
          },
          "the names of the batch's host motions (a scene's motion = \"host\", Rod.root_driver / tip_driver)")
      .def(
          "set_driver_pose",
          [](PyBatch& p, const std::string& name, std::optional<std::vector<double>> rotation,
             std::optional<std::vector<double>> translation, double time) {
            manyrods::Pose pose;
            if (rotation) {
              if (rotation->size() != 9)
                throw manyrods::InputError("rotation: needs 9 values, a 3 × 3 matrix row by row (got " +
                                           std::to_string(rotation->size()) + ")");
              std::copy(rotation->begin(), rotation->end(), pose.rotation.begin());
            }
            if (translation) pose.translation = vec3(*translation, "translation");
            p.b.set_driver_pose(p.b.find_driver(name), pose, time);
          },
          "name"_a, "rotation"_a = nb::none(), "translation"_a = nb::none(), nb::kw_only(), "time"_a,
          "Moves the host motion `name` from its pose at Batch.time to this pose (rotation: 9 numbers row by row, "
          "default identity; translation default 0) at `time` >= Batch.time, and holds it there");

  // ---- scenes (include/manyrods/scene.h)
  nb::class_<Scene>(m, "Scene", "A parsed, validated scene file")
      .def_ro("source", &Scene::source)
      .def_ro("text", &Scene::text)
      .def_prop_ro("rod_count", [](const Scene& s) { return s.rods.size(); })
      .def_prop_ro("duration", [](const Scene& s) { return s.sim.duration; })
      .def_prop_ro("output_interval", [](const Scene& s) { return s.sim.output_interval; })
      .def_prop_ro("precision", [](const Scene& s) { return s.sim.precision == Precision::float32 ? "float" : "double"; })
      .def_prop_ro("rods", [](const Scene& s) { return s.rods; }, "The expanded rods (copies)")
      .def(
          "build_batch",
          [](const Scene& s, std::optional<std::string> precision, int threads) {
            if (threads < 1) throw manyrods::InputError("threads: must be >= 1");
            std::optional<Precision> p;
            if (precision) p = precision_of(*precision);
            return new PyBatch{AnyBatch::from_scene(s, p), threads};
          },
          "precision"_a = nb::none(), "threads"_a = 1,
          "The scene's batch (initial state applied), in its precision or the given one")
      .def(
          "run",
          [](const Scene& s, const std::string& output, int threads, std::optional<double> duration,
             double checkpoint_every, bool progress) {
            manyrods::scene::RunResult r;
            {
              nb::gil_scoped_release release;
              r = manyrods::scene::run_scene(s, run_options(output, threads, duration, checkpoint_every, progress));
            }
            return run_result(r);
          },
          "output"_a, nb::kw_only(), "threads"_a = 1, "duration"_a = nb::none(), "checkpoint_every"_a = 0.0,
          "progress"_a = false, "Run the scene into an HDF5 file, as `manyrods run` does")
      .def(
          "sweep",
          [](const Scene& s, const std::vector<std::string>& vary, const std::string& output, int samples,
             std::uint64_t seed, int threads, std::optional<double> duration, std::optional<std::string> design,
             const std::string& frames) {
            if (frames != "ends" && frames != "all" && frames != "none")
              throw manyrods::scene::SceneError("sweep: frames = '" + frames + "': expected 'ends', 'all' or 'none'");
            std::vector<manyrods::scene::Vary> vs;
            for (const std::string& v : vary) vs.push_back(manyrods::scene::parse_vary(v));
            const manyrods::scene::Design des = manyrods::scene::make_design(design.value_or(""), samples, seed);
            manyrods::scene::SweepRun r;
            {
              nb::gil_scoped_release release;
              const manyrods::scene::Sweep sw = manyrods::scene::make_sweep(s.text, s.source, vs, des);
              manyrods::scene::RunOptions opt = run_options(output, threads, duration, 0, false);
              opt.frames = frames == "all"    ? manyrods::scene::RunOptions::Frames::all
                           : frames == "none" ? manyrods::scene::RunOptions::Frames::none
                                              : manyrods::scene::RunOptions::Frames::ends;
              r = manyrods::scene::run_sweep(sw, opt);
            }
            nb::dict d;
            d["parameters"] = columns(r.parameters);
            d["summary"] = columns(r.summary);
            d["statistics"] = columns(r.statistics);  // per observable, in the order of statistic_names
            d["statistic_names"] = manyrods::scene::sweep_statistic_names();
            if (!r.sensitivity.empty()) {  // saltelli: per observable, [S1 …, ST …] of the parameters
              d["sensitivity"] = columns(r.sensitivity);
              std::vector<std::string> keys;
              for (const auto& v : vs) keys.push_back(v.key);
              d["sensitivity_names"] = manyrods::scene::sensitivity_names(keys);
            }
            d["run"] = run_result(r.run);
            return d;
          },
          "vary"_a, "output"_a, nb::kw_only(), "samples"_a = 0, "seed"_a = 0, "threads"_a = 1,
          "duration"_a = nb::none(), "design"_a = nb::none(), "frames"_a = "ends",
          "A parameter sweep (`manyrods sweep`): vary = ['rods.0.damping.tau_extension=0:0.05:5', "
          "'rods.0.material.youngs_modulus=lognormal:1e6:0.2', …], design = 'grid' | 'mc' | 'lhs' | 'sobol' "
          "(default: grid, or mc with samples), frames = 'ends' (first and last step), 'all' or 'none'; returns the "
          "parameters, the per-variation summary and its statistics as NumPy arrays");

  m.def("load_scene", &manyrods::scene::load_scene, "path"_a, "Read and validate a TOML scene file");
  m.def(
      "read_output",
      [](const std::string& path) {
        const manyrods::h5::Reader r(path);
        const manyrods::h5::Output& o = r.output();
        const std::size_t frames = std::size_t(r.frames()), nodes = std::size_t(o.nodes);
        auto* x = new std::vector<double>(frames * nodes * 3);
        nb::capsule owner(x, [](void* v) noexcept { delete static_cast<std::vector<double>*>(v); });
        std::vector<double> f;
        for (std::size_t k = 0; k < frames; ++k) {
          r.read_positions(std::int64_t(k), f);
          std::copy(f.begin(), f.end(), x->begin() + std::ptrdiff_t(k * nodes * 3));
        }
        nb::dict d;
        d["time"] = o.time;
        d["node_offsets"] = o.node_offsets;
        d["rod_group"] = o.rod_group;
        d["rod_width"] = o.rod_width;
        d["group_names"] = o.group_names;
        d["node_position"] = nb::ndarray<nb::numpy, double>(x->data(), {frames, nodes, 3}, owner);
        return d;
      },
      "path"_a,
      "A manyrods output file's frames: time [frames], node_position [frames, nodes, 3] (m), node_offsets "
      "[rods + 1], rod_group, rod_width, group_names");
  m.def("parse_scene",
        [](const std::string& text, const std::string& source) { return manyrods::scene::parse_scene(text, source); },
        "text"_a, "source"_a = "<string>", "Parse and validate a scene from TOML text");
}
