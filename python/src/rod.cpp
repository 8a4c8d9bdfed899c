// python/src/rod.cpp — manyrods._core: sections, materials, damping
// (include/manyrods/material.h) and rods (include/manyrods/batch.h RodSpec).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "bindings.h"

namespace manyrods_python {
namespace {

// ---- point and frame arrays --------------------------------------------------

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

// An array-like (a NumPy array, nested lists) of `ndim` dimensions as a
// float64 array (a Points or Frames), InputError naming `what` otherwise.
template <class Array>
Array array_of(nb::handle h, std::size_t ndim, const char* what, const char* shape) {
  const nb::object a = float64_array(h, what);
  if (nb::cast<std::size_t>(a.attr("ndim")) != ndim)
    throw manyrods::InputError(std::string(what) + ": shape " + shape + " expected (got " +
                               nb::repr(a.attr("shape")).c_str() + ")");
  return nb::cast<Array>(a);
}

// The section and material of a named constructor: both required (the
// library's defaults are zero, which no rod can be built from).
void require(const char* function, const std::optional<manyrods::Section>& section,
             const std::optional<manyrods::Material>& material) {
  if (section && material) return;
  std::string missing = !section && !material ? "'section' and 'material'" : !section ? "'section'" : "'material'";
  throw nb::type_error((std::string("Rod.") + function + "(): missing required keyword argument " + missing +
                        ": a rod has no default cross section or material; pass e.g. "
                        "section=manyrods.Section.circle(0.005), "
                        "material=manyrods.Material(density=1000, youngs_modulus=1e6, poisson_ratio=0.5)")
                           .c_str());
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
  const manyrods::RodEnd end = root ? manyrods::RodEnd::root : manyrods::RodEnd::tip;
  if (kind == "clamped") manyrods::set_end_hold(r, end, manyrods::HoldKind::clamped);
  else if (kind == "pinned") manyrods::set_end_hold(r, end, manyrods::HoldKind::pinned);
  else if (kind == "free") manyrods::set_end_hold(r, end, std::nullopt);
  else
    throw manyrods::InputError(std::string(root ? "root" : "tip") + ": \"free\", \"clamped\" or \"pinned\" (got \"" +
                               kind + "\")");
}

std::string hold_of(const RodSpec& r, bool root) {
  const std::optional<manyrods::HoldKind> h = manyrods::end_hold(r, root ? manyrods::RodEnd::root : manyrods::RodEnd::tip);
  return !h ? "free" : *h == manyrods::HoldKind::clamped ? "clamped" : "pinned";
}

// ---- reprs: Python expressions that rebuild the value ---------------------

// x as Python reads it, shortest round-trip ("0.01", "1000", "1e6", "2.5e-5").
std::string number(double x) {
  if (std::isnan(x)) return "math.nan";
  if (std::isinf(x)) return x > 0 ? "math.inf" : "-math.inf";
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  std::string s(buf, r.ptr);
  const std::size_t e = s.find('e');
  if (e != std::string::npos) {  // "1e+06" -> "1e6", "2.5e-05" -> "2.5e-5"
    std::string exp = s.substr(e + 1);
    const bool neg = exp[0] == '-';
    if (exp[0] == '+' || exp[0] == '-') exp.erase(0, 1);
    exp.erase(0, std::min(exp.find_first_not_of('0'), exp.size() - 1));
    s = s.substr(0, e + 1) + (neg ? "-" : "") + exp;
  }
  return s;
}

std::string section_repr(const manyrods::Section& x) {
  using Shape = manyrods::Shape;
  switch (x.shape) {
    case Shape::circle: return "Section.circle(" + number(x.a) + ")";
    case Shape::ellipse: return "Section.ellipse(" + number(x.a) + ", " + number(x.b) + ")";
    case Shape::rectangle: return "Section.rectangle(" + number(x.a) + ", " + number(x.b) + ")";
    case Shape::hollow_circle: return "Section.hollow_circle(" + number(x.a) + ", " + number(x.b) + ")";
  }
  return "Section(?)";
}

std::string material_repr(const manyrods::Material& x) {
  std::string s = "Material(density=" + number(x.density) + ", youngs_modulus=" + number(x.youngs_modulus);
  if (!std::isnan(x.poisson_ratio)) s += ", poisson_ratio=" + number(x.poisson_ratio);
  if (!std::isnan(x.shear_modulus)) s += ", shear_modulus=" + number(x.shear_modulus);
  return s + ")";
}

std::string damping_repr(const manyrods::Damping& x) {
  using Form = manyrods::Damping::Form;
  const std::string args = "(" + number(x.p1) + ", " + number(x.p2) + ")";
  switch (x.form) {
    case Form::none: return "Damping.none()";
    case Form::shear_bulk: return "Damping.shear_bulk" + args;
    case Form::shear_extension: return "Damping.shear_extension" + args;
    case Form::viscosities: return "Damping.viscosities" + args;
  }
  return "Damping(?)";
}

}  // namespace

// ---- sections, materials, damping (include/manyrods/material.h)
void bind_materials(nb::module_& m) {
  nb::class_<manyrods::Section>(m, "Section", "A cross section; principal axes d1, d2 (m)")
      .def_static("circle", &manyrods::Section::circle, "radius"_a)
      .def_static("ellipse", &manyrods::Section::ellipse, "semi_axis_1"_a, "semi_axis_2"_a)
      .def_static("rectangle", &manyrods::Section::rectangle, "width_1"_a, "height_2"_a)
      .def_static("hollow_circle", &manyrods::Section::hollow_circle, "outer_radius"_a, "inner_radius"_a)
      .def_rw("a", &manyrods::Section::a)
      .def_rw("b", &manyrods::Section::b)
      .def("__repr__", &section_repr);

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
      .def_rw("shear_modulus", &manyrods::Material::shear_modulus)
      .def("__repr__", &material_repr);

  nb::class_<manyrods::Damping>(m, "Damping", "Kelvin–Voigt parameters (retardation times in s, or viscosities)")
      .def(nb::init<>())
      .def_static("none", &manyrods::Damping::none)
      .def_static("shear_bulk", &manyrods::Damping::shear_bulk, "tau_shear"_a, "tau_bulk"_a)
      .def_static("shear_extension", &manyrods::Damping::shear_extension, "tau_shear"_a, "tau_extension"_a)
      .def_static("viscosities", &manyrods::Damping::viscosities, "shear_viscosity"_a, "bulk_viscosity"_a)
      .def("__repr__", &damping_repr);
}

// ---- rods (include/manyrods/batch.h RodSpec)

namespace {

// r with the properties both named constructors take.
RodSpec with_properties(RodSpec r, const manyrods::Section& section, const manyrods::Material& material,
                        const manyrods::Damping& damping, const std::string& root, const std::string& tip, bool stiff,
                        const std::string& name) {
  r.section = section;
  r.material = material;
  r.damping = damping;
  set_hold(r, true, root);
  set_hold(r, false, tip);
  r.stiff_implicit = stiff;
  r.name = name;
  return r;
}

// The named constructors: straight and polyline.
void bind_rod_factories(nb::class_<RodSpec>& c) {
  // (section and material are required; they are taken as None-able only so
  // that a missing one gets its own TypeError, and the signatures say so)
  c.def_static(
       "straight",
       [](const std::vector<double>& start, const std::vector<double>& direction, double length, int elements,
          std::optional<std::vector<double>> normal, const std::optional<manyrods::Section>& section,
          const std::optional<manyrods::Material>& material, const manyrods::Damping& damping,
          const std::string& root, const std::string& tip, bool stiff, const std::string& name) {
         require("straight", section, material);
         const Vec3 d = vec3(direction, "direction");
         const Vec3 n = normal ? vec3(*normal, "normal") : RodSpec::normal_across(d);
         if (!(elements >= 1)) throw manyrods::InputError("elements: must be >= 1 (got " + std::to_string(elements) + ")");
         return with_properties(RodSpec::straight(vec3(start, "start"), d, n, length, elements), *section, *material,
                                damping, root, tip, stiff, name);
       },
       "start"_a, "direction"_a, "length"_a, "elements"_a, nb::kw_only(), "normal"_a = nb::none(),
       "section"_a = nb::none(), "material"_a = nb::none(), "damping"_a = manyrods::Damping::none(),
       "root"_a = "clamped", "tip"_a = "free", "stiff"_a = false, "name"_a = "",
       nb::sig("def straight(start: collections.abc.Sequence[float], direction: collections.abc.Sequence[float], "
               "length: float, elements: int, *, normal: collections.abc.Sequence[float] | None = None, "
               "section: manyrods.Section, material: manyrods.Material, "
               "damping: manyrods.Damping = Damping.none(), root: str = 'clamped', tip: str = 'free', "
               "stiff: bool = False, name: str = '') -> manyrods.Rod"),
       "A straight rod of `elements` elements from `start` along `direction` (d3), d1 along `normal` made "
       "orthogonal (default: the axis least aligned with `direction`). `section` and `material` are required "
       "(TypeError without them): there is no default rod. root, tip: \"clamped\", \"pinned\" or \"free\".")
      .def_static(
          "polyline",
          [](nb::handle nodes, nb::handle frames, std::optional<std::vector<double>> first_normal,
             const std::optional<manyrods::Section>& section, const std::optional<manyrods::Material>& material,
             const manyrods::Damping& damping, const std::string& root, const std::string& tip, bool stiff,
             const std::string& name) {
            require("polyline", section, material);
            std::vector<Vec3> x = points_of(array_of<Points>(nodes, 2, "nodes", "(n+1, 3)"), "nodes");
            if (x.size() < 2) throw manyrods::InputError("nodes: a rod needs at least 2 nodes (got " + std::to_string(x.size()) + ")");
            std::vector<Mat3> q;
            if (!frames.is_none()) {
              q = frames_of(array_of<Frames>(frames, 3, "frames", "(n, 3, 3)"), "frames");
            } else {
              // (a zero first normal: RodSpec::normal_across the first element)
              q = RodSpec::parallel_transport_frames(
                  x, first_normal ? vec3(*first_normal, "first_normal") : Vec3{0, 0, 0});
            }
            return with_properties(RodSpec::polyline(std::move(x), std::move(q)), *section, *material, damping, root,
                                   tip, stiff, name);
          },
          "nodes"_a, "frames"_a = nb::none(), nb::kw_only(), "first_normal"_a = nb::none(),
          "section"_a = nb::none(), "material"_a = nb::none(), "damping"_a = manyrods::Damping::none(),
          "root"_a = "clamped", "tip"_a = "free", "stiff"_a = false, "name"_a = "",
          nb::sig("def polyline(nodes: numpy.typing.ArrayLike, frames: numpy.typing.ArrayLike | None = None, *, "
                  "first_normal: collections.abc.Sequence[float] | None = None, section: manyrods.Section, "
                  "material: manyrods.Material, damping: manyrods.Damping = Damping.none(), root: str = 'clamped', "
                  "tip: str = 'free', stiff: bool = False, name: str = '') -> manyrods.Rod"),
          "A rod along the polyline `nodes` ((n+1, 3) array-like, m): its shape is the rest shape. `frames` "
          "(n, 3, 3), rows d1, d2, d3; default: parallel transport (twist-free) from `first_normal`. `section` and "
          "`material` are required (TypeError without them): there is no default rod.");
}

// A held end's host motion by name (a HostMotion; None: static), for
// root_driver and tip_driver.
template <std::shared_ptr<const manyrods::RootMotion> RodSpec::*kMotion>
void def_driver(nb::class_<RodSpec>& c, const char* name, const char* doc) {
  c.def_prop_rw(
      name,
      [](const RodSpec& r) -> std::optional<std::string> {
        if (auto h = std::dynamic_pointer_cast<const manyrods::HostMotion>(r.*kMotion)) return h->name();
        return std::nullopt;
      },
      [](RodSpec& r, std::optional<std::string> motion) {
        r.*kMotion = motion ? std::make_shared<manyrods::HostMotion>(*motion) : nullptr;
      },
      doc);
}

// Host motions, holds, parameters and the (copied) arrays.
void bind_rod_fields(nb::class_<RodSpec>& c) {
  def_driver<&RodSpec::root_motion>(
      c, "root_driver", "the host motion the held root follows, by name (Batch.set_driver_pose); None: static");
  def_driver<&RodSpec::tip_motion>(c, "tip_driver", "the host motion the held tip follows, by name; None: static");
  c.def_rw("name", &RodSpec::name)
      .def_rw("section", &RodSpec::section)
      .def_rw("material", &RodSpec::material)
      .def_rw("damping", &RodSpec::damping)
      .def_rw("stiff", &RodSpec::stiff_implicit)
      .def_rw("section_scale", &RodSpec::section_scale,
              "a tapered rod: each element's section scaled by this factor (area x f^2, second moments x f^4, "
              "contact radius x f); [] (the default): uniform")
      .def_rw("preload", &RodSpec::preload,
              "gravity preload: the rest shape is solved so that the rod as given is its static equilibrium under "
              "gravity (and the batch's loads: Batch.preload() again after setting them)")
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
}

}  // namespace

void bind_rod(nb::module_& m) {
  nb::class_<RodSpec> c(m, "Rod", "One rod as the user describes it (double precision, SI units)");
  bind_rod_factories(c);
  bind_rod_fields(c);
}

}  // namespace manyrods_python
