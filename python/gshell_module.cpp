// The `gshell` Python module: NumPy arrays in and out of the library (see python/README section).
#include "bindings.h"
#include "gil_probe.h"
#include "progress_watch.h"

#include <gshell/error.h>

#include <cstring>

namespace py = pybind11;

PYBIND11_MODULE(gshell, m) {
  m.doc() = R"(gshell: shells over triangle surfaces (Huang et al. 2007, "Gradient-based shell
generation and deformation"), with NumPy arrays.

Conventions: vertices V are float arrays of shape (n, 3) (converted to float64), faces F integer
arrays of shape (m, 3) with counter-clockwise faces (outward normals), tets integer arrays of
shape (k, 4). Shell vertices are numbered base 0..n-1, then top n..2n-1. Results are float64 /
int64 arrays. Bad input (wrong shape or dtype, NaN, index out of range, unknown option, a mesh
that cannot carry a shell, a file that cannot be read) raises ValueError. Long computations
release the GIL, take a `progress` argument and end at Ctrl-C (KeyboardInterrupt).)";
  m.attr("__version__") = GSHELL_VERSION;

  // InputError is the library's "bad input" (one line naming the file or argument).
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const gshell::InputError& e) {
      // Messages name files, whose names are bytes: one that is not UTF-8 made PyErr_SetString
      // fail and left a ValueError without a message. Such bytes are shown as \xNN escapes.
      const char* what = e.what();
      PyObject* message = PyUnicode_DecodeUTF8(what, static_cast<Py_ssize_t>(std::strlen(what)), "backslashreplace");
      if (!message) {
        PyErr_Clear();
        message = PyUnicode_FromString("(a message that is not text)");
      }
      PyErr_SetObject(PyExc_ValueError, message);
      Py_XDECREF(message);
    }
  });
  gshell::python::register_python_error_pending(); // KeyboardInterrupt and progress callables' errors
  gshell::python::register_interpreter_exit(); // calls in Python threads when the interpreter exits

  gshell::python::bind_io(m);
  gshell::python::bind_generate(m);
  gshell::python::bind_deform(m);
  gshell::python::bind_pose(m);
  gshell::python::bind_gil_probe(m);
  gshell::python::shorten_argument_type_errors(m);
}
