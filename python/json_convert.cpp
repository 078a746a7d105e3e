#include "bindings.h"
#include "numpy_arrays.h"

namespace gshell::python {

namespace {
template <class Json> py::object loads(const Json& value) {
  // replace: a path with invalid UTF-8 in a report must not make the whole result unreadable.
  const std::string text = value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return py::module_::import("json").attr("loads")(text);
}
} // namespace

py::object to_python(const nlohmann::json& value) { return loads(value); }
py::object to_python(const nlohmann::ordered_json& value) { return loads(value); }

nlohmann::json from_python(const py::handle& object, const char* name) {
  // NumPy scalars and arrays (np.int64(3), np.array([0, 0, 1])) are what users hold their ids and
  // vectors in: written through their tolist(). Anything else json cannot write stays an error.
  const py::cpp_function numpy_to_list([](const py::object& value) -> py::object {
    if (py::hasattr(value, "tolist")) return value.attr("tolist")();
    throw py::type_error("Object of type " + std::string(py::str(py::type::of(value).attr("__name__"))) +
                         " is not JSON serializable");
  });
  std::string text;
  try {
    // allow_nan=False: NaN is not JSON, and a NaN target must fail here, not inside a solve.
    text = py::module_::import("json")
               .attr("dumps")(object, py::arg("allow_nan") = false, py::arg("default") = numpy_to_list)
               .cast<std::string>();
  } catch (const py::error_already_set& e) {
    // The exception's own message only: what() appends a traceback, and errors are one line.
    value_error(std::string(name) + " cannot be written as JSON: " + std::string(py::str(e.value())));
  }
  return nlohmann::json::parse(text);
}

} // namespace gshell::python
