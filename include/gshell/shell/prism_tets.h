#pragma once
// Cutting prisms into tets by the min-index rule (docs/design.md "Prisms and tets").
#include <gshell/solver/rest_tets.h>
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <array>

namespace gshell {

/// Shell vertex ids: base vertex i is i, top vertex i is n + i.
/// Returns 3m x 4 tets, tets 3f..3f+2 belonging to face f, each positively oriented when the
/// top lies on the side of the face normal (counter-clockwise faces). Every side quad with base
/// ids i < j is cut along base(i)-top(j), so neighbouring prisms agree on the diagonal.
/// \throws InputError when F is not m x 3 with ids in [0, n).
Eigen::MatrixXi build_prism_tets(const Eigen::MatrixXi& F, int n);

/// The three tets of the prism over a face with vertex ids (v0, v1, v2), as prism corners 0..5
/// (0..2 the base corners in this order, 3..5 the tops above them), by the min-index rule on the
/// ids: rows 3f..3f+2 of prism_tet_corners for F.row(f) = (v0, v1, v2).
std::array<std::array<int, 4>, 3> prism_corner_tets(int v0, int v1, int v2);

/// Same tets, each vertex given as a prism corner 0..5 of its face: 0..2 base corners in the
/// face's own order (F(f,0..2)), 3..5 the top corners above them. Row t matches build_prism_tets.
/// \throws InputError when F is not m x 3.
Eigen::MatrixXi prism_tet_corners(const Eigen::MatrixXi& F);

/// Rest tets of the shell over 2n vertices (build_prism_tets) whose rest shapes are the given
/// per-face prisms (6m x 3, layout of ideal_prisms.h: rows 6f..6f+2 base corners in face order,
/// 6f+3..6f+5 the top corners). Each prism is its own rest shape ("cracked" ideal prisms).
/// \throws InputError when F is not m x 3 with ids in [0, n), prisms is not 6m x 3, or a rest tet
///         has non-positive volume (a prism turned inside out).
RestTets prism_rest_tets(const Eigen::MatrixXi& F, int n, const Eigen::MatrixXd& prisms);

/// The rest tets of prism_rest_tets(F, n, normal_prisms(V, F, eta)) (n = V.rows()) in RestTets'
/// affine-prism form: per face the inverse of [b - a, c - a, eta n] and per tet its corners in
/// the unit prism, no per-tet matrices and no 6m x 3 corner matrix. dm_inv(t) agrees with the
/// per-tet form to rounding (not bit for bit: the inverse is taken once per prism); the volumes
/// are the prism's third, det [b - a, c - a, eta n] / 6.
/// \throws InputError when V is not n x 3, F not m x 3 with ids in [0, n), eta is not finite, or
///         a rest tet has non-positive volume (a face of zero area, or eta <= 0).
RestTets normal_prism_rest_tets(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta);

} // namespace gshell
