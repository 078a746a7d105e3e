#pragma once
// A shortcut for the adjacency-aware pair tests: on a smooth closed surface most neighbouring
// triangles are settled at once by showing that the whole star of a vertex is embedded.
#include <Eigen/Core>
#include <vector>

namespace gshell::detail {

/// Per vertex of (V, F): 1 when its faces form a single closed fan whose projection onto a
/// coordinate plane is one-to-one, shown exactly (every projected face positively oriented, by
/// exact orient2d, and the fan winding once around the vertex, by exact coordinate comparisons
/// and orient2d). Then any two faces of the star meet only at the vertices and edges they share,
/// and pairs sharing this vertex need no test. 0 otherwise: boundary or non-manifold vertices,
/// folded or twisted stars, faces with repeated or out-of-range ids (the pair tests decide those).
/// A coordinate projection is exact (it only drops a coordinate), hence no rounding enters.
std::vector<char> embedded_stars(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// The same for the 2n vertices of a shell's boundary surface (shell_boundary): base vertex i
/// (id i) from its star in (base, F), top vertex i (id n + i) from its star in (top, F). Walls
/// touch only boundary vertices, whose stars in F are not closed fans, so they are never flagged.
/// Without `base_stars` the base vertices are left 0 (when no base/base pair is tested, no other
/// pair shares a flaggable base vertex).
std::vector<char> embedded_shell_stars(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                       const Eigen::MatrixXi& F, bool base_stars);

} // namespace gshell::detail
