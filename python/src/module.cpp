// The `_cariesim` module: cariesim::Error becomes the package's cariesim.Error (cariesim/_errors.py,
// which reads file, line, column, field and row out of the message), then each layer's bindings.

#include <pybind11/pybind11.h>

#include <exception>

#include "bindings.hpp"
#include "cariesim/common/error.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_cariesim, m) {
  m.doc() = "cariesim's C++ library (use the `cariesim` package, docs/python.md)";
  // Every cariesim::Error raises cariesim.Error with its location parsed.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const cariesim::Error& e) {
      const py::object error = py::module_::import("cariesim._errors").attr("Error")(e.what());
      PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(error.ptr())), error.ptr());
    }
  });
  cariesim::python::bind_scene(m);
  cariesim::python::bind_simulate(m);
  cariesim::python::bind_records(m);
}
