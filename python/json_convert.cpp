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
  std::string text;
  try {
    // allow_nan=False: NaN is not JSON, and a NaN target must fail here, not inside a solve.
    text = py::module_::import("json").attr("dumps")(object, py::arg("allow_nan") = false).cast<std::string>();
  } catch (const py::error_already_set& e) {
    value_error(std::string(name) + " cannot be written as JSON: " + e.what());
  }
  return nlohmann::json::parse(text);
}

} // namespace gshell::python
