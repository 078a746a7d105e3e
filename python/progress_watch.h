#pragma once
// Long calls let Python in while they run: at each solver iteration (or deform frame) they take
// the GIL for a moment to run pending signal handlers, so Ctrl-C (KeyboardInterrupt) ends them
// there instead of after minutes, and to call the `progress` argument the user gave.
#include <pybind11/pybind11.h>

#include <gshell/solver/shell_solver.h>

#include <chrono>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

namespace gshell::python {

namespace py = pybind11;

/// Thrown from a progress callback, through the library (with the GIL released), when Python has
/// an exception to raise: a signal handler's (KeyboardInterrupt) or the `progress` callable's.
/// The Python error stays set; the module's exception translator lets it through.
struct PythonErrorPending {};

/// The progress of one long call. Made with the GIL held from its `progress` argument: None
/// (nothing shown; signals are still checked, at most every 0.1 s), True (one line per update on
/// sys.stderr) or a callable, called with one dict per update (the fields named by each call's
/// docstring). Must outlive the call and die with the GIL held.
class ProgressWatch {
public:
  ProgressWatch(const py::object& progress, std::string call);
  ProgressWatch(const ProgressWatch&) = delete;
  ProgressWatch& operator=(const ProgressWatch&) = delete;

  /// Without the GIL: one update. \throws PythonErrorPending when a signal handler or the
  /// callable raised.
  void report(const nlohmann::ordered_json& update);
  /// Without the GIL: only the signal handlers (at most every 0.1 s), for the iterations of a
  /// call whose updates are coarser (deform's frames). \throws PythonErrorPending as report().
  void check_signals();
  /// Hooks solve.progress and solve.stage to report {"stage"?, "iteration", "energy", "seconds"}
  /// ("stage": the solve's stage name, e.g. paper, repair, relax, when it names one; before it
  /// names one, `first_stage` if not empty). When printing, each stage is also a line of its own
  /// as it begins.
  void watch(SolveOptions& solve, std::string first_stage = {});
  /// For calls whose updates add fields of their own (a pose step's number, a frame's): a
  /// callback for the job's `stage` option, and the stage it last named (empty before any).
  /// The signal handlers run at each stage too: generation's phases without iterations (setup,
  /// factor, start, metrics, certificate) take seconds at millions of faces. `print_stages`: when
  /// printing, each stage is also a line as it begins (a callable's dicts keep their documented
  /// keys, which a stage alone would not have).
  std::function<void(const char*)> stage_hook(bool print_stages = false) {
    return [this, print_stages](const char* name) {
      stage_ = name;
      if (print_stages && print_)
        report({{"stage", stage_}});
      else
        check_signals();
    };
  }
  const std::string& stage() const { return stage_; }

private:
  std::string line(const nlohmann::ordered_json& update) const; ///< for progress=True
  /// Runs the signal handlers, then `work`, with the GIL; a Python error becomes PythonErrorPending.
  void with_python(const std::function<void()>& work);

  py::object callable_; ///< None when printing or silent
  bool print_ = false;
  std::string call_, stage_;
  std::chrono::steady_clock::time_point last_check_{};
};

/// The module's exception translator for PythonErrorPending: the error is already set.
void register_python_error_pending();

} // namespace gshell::python
