#pragma once
#include <gshell/mesh.h>
#include <string>
#include <vector>

namespace gshell {

/// The one entry point for surface inputs of subcommands: a `builtin:...` spec or a file path.
/// The result is validated (require_valid_mesh); `warnings` (if not null) receives what reading
/// (read_mesh) and the validation warn of, one line per kind, each naming the input.
/// `skipped`: as read_mesh's (nothing for a builtin).
/// \throws InputError naming the input when it cannot be read (read_mesh, make_builtin) or is
///         not a valid mesh (require_valid_mesh).
TriMesh load_mesh(const std::string& input, std::vector<std::string>* warnings = nullptr,
                  std::vector<std::string>* skipped = nullptr);

/// The same input, read (make_builtin or read_mesh, whose warnings go to `warnings`) but not
/// validated as a surface: for meshes checked for their own use (deformation frames, embedded
/// detail, a shell's top in metrics).
/// \throws InputError naming the input when it cannot be read.
TriMesh read_mesh_or_builtin(const std::string& input, std::vector<std::string>* warnings = nullptr,
                             std::vector<std::string>* skipped = nullptr);

/// "INPUT: its normals and materials are not carried into OUTPUT (positions, faces and texture
/// coordinates are)", for a mesh carried into an output (embedded detail, a texture tile) whose
/// reading skipped that data (read_mesh's `skipped`, not empty). Texture coordinates are named
/// carried only into an OBJ output, the one format that holds them.
std::string carried_data_warning(const std::string& input, const std::vector<std::string>& skipped,
                                 const std::string& output);

/// "INPUT: its texture coordinates are not written to OUTPUT (only OBJ holds them)" when `mesh`
/// (or what is made from it) has texture coordinates and OUTPUT is not an OBJ; else "".
std::string dropped_texture_coordinates_warning(const std::string& input, const TriMesh& mesh,
                                                const std::string& output);

} // namespace gshell
