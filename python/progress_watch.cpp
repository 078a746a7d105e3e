#include "progress_watch.h"

#include "bindings.h"
#include "numpy_arrays.h"

#include <cstdio>

namespace gshell::python {

ProgressWatch::ProgressWatch(const py::object& progress, std::string call) : call_(std::move(call)) {
  if (progress.is_none()) return;
  if (py::isinstance<py::bool_>(progress)) {
    print_ = progress.cast<bool>();
    return;
  }
  if (!PyCallable_Check(progress.ptr())) value_error("progress must be None, True, False or a callable taking one dict");
  callable_ = progress;
}

std::string ProgressWatch::line(const nlohmann::ordered_json& update) const {
  std::string text = call_ + ":";
  for (const auto& [key, value] : update.items()) {
    text += (text.back() == ':' ? " " : ", ") + key + " ";
    if (value.is_string()) {
      text += value.get<std::string>();
    } else if (value.is_number_float()) {
      char number[32];
      std::snprintf(number, sizeof number, "%.6g", value.get<double>());
      text += number;
    } else {
      text += value.dump();
    }
  }
  return text + "\n";
}

void ProgressWatch::report(const nlohmann::ordered_json& update) {
  stop_if_interpreter_exiting(); // before the GIL: taking it then would end this thread badly
  if (!print_ && !callable_) return check_signals();
  with_python([&] {
    if (callable_)
      callable_(to_python(update));
    else if (const py::object stderr_ = py::module_::import("sys").attr("stderr"); !stderr_.is_none())
      stderr_.attr("write")(line(update)); // None under pythonw and some services: print() skips it too
  });
}

void ProgressWatch::check_signals() {
  stop_if_interpreter_exiting();
  // Taking the GIL can wait for another Python thread's time slice (5 ms): not at every iteration
  // of a fast solve when nothing is shown.
  const auto now = std::chrono::steady_clock::now();
  if (now - last_check_ < std::chrono::milliseconds(100)) return;
  last_check_ = now;
  with_python([] {});
}

void ProgressWatch::with_python(const std::function<void()>& work) {
  py::gil_scoped_acquire gil;
  try {
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    work();
  } catch (py::error_already_set& e) {
    e.restore(); // the Python error, set again for the translator once the call unwinds
    throw PythonErrorPending{};
  }
}

void ProgressWatch::watch(SolveOptions& solve, std::string first_stage) {
  stage_ = std::move(first_stage);
  solve.stage = stage_hook(true);
  solve.progress = [this](int iteration, double energy, double seconds) {
    nlohmann::ordered_json update;
    if (!stage_.empty()) update["stage"] = stage_;
    update["iteration"] = iteration;
    update["energy"] = energy;
    update["seconds"] = seconds;
    report(update);
  };
}

void register_python_error_pending() {
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const PythonErrorPending&) {
      if (!PyErr_Occurred()) PyErr_SetString(PyExc_RuntimeError, "gshell: the call was interrupted");
    }
  });
}

} // namespace gshell::python
