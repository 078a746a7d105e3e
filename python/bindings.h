#pragma once
// One function per part of the library that the module exposes; gshell_module.cpp calls them in
// order (later parts use classes registered by earlier ones).
#include <pybind11/pybind11.h>

#include <nlohmann/json.hpp>
#include <mutex>
#include <string>

namespace gshell::python {

namespace py = pybind11;

void bind_io(py::module_& m);       ///< read_mesh, write_mesh, builtin
void bind_generate(py::module_& m); ///< Shell, generate, metrics, load_shell
void bind_deform(py::module_& m);   ///< Deformer, Embedding, embed
void bind_pose(py::module_& m);     ///< Poser

/// A JSON value as plain Python objects (dict, list, float, int, str, bool, None), by way of
/// json.loads, so the result is exactly what reading the CLI's report.json in Python gives.
py::object to_python(const nlohmann::json& value);
py::object to_python(const nlohmann::ordered_json& value);

/// A Python object (dict, list, ...) as JSON, by way of json.dumps. Raises ValueError when it
/// cannot be written as JSON.
nlohmann::json from_python(const py::handle& object, const char* name);

/// Runs `work` with the GIL released (other Python threads run meanwhile) and `mutex` (the
/// object's) held, and returns what it returns; the lock is let go before the GIL is taken back.
template <class Work> auto without_gil_locked(std::mutex& mutex, Work&& work) {
  py::gil_scoped_release release;
  const std::lock_guard<std::mutex> lock(mutex);
  return work();
}

} // namespace gshell::python
