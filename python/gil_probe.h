#pragma once
// A probe for the test that long calls release the GIL (python/tests, GilTest): armed from
// Python, a long call stops at it while it holds no GIL and waits until another Python thread
// (which can only run if the GIL is free) lets it go. Unarmed it costs one atomic load.
#include <pybind11/pybind11.h>

namespace gshell::python {

/// Called by long calls inside their GIL-released part.
void pass_gil_probe();

/// gshell._gil_probe_arm(), _gil_probe_wait_entered(timeout), _gil_probe_release(), _gil_probe_passed().
void bind_gil_probe(pybind11::module_& m);

} // namespace gshell::python
