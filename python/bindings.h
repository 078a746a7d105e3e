#pragma once
// One function per part of the library that the module exposes; gshell_module.cpp calls them in
// order (later parts use classes registered by earlier ones).
#include <pybind11/pybind11.h>

#include "interpreter_exit.h"

#include <nlohmann/json.hpp>
#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

namespace gshell::python {

/// Wraps the module's functions and its classes' public methods (and __init__) so that a call
/// pybind11 cannot match raises a TypeError of one line, the signature and the types given,
/// instead of pybind11's, which prints every argument: `generate(V, F, thickness="0.1")` gave
/// 16 KB (every row of V and F). Called last, once the bindings are made.
void shorten_argument_type_errors(pybind11::module_& m);

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

/// The lock of an object whose calls run without the GIL (Deformer, Poser): two Python threads
/// take turns. Its own progress callback runs inside solve(), on the thread holding the lock:
/// a property read or a call from there would wait for itself forever (with Ctrl-C unable to end
/// it), so it raises RuntimeError instead. Another thread waits for the solve to end, and Ctrl-C
/// ends that wait (KeyboardInterrupt).
class ObjectLock {
public:
  explicit ObjectLock(const char* object) : object_(object) {}

  class Held {
  public:
    explicit Held(ObjectLock& lock) : lock_(lock) {
      if (lock_.owner_.load() == std::this_thread::get_id())
        throw std::runtime_error(std::string(lock_.object_) +
                                 " is busy: its solve() is running (a progress callback cannot use the object it "
                                 "reports on)");
      // Called without the GIL. Another thread's solve may hold the lock for minutes: wait in
      // slices and take the GIL between them to let Ctrl-C (KeyboardInterrupt) end the wait.
      while (!lock_.mutex_.try_lock_for(std::chrono::milliseconds(100))) {
        stop_if_interpreter_exiting();
        py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      }
      lock_.owner_ = std::this_thread::get_id();
    }
    ~Held() {
      lock_.owner_ = std::thread::id();
      lock_.mutex_.unlock();
    }
    Held(const Held&) = delete;
    Held& operator=(const Held&) = delete;

  private:
    ObjectLock& lock_;
  };

private:
  const char* object_;
  std::timed_mutex mutex_;
  std::atomic<std::thread::id> owner_{};
};

/// Runs `work` with the GIL released (other Python threads run meanwhile) and `lock` (the
/// object's) held, and returns what it returns; the lock is let go before the GIL is taken back.
template <class Work> auto without_gil_locked(ObjectLock& lock, Work&& work) {
  ReleasedGil release;
  const ObjectLock::Held held(lock);
  return work();
}

} // namespace gshell::python
