// python/src/bindings.h — what the files of the Python module manyrods._core
// share: the bind_* functions NB_MODULE (module.cpp) calls, the conversions
// more than one of them uses, and the Python Batch.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/variant.h>
#include <nanobind/stl/vector.h>

#include <string>
#include <vector>

#include "manyrods/any_batch.h"
#include "manyrods/manyrods.h"
#include "manyrods/scene.h"

namespace nb = nanobind;

namespace manyrods_python {

using namespace nb::literals;
using manyrods::Mat3;
using manyrods::RodSpec;
using manyrods::Vec3;
using manyrods::scene::AnyBatch;
using manyrods::scene::Precision;
using manyrods::scene::Scene;

// ---- small conversions (rods, batches, scenes) -------------------------------

inline Vec3 vec3(const std::vector<double>& v, const char* what) {
  if (v.size() != 3) throw manyrods::InputError(std::string(what) + ": needs 3 values (got " + std::to_string(v.size()) + ")");
  return {v[0], v[1], v[2]};
}

// `h` as a float64 NumPy array (numpy.asarray: lists, tuples, arrays of any
// number type); InputError naming `what` when it is not numbers.
inline nb::object float64_array(nb::handle h, const char* what) {
  try {
    return nb::module_::import_("numpy").attr("asarray")(h, "dtype"_a = "float64");
  } catch (const nb::python_error& e) {
    throw manyrods::InputError(std::string(what) + ": not an array of numbers (" +
                               nb::str(e.value()).c_str() + ")");
  }
}

inline Precision precision_of(const std::string& p) {
  if (p == "double" || p == "float64") return Precision::float64;
  if (p == "float" || p == "float32") return Precision::float32;
  throw manyrods::InputError("precision: \"double\" or \"float\" (got \"" + p + "\")");
}

// ---- the batch ---------------------------------------------------------------

// A Python Batch: the AnyBatch and the thread count its calls use.
struct PyBatch {
  AnyBatch b;
  int threads = 1;
};

// ---- the bindings, in the order NB_MODULE calls them: nanobind needs a class
// bound before a signature that uses it
void bind_errors(nb::module_& m);     // module.cpp
void bind_materials(nb::module_& m);  // rod.cpp
void bind_rod(nb::module_& m);        // rod.cpp
void bind_batch(nb::module_& m);      // batch.cpp
void bind_scene(nb::module_& m);      // scene.cpp
void bind_io(nb::module_& m);         // scene.cpp
void bind_cmaes(nb::module_& m);      // cmaes.cpp

}  // namespace manyrods_python
