#pragma once
// Reading a command's surface input: load_mesh, with what its validation warns of (cuts, unused
// vertices) printed on stderr, whatever --quiet says, as generate and convert print theirs.
#include <gshell/mesh.h>

#include <string>
#include <vector>

namespace gshell::cli {

/// load_mesh(input), printing each warning as "gshell COMMAND: warning: ..." (and appending them
/// to `warnings` if given, for a report).
/// \throws InputError as load_mesh.
TriMesh load_surface(const std::string& input, const std::string& command,
                     std::vector<std::string>* warnings = nullptr);

} // namespace gshell::cli
