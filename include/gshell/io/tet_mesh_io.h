#pragma once
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

namespace gshell {

/// A tetrahedral mesh with named data arrays (each array: one row per point or per cell, 1 or 3
/// columns), as written for ParaView.
struct TetMesh {
  Eigen::MatrixXd X; ///< N x 3 points
  Eigen::MatrixXi T; ///< K x 4 point ids, positively oriented
  std::vector<std::pair<std::string, Eigen::MatrixXd>> point_data;
  std::vector<std::pair<std::string, Eigen::MatrixXd>> cell_data;
};

/// `.vtu` (VTK XML UnstructuredGrid, appended raw binary, readable by ParaView) or `.mesh`
/// (MEDIT ASCII; data arrays are dropped, the cell reference is 1). Atomic.
/// \throws InputError naming `path` on another extension or when it cannot be written; InputError
///         naming the argument when X is not N x 3, T not K x 4, a tet id is out of range or a
///         data array is unnamed or has the wrong shape. Nothing is written then.
void write_tet_mesh(const std::string& path, const TetMesh& mesh);

/// Reads back a `.vtu` written by write_tet_mesh (tetrahedra only) or a MEDIT `.mesh`.
/// \throws InputError naming `path` when it is missing, of another extension or malformed.
TetMesh read_tet_mesh(const std::string& path);

} // namespace gshell
