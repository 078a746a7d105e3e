#pragma once
#include <gshell/mesh.h>
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

namespace gshell {

/// Optional per-vertex / per-face data written alongside a surface (PLY only; OBJ/OFF ignore it,
/// except that OFF writes per-face colors as COFF-style face colors where possible).
struct MeshAttributes {
  using Colors = Eigen::Matrix<unsigned char, Eigen::Dynamic, 3>;
  Colors vertex_colors;                                             ///< n x 3 RGB, or empty
  Colors face_colors;                                               ///< m x 3 RGB, or empty
  std::vector<std::pair<std::string, Eigen::VectorXd>> vertex_scalars; ///< name, n values
  std::vector<std::pair<std::string, Eigen::VectorXd>> face_scalars;   ///< name, m values
};

/// What write_mesh checks of `path` first, for commands to check before their work.
/// \throws InputError naming `path` when its extension is not .obj, .off or .ply (any case).
void check_mesh_output_format(const std::string& path);

/// Writes OBJ (with vt when the mesh has UVs), OFF or PLY (binary little endian unless
/// `ascii_ply`), chosen by extension. Atomic (temporary file + rename). Vertex order is kept.
/// \throws InputError naming `path` on an unknown extension (also .stl: it cannot keep vertex
///         order) or an unwritable path; InputError naming the argument when the mesh has no
///         vertices (the readers refuse such a file) or the mesh or the
///         attributes are inconsistent (sizes, indices, PLY property names that are not one word
///         [A-Za-z0-9_.-] or clash). Nothing is written then.
void write_mesh(const std::string& path, const TriMesh& mesh, const MeshAttributes& attributes = {},
                bool ascii_ply = false);

} // namespace gshell
