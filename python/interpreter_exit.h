#pragma once
// Python threads that are inside a gshell call when the interpreter exits.
//
// CPython (up to 3.13) stops a daemon thread that tries to take the GIL back during finalisation
// by unwinding it with pthread_exit. Unwound through a destructor of ours (the GIL's re-take is
// one), that ends the process with std::terminate; a solve still running meanwhile also races
// OpenBLAS's shutdown (a segfault). So the module counts the calls running without the GIL, and
// at exit (an atexit hook, which runs before finalisation) asks them to stop at their next
// progress check and waits until every one has its GIL back; the stopped threads end quietly
// with SystemExit.
#include <pybind11/pybind11.h>

#include <optional>

namespace gshell::python {

namespace py = pybind11;

/// Thrown, without the GIL, by a long call that sees the interpreter exiting; the module's
/// translator raises SystemExit for it (which a thread ends on without a traceback).
struct InterpreterExiting {};

/// True once the interpreter has begun to exit (the module's atexit hook has run).
bool interpreter_exiting();

/// Without the GIL: throws InterpreterExiting when the interpreter is exiting.
void stop_if_interpreter_exiting();

/// py::gil_scoped_release for gshell's calls, counted: the interpreter's exit waits until the GIL
/// is taken back. Use it for every region that runs without the GIL.
class ReleasedGil {
public:
  ReleasedGil();
  ~ReleasedGil();
  ReleasedGil(const ReleasedGil&) = delete;
  ReleasedGil& operator=(const ReleasedGil&) = delete;

private:
  std::optional<py::gil_scoped_release> release_;
};

/// Registers the atexit hook, the fork handler (a child has none of its parent's other threads)
/// and the translator of InterpreterExiting.
void register_interpreter_exit();

} // namespace gshell::python
