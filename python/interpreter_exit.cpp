#include "interpreter_exit.h"

#include <atomic>
#include <chrono>
#include <thread>

namespace gshell::python {

namespace {

std::atomic<bool> exiting{false};
std::atomic<int> calls_without_gil{0};

/// How long the exit waits for calls that do not check in (a factorisation has no progress
/// checks): beyond it the process exits as it would have without the wait.
constexpr std::chrono::seconds kLongestWait{60};

void wait_for_calls() {
  exiting = true;
  py::gil_scoped_release release; // the waited-for calls need the GIL to return
  const auto give_up = std::chrono::steady_clock::now() + kLongestWait;
  while (calls_without_gil.load() > 0 && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
}

} // namespace

bool interpreter_exiting() { return exiting.load(std::memory_order_relaxed); }

void stop_if_interpreter_exiting() {
  if (interpreter_exiting()) throw InterpreterExiting{};
}

ReleasedGil::ReleasedGil() {
  ++calls_without_gil;
  release_.emplace();
}

ReleasedGil::~ReleasedGil() {
  release_.reset(); // the GIL first: the count may reach 0 only once this thread holds it
  --calls_without_gil;
}

void register_interpreter_exit() {
  py::module_::import("atexit").attr("register")(py::cpp_function(&wait_for_calls));
  // A forked child has only the thread that forked, which holds the GIL: no call is running there.
  py::module_::import("os").attr("register_at_fork")(
      py::arg("after_in_child") = py::cpp_function([] { calls_without_gil = 0; }));
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InterpreterExiting&) {
      PyErr_SetString(PyExc_SystemExit, "gshell: the interpreter is exiting");
    }
  });
}

} // namespace gshell::python
