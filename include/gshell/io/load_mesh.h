#pragma once
#include <gshell/mesh.h>
#include <string>

namespace gshell {

/// The one entry point for surface inputs of subcommands: a `builtin:...` spec or a file path.
/// The result is validated (require_valid_mesh).
/// \throws InputError naming the input when it cannot be read (read_mesh, make_builtin) or is
///         not a valid mesh (require_valid_mesh).
TriMesh load_mesh(const std::string& input);

} // namespace gshell
