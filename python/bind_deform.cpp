#include "bindings.h"

namespace gshell::python {

void bind_deform(py::module_&) {}

} // namespace gshell::python
