#include "bindings.h"

namespace gshell::python {

void bind_generate(py::module_&) {}

} // namespace gshell::python
