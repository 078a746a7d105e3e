#pragma once
// Reading a command's inputs: a surface by load_mesh, with what its validation warns of (cuts,
// unused vertices), and a rest shell with what its report says is wrong with it, printed on
// stderr whatever --quiet says, as generate and convert print theirs.
#include <gshell/mesh.h>

#include <string>

namespace gshell::cli {

/// load_mesh(input), printing each warning as "gshell COMMAND: warning: ...".
/// \throws InputError as load_mesh.
TriMesh load_surface(const std::string& input, const std::string& command);

/// Warns that the rest shell in folder `shell` is not valid when `faults` (reported_shell_faults
/// of its report) is not empty: the guard leaves those places out, so a `result` (a pose step, a
/// frame) may stay invalid there, and the user learns why before the first one is reported so.
void warn_invalid_rest_shell(const std::string& shell, const std::string& faults, const std::string& result);

} // namespace gshell::cli
