#include "bindings.h"

namespace gshell::python {

void bind_pose(py::module_&) {}

} // namespace gshell::python
