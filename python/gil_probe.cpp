#include "gil_probe.h"
#include "interpreter_exit.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>

namespace gshell::python {

namespace py = pybind11;

namespace {

struct Probe {
  std::atomic<bool> armed{false};
  std::mutex mutex;
  std::condition_variable changed;
  bool entered = false, released = false, passed = false;
};

Probe& probe() {
  static Probe p;
  return p;
}

} // namespace

void pass_gil_probe() {
  Probe& p = probe();
  if (!p.armed.exchange(false)) return; // one call per arming
  std::unique_lock<std::mutex> lock(p.mutex);
  p.entered = true;
  p.changed.notify_all();
  // A bound, not a timing assertion: only a call that wrongly holds the GIL ever waits this long
  // (the releasing thread cannot run), and it then fails instead of hanging the test run.
  p.passed = p.changed.wait_for(lock, std::chrono::seconds(60), [&] { return p.released; });
}

void bind_gil_probe(py::module_& m) {
  m.def("_gil_probe_arm", [] {
    Probe& p = probe();
    const std::lock_guard<std::mutex> lock(p.mutex);
    p.entered = p.released = p.passed = false;
    p.armed = true;
  }, "Tests only: the next long call stops inside its GIL-released part until _gil_probe_release().");
  m.def("_gil_probe_wait_entered", [](double timeout) {
    ReleasedGil release;
    Probe& p = probe();
    std::unique_lock<std::mutex> lock(p.mutex);
    return p.changed.wait_for(lock, std::chrono::duration<double>(timeout), [&] { return p.entered; });
  }, py::arg("timeout"), "Tests only: wait until a long call reached the probe; False on timeout.");
  m.def("_gil_probe_release", [] {
    Probe& p = probe();
    const std::lock_guard<std::mutex> lock(p.mutex);
    p.released = true;
    p.changed.notify_all();
  }, "Tests only: let the waiting long call go on.");
  m.def("_gil_probe_passed", [] {
    Probe& p = probe();
    const std::lock_guard<std::mutex> lock(p.mutex);
    return p.passed;
  }, "Tests only: whether the long call was let go (released by another thread while it held no GIL).");
}

} // namespace gshell::python
