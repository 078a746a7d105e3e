#pragma once
// Counting intersecting triangle pairs (docs/design.md "Quality measures"): self-intersections of
// the top surface and intersections between top and base of a shell.
//
// Conventions (all functions):
// - A face is the closed point set of its triangle, so touching (at a point or along an edge)
//   counts as intersecting, as does coplanar overlap. The test is exact (CGAL's exact predicates).
// - A degenerate face (three collinear corners) is taken as the segment or point it covers and
//   tested as such; it is neither skipped nor an error.
// - Faces are compared by their vertex ids; distinct ids at the same position are different
//   vertices, so the mesh should be welded. self_intersecting_pairs never counts two faces that
//   share a vertex id (mesh neighbours), even if they also meet elsewhere (a fold, two fans
//   crossing at their common vertex); surface_self_intersections tests those too and counts every
//   pair that meets anywhere except at the vertices and edges it shares, which is what an
//   embedded surface forbids (docs/validity.md).
// Bad input (a face index out of range, a non-finite coordinate) throws InputError.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <utility>
#include <vector>

namespace gshell {

/// Pairs (f, g), f < g, of faces of one mesh that share no vertex and intersect; sorted.
/// \throws InputError when V is not n x 3 and finite or F not m x 3 with ids in [0, n) (this and
///         every function below).
std::vector<std::pair<int, int>> self_intersecting_pairs(const Eigen::MatrixXd& V,
                                                         const Eigen::MatrixXi& F);

/// Number of pairs of faces that share no vertex and intersect (= self_intersecting_pairs().size()).
int count_self_intersections(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// Pairs (f, g), f < g, of faces of one mesh that intersect anywhere except at the vertices and
/// edges they share; sorted. Sharing one vertex p, they may meet at p only; sharing an edge pq,
/// on the segment pq only (two faces folded flat onto each other across it are counted).
/// \throws InputError also on a face that repeats a vertex id.
std::vector<std::pair<int, int>> surface_self_intersections(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// Pairs (f1, f2), f1 a face of mesh 1 and f2 a face of mesh 2, that intersect; sorted. The two
/// meshes share no vertices (e.g. the top and the base of a shell), so every pair is tested.
std::vector<std::pair<int, int>> intersecting_pairs_between(const Eigen::MatrixXd& V1,
                                                            const Eigen::MatrixXi& F1,
                                                            const Eigen::MatrixXd& V2,
                                                            const Eigen::MatrixXi& F2);

/// Number of intersecting pairs (f1 in mesh 1, f2 in mesh 2) (= intersecting_pairs_between().size()).
int count_intersections_between(const Eigen::MatrixXd& V1, const Eigen::MatrixXi& F1,
                                const Eigen::MatrixXd& V2, const Eigen::MatrixXi& F2);

} // namespace gshell
