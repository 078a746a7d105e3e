#pragma once
#include <gshell/mesh.h>
#include <string>

namespace gshell {

/// The one entry point for surface inputs of subcommands: a `builtin:...` spec or a file path.
/// The result is validated (require_valid_mesh); errors throw InputError naming the input.
TriMesh load_mesh(const std::string& input);

} // namespace gshell
