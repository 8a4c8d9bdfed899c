// python/src/module.cpp — the Python module manyrods._core (nanobind): scenes,
// rods, batches, and the batch's state as zero-copy NumPy views.
//
// NB_MODULE calls one bind_* per class or group (python/src/bindings.h), in
// order: errors (here), sections, materials, damping and rods (rod.cpp),
// batches (batch.cpp), scenes and the module's readers (scene.cpp), the
// CMA-ES (cmaes.cpp).
#include "bindings.h"
#include "manyrods/curves.h"
#include "manyrods/h5io.h"
#include "manyrods/runner.h"

namespace manyrods_python {

// ---- errors: InputError and SceneError -> ValueError, files -> OSError
void bind_errors(nb::module_& m) {
  static nb::exception<manyrods::NonFiniteError> non_finite(m, "NonFiniteError", PyExc_RuntimeError);
  static nb::exception<manyrods::scene::ValidityError> validity(m, "ValidityError", PyExc_RuntimeError);
  static nb::exception<manyrods::scene::StaticError> no_equilibrium(m, "StaticError", PyExc_RuntimeError);
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
}

}  // namespace manyrods_python

NB_MODULE(_core, m) {
  m.doc() = "manyrods: many Cosserat rods with Kelvin–Voigt damping (the C++ library's Python module)";
  m.attr("__version__") = MANYRODS_VERSION;

  manyrods_python::bind_errors(m);
  manyrods_python::bind_materials(m);
  manyrods_python::bind_rod(m);
  manyrods_python::bind_batch(m);
  manyrods_python::bind_scene(m);
  manyrods_python::bind_io(m);
  manyrods_python::bind_cmaes(m);
  // binary USD grooms (.usdc, .usdz) through OpenUSD's pxr, imported when
  // one is read (docs/scenes.md "Grooms from curves")
  manyrods::scene::set_usd_converter([](const std::string& path) -> std::string {
    nb::gil_scoped_acquire gil;
    nb::object usd;
    try {
      usd = nb::module_::import_("pxr.Usd");
    } catch (const nb::python_error&) {
      throw manyrods::InputError(path + ": binary USD is read through OpenUSD, whose Python module (pxr) is not "
                                 "installed: pip install usd-core, or convert it to USD ASCII (usdcat)");
    }
    nb::object stage;
    try {
      stage = usd.attr("Stage").attr("Open")(path);
    } catch (const nb::python_error& e) {
      throw manyrods::InputError(path + ": OpenUSD cannot open it: " + e.what());
    }
    if (stage.is_none()) throw manyrods::InputError(path + ": OpenUSD cannot open it");
    return nb::cast<std::string>(stage.attr("ExportToString")());  // the composed stage, flattened, as text
  });
}
