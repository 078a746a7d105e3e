#pragma once
// The triangle surface every part of gshell works on.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <string>

namespace gshell {

/// A triangle mesh with optional texture coordinates, in the libigl convention.
/// Vertex i is row i of V; the order is kept by every reader, writer and algorithm, because the
/// top surface and the shell's tets index vertices by it (top vertex i sits over base vertex i).
struct TriMesh {
  Eigen::MatrixXd V;   ///< n x 3 positions (model units)
  Eigen::MatrixXi F;   ///< m x 3 vertex ids per face, counter-clockwise seen from the outside
  Eigen::MatrixXd UV;  ///< k x 2 texture coordinates; empty when the mesh has none
  Eigen::MatrixXi FUV; ///< m x 3 ids into UV per face corner; empty when the mesh has none

  int num_vertices() const { return static_cast<int>(V.rows()); }
  int num_faces() const { return static_cast<int>(F.rows()); }
  bool has_uv() const { return UV.rows() > 0 && FUV.rows() == F.rows(); }
};

} // namespace gshell
