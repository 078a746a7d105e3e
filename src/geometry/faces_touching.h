#pragma once
// Internal: the faces with a corner among flagged vertices. The guards leave such one-rings of
// faces out around what no top can mend (unextrudable vertices, the base's crossings, pairs
// intersecting or touching to rounding at rest).
#include <Eigen/Core>

#include <vector>

namespace gshell::detail {

/// Per face of F: whether one of its corners is flagged in `vertex_flag` (one per vertex).
inline std::vector<char> faces_touching(const Eigen::MatrixXi& F, const std::vector<char>& vertex_flag) {
  std::vector<char> face(static_cast<std::size_t>(F.rows()), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f) face[f] = vertex_flag[F(f, 0)] || vertex_flag[F(f, 1)] || vertex_flag[F(f, 2)];
  return face;
}

} // namespace gshell::detail
