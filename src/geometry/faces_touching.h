#pragma once
// Internal: the faces with a corner among flagged vertices. The guards leave such one-rings of
// faces out around what no top can mend (unextrudable vertices, the base's crossings, pairs
// intersecting or touching to rounding at rest); generation and the deformation frames use these
// same helpers, so that both leave out the same faces for the same cause.
#include <Eigen/Core>

#include <utility>
#include <vector>

namespace gshell::detail {

/// Per face of F: whether one of its corners is flagged in `vertex_flag` (one per vertex).
inline std::vector<char> faces_touching(const Eigen::MatrixXi& F, const std::vector<char>& vertex_flag) {
  std::vector<char> face(static_cast<std::size_t>(F.rows()), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    face[f] = vertex_flag[F(f, 0)] || vertex_flag[F(f, 1)] || vertex_flag[F(f, 2)];
  return face;
}

/// The same for the vertices listed in `vertices` (ids in [0, n); repeats allowed).
inline std::vector<char> faces_touching(const Eigen::MatrixXi& F, int n, const std::vector<int>& vertices) {
  std::vector<char> flag(static_cast<std::size_t>(n), 0);
  for (int v : vertices) flag[v] = 1;
  return faces_touching(F, flag);
}

/// The faces sharing a vertex with a face of one of `crossings` (pairs of faces of F over n
/// vertices that cross each other): where no top over a base crossing itself can be clean.
inline std::vector<char> faces_around_crossings(const Eigen::MatrixXi& F, int n,
                                                const std::vector<std::pair<int, int>>& crossings) {
  std::vector<char> corner(static_cast<std::size_t>(n), 0);
  for (const auto& [f, g] : crossings)
    for (int k = 0; k < 3; ++k) corner[F(f, k)] = corner[F(g, k)] = 1;
  return faces_touching(F, corner);
}

} // namespace gshell::detail
