// python/src/batch.cpp — manyrods._core: the Batch and its state as
// zero-copy NumPy views.
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
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "bindings.h"

namespace manyrods_python {
namespace {

// ---- the batch ---------------------------------------------------------------

manyrods::Integrator integrator_of(const std::string& i) {
  if (i == "position_verlet") return manyrods::Integrator::position_verlet;
  if (i == "pefrl") return manyrods::Integrator::pefrl;
  throw manyrods::InputError("integrator: \"position_verlet\" or \"pefrl\" (got \"" + i + "\")");
}

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
#define MANYRODS_ENERGY_ITEM(name, dataset, unit, written, doc) d[#name] = e.name;
  MANYRODS_ENERGY_FIELDS(MANYRODS_ENERGY_ITEM)
#undef MANYRODS_ENERGY_ITEM
  d["total"] = e.total();
  return d;
}

// Steps with the GIL released; Ctrl-C between chunks (see the top).
// force_dt: run a dt above the stable limit (AnyBatch::check_dt refuses it
// otherwise, as `manyrods run` does).
void step_batch(PyBatch& pb, double dt, std::int64_t count, bool force_dt) {
  bool interrupted = false;
  {
    nb::gil_scoped_release release;
    pb.b.step(dt, count, pb.threads,
              [&] {
                nb::gil_scoped_acquire acquire;
                if (PyErr_CheckSignals() != 0) interrupted = true;
                return !interrupted;
              },
              0.1, force_dt);
  }
  if (interrupted) throw nb::python_error();
}

}  // namespace

// ---- batches

namespace {

// The constructor, sizes, time and the slots of each rod.
void bind_batch_layout(nb::class_<PyBatch>& c) {
  c.def(
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
                   "the scene's step (its dt or \"auto\"); rods built in code: 0.9 × min(stable_dt()['elastic'], stable_dt()['accuracy'])")
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
          "rod"_a, "The slots of rod `rod`'s elements");
}

// The state and load views, their setters, and a copy of the positions.
void bind_batch_state(nb::class_<PyBatch>& c) {
  // the views, one per entry of include/manyrods/fields.h MANYRODS_PUBLIC_ARRAYS:
  // the state read-only (its setters below write it), the loads writable
#define MANYRODS_PY_VIEW(group, field, name, doc)                                                          \
  c.def_prop_ro(                                                                                           \
      #name,                                                                                               \
      [](nb::handle self) {                                                                                \
        return nb::cast<PyBatch&>(self).b.visit([&](auto& b) -> nb::object {                              \
          constexpr bool kWritable = std::string_view(#group) == "loads";                                  \
          return field_view(b.group.field, b.slots(), kWritable, b.group.field.size() == 9, self);        \
        });                                                                                                \
      },                                                                                                   \
      std::string_view(#group) == "loads" ? doc ", a writable view" : doc ", a read-only view");
  MANYRODS_PUBLIC_ARRAYS(MANYRODS_PY_VIEW)
#undef MANYRODS_PY_VIEW
  c.def(
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
          "All nodes in rod order, (nodes, 3), a copy (the HDF5 frame layout)");
}

// Stepping, energies, the stable step and statics.
void bind_batch_dynamics(nb::class_<PyBatch>& c) {
  c.def(
       "step",
       [](PyBatch& p, double dt, std::int64_t count, bool force_dt) { step_batch(p, dt, count, force_dt); }, "dt"_a,
       "count"_a = 1, nb::kw_only(), "force_dt"_a = false,
       "`count` steps of length dt (GIL released; Ctrl-C stops between chunks). NonFiniteError names the first "
       "bad step.\n\nThe step-size guard: a dt above stable_dt()['elastic'] (the limit of what the batch "
       "integrates explicitly) raises ValueError naming the limit and the safe value (0.9 x the limit), as "
       "`manyrods run` does; force_dt=True runs it anyway, for studying what it does (a rod that moves then "
       "blows up within a few steps: NonFiniteError).")
      .def(
          "advance",
          [](PyBatch& p, double duration, std::optional<double> dt, bool force_dt) {
            const double h = dt ? *dt : p.b.scene_dt();
            if (!(duration >= 0) || !std::isfinite(duration))
              throw manyrods::InputError("advance: duration must be >= 0 and finite");
            if (!(h > 0)) throw manyrods::InputError("advance: dt must be > 0");
            const std::int64_t n = std::llround(duration / h);
            step_batch(p, h, n, force_dt);
            return n;
          },
          "duration"_a, "dt"_a = nb::none(), nb::kw_only(), "force_dt"_a = false,
          "Advance by `duration` s in steps of dt (default: Batch.dt); returns the steps. A dt above "
          "stable_dt()['elastic'] raises ValueError (the step-size guard, see Batch.step) unless force_dt=True.")
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
            d["accuracy"] = s.accuracy;
            return d;
          },
          "The largest stable step (s) of what the batch integrates explicitly ('elastic'; inf: none, e.g. only "
          "stiff rods) and the stiff rods' accuracy step ('accuracy', the one dt = \"auto\" takes for them)")
      .def(
          "solve_static",
          [](PyBatch& p, int load_steps, double tolerance, std::optional<double> at, bool check) {
            manyrods::StaticOptions o;
            o.load_steps = load_steps;
            o.tolerance = tolerance;
            if (at) o.hold_time = *at;
            manyrods::StaticResult r;
            {
              nb::gil_scoped_release release;
              r = p.b.solve_static(o);
            }
            if (check) p.b.check_static(r);
            nb::dict d;
            d["converged"] = r.converged;
            d["iterations"] = r.iterations;
            d["load_increments"] = r.load_increments;
            d["warm_rods"] = r.warm_rods;
            d["sticking"] = r.sticking;
            d["slipping"] = r.slipping;
            d["last_update"] = r.last_update;
            d["residual_force"] = r.residual_force;
            d["residual_couple"] = r.residual_couple;
            d["failed_rod"] = r.failed_rod;
            d["failed_node"] = r.failed_node;
            d["load_reached"] = r.load_reached;
            d["mechanism"] = r.mechanism;
            d["message"] = p.b.static_failure(r);
            return d;
          },
          "load_steps"_a = 10, "tolerance"_a = 1e-10, "at"_a = nb::none(), nb::kw_only(), "check"_a = true,
          "Static equilibrium under the loads, gravity and buoyancy, the colliders' push and friction and the rods' "
          "contact (double batches, no wind), from the current state along an adaptive load path; `at`: the time (s) whose poses the driven holds take (the "
          "batch's time becomes it). Without an equilibrium: ValueError for a rod that is a mechanism under its "
          "loads, manyrods.StaticError when Newton fails (the message names the rod, node and residual), or with "
          "check=False the dict says so (converged, failed_rod, message). Returns iterations, load_increments, "
          "residual_force (N), residual_couple (N m), sticking and slipping (collider contacts with friction: "
          "nodes stuck where they first touched, nodes at the friction limit), ...")
      .def(
          "preload",
          [](PyBatch& p) {
            manyrods::PreloadResult r;
            {
              nb::gil_scoped_release release;
              r = p.b.preload();
            }
            nb::dict d;
            d["rods"] = r.rods;
            d["contacts"] = r.contacts;
            d["residual_force"] = r.residual_force;
            d["residual_couple"] = r.residual_couple;
            return d;
          },
          "Gravity preload again: the rest shapes of the rods with preload solved so that the rods as they are now "
          "stand still under gravity and the loads as they are now (the batch's build did it for the rods as "
          "built). ValueError naming the rod and node where no rest shape does (a free rod in gravity), or the rod "
          "whose equilibrium would be unstable (beyond its buckling load); the rest shapes then stay as they were. Returns "
          "rods, contacts (collider touches carrying load), residual_force (N), residual_couple (N m)")
      .def(
          "hold_reactions",
          [](const PyBatch& p) {
            const std::vector<manyrods::HoldReaction> h = p.b.hold_reactions();
            const std::size_t n = h.size();
            auto* fm = new double[6 * n + 1];
            auto* ints = new std::int32_t[3 * n + 1];
            for (std::size_t i = 0; i < n; ++i) {
              ints[i] = h[i].rod, ints[n + i] = h[i].node, ints[2 * n + i] = h[i].clamped;
              for (int a = 0; a < 3; ++a) fm[3 * i + a] = h[i].force[a], fm[3 * n + 3 * i + a] = h[i].moment[a];
            }
            nb::capsule own_f(fm, [](void* q) noexcept { delete[] static_cast<double*>(q); });
            nb::capsule own_i(ints, [](void* q) noexcept { delete[] static_cast<std::int32_t*>(q); });
            nb::dict d;
            d["rod"] = nb::ndarray<nb::numpy, std::int32_t>(ints, {n}, own_i);
            d["node"] = nb::ndarray<nb::numpy, std::int32_t>(ints + n, {n}, own_i);
            d["clamped"] = nb::ndarray<nb::numpy, std::int32_t>(ints + 2 * n, {n}, own_i);
            d["force"] = nb::ndarray<nb::numpy, double>(fm, {n, 3}, own_f);
            d["moment"] = nb::ndarray<nb::numpy, double>(fm + 3 * n, {n, 3}, own_f);
            return d;
          },
          "The reactions at the held nodes now (at rest), rod by rod, root to tip: rod, node, clamped (1 or 0), "
          "force (H, 3) in N and moment (H, 3) in N m, lab frame, what each hold exerts on its rod (at a static "
          "equilibrium: the connector loads). Double batches.");
}

// The state's hash and HDF5 file.
void bind_batch_output(nb::class_<PyBatch>& c) {
  c.def("state_hash", [](const PyBatch& p) { return p.b.state_hash(); },
        "FNV-1a hash of the state: equal hashes = bit-identical states")
      .def(
          "save",
          [](const PyBatch& p, const std::string& path, bool holds) {
            if (!holds) return p.b.save(path);
            const manyrods::h5::Holds h = p.b.holds_record();  // (the residuals are not known here)
            p.b.save(path, &h);
          },
          "path"_a, nb::kw_only(), "holds"_a = false,
          "An HDF5 file (the run layout) with this state as its one frame and checkpoint; holds=True adds the "
          "reactions at the holds (/holds, as `manyrods static` writes; double batches)");
}

// ---- driver poses: rotation as a matrix, 9 numbers or a quaternion --------

// The rotation of set_driver_pose from a 3 × 3 array-like, 9 numbers row by
// row, or a unit quaternion (w, x, y, z); InputError naming what is wrong.
manyrods::Mat3 rotation_of(nb::handle rotation) {
  const nb::object a = float64_array(rotation, "rotation");
  const nb::ndarray<const double, nb::device::cpu> v = nb::cast<nb::ndarray<const double, nb::device::cpu>>(a);
  std::vector<double> q;
  const std::int64_t* st = v.stride_ptr();
  if (v.ndim() == 2 && v.shape(0) == 3 && v.shape(1) == 3) {
    for (std::size_t r = 0; r < 3; ++r)
      for (std::size_t c = 0; c < 3; ++c) q.push_back(v.data()[std::int64_t(r) * st[0] + std::int64_t(c) * st[1]]);
  } else if (v.ndim() == 1 && (v.shape(0) == 9 || v.shape(0) == 4)) {
    for (std::size_t i = 0; i < v.shape(0); ++i) q.push_back(v.data()[std::int64_t(i) * st[0]]);
  } else {
    std::string shape = "(";
    for (std::size_t i = 0; i < v.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(v.shape(i));
    shape += v.ndim() == 1 ? ",)" : ")";
    throw manyrods::InputError("rotation: a 3 x 3 matrix, 9 numbers (row by row) or a quaternion (w, x, y, z) "
                               "expected (got shape " + shape + ")");
  }
  for (std::size_t i = 0; i < q.size(); ++i)
    if (!std::isfinite(q[i]))
      throw manyrods::InputError("rotation: value " + std::to_string(i) + " is not finite");
  manyrods::Mat3 m;
  if (q.size() == 4) {  // unit quaternion (w, x, y, z) → matrix
    const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(std::abs(n - 1) <= 1e-6))
      throw manyrods::InputError("rotation: a quaternion (w, x, y, z) must have unit norm (within 1e-6; got |q| = " +
                                 std::to_string(n) + ")");
    const double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    m = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
         2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
         2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
    return m;
  }
  std::copy(q.begin(), q.end(), m.begin());
  return m;  // (HostMotion::set_target checks that it is a proper rotation)
}

void set_driver_pose(PyBatch& p, const std::string& name, nb::handle rotation,
                     std::optional<std::vector<double>> translation, std::optional<std::vector<double>> pivot,
                     double time) {
  manyrods::Pose pose;
  if (!rotation.is_none()) pose.rotation = rotation_of(rotation);
  const Vec3 t = translation ? vec3(*translation, "translation") : Vec3{0, 0, 0};
  const Vec3 c = pivot ? vec3(*pivot, "pivot") : Vec3{0, 0, 0};
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(t[i]) || !std::isfinite(c[i]))
      throw manyrods::InputError(std::string(std::isfinite(t[i]) ? "pivot" : "translation") + ": component " +
                                 std::to_string(i) + " is not finite");
  pose.translation = t;
  p.b.set_driver_pose(p.b.find_driver(name), pose, time, c);  // (HostMotion::set_target turns it about c)
}

// Host motions (drivers) and their poses.
void bind_batch_drivers(nb::class_<PyBatch>& c) {
  c.def_prop_ro(
       "drivers",
       [](const PyBatch& p) {
         std::vector<std::string> v;
         for (int i = 0; i < p.b.driver_count(); ++i) v.push_back(p.b.driver_name(i));
         return v;
       },
       "the names of the batch's host motions (a scene's motion = \"host\", Rod.root_driver / tip_driver)")
      .def("set_driver_pose", &set_driver_pose, "name"_a, "rotation"_a = nb::none(), "translation"_a = nb::none(),
           nb::kw_only(), "pivot"_a = nb::none(), "time"_a,
           nb::sig("def set_driver_pose(self, name: str, rotation: numpy.typing.ArrayLike | None = None, "
                   "translation: collections.abc.Sequence[float] | None = None, *, "
                   "pivot: collections.abc.Sequence[float] | None = None, time: float) -> None"),
           "Moves the host motion `name` from its pose at Batch.time to this pose at `time` >= Batch.time (the "
           "translation linearly, the rotation along the shortest arc), and holds it there. The pose maps a point "
           "x to R (x - pivot) + pivot + translation.\n\n"
           "rotation: a 3 x 3 array-like (R, rows), 9 numbers (R row by row) or a unit quaternion "
           "(w, x, y, z), scalar first, Hamilton convention: (cos(a/2), sin(a/2) axis) turns by a about axis); "
           "default identity. A matrix must be a proper rotation (|R R^T - I| <= 1e-6, det > 0), a quaternion "
           "unit within 1e-6 (it is normalized); values must be finite.\n"
           "translation: 3 numbers, m, default 0. pivot: the point the rotation turns about, m, default the "
           "origin.");
}

}  // namespace

void bind_batch(nb::module_& m) {
  nb::class_<PyBatch> c(m, "Batch",
                        "Many rods in structure-of-arrays form. State views (node_position, node_velocity, "
                        "element_directors, element_omega) are read-only zero-copy NumPy arrays indexed by slot; "
                        "loads (node_force, element_couple) are writable.");
  bind_batch_layout(c);
  bind_batch_state(c);
  bind_batch_dynamics(c);
  bind_batch_output(c);
  bind_batch_drivers(c);
}

}  // namespace manyrods_python
