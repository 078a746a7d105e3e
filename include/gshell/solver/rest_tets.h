#pragma once
// Per-tet rest shapes for the deformation energy (docs/design.md "The energy").
#include <Eigen/Core>
#include <array>
#include <functional>
#include <vector>

namespace gshell {

/// Rest shapes of K tets over a vertex set. Each tet has its own rest shape, so "cracked"
/// ideal prisms and a seamless rest shell are the same data.
struct RestTets {
  Eigen::MatrixXi T;                       ///< K x 4 global vertex ids
  std::vector<Eigen::Matrix3d> Dm_inv;     ///< inverse rest edge matrix [u1-u0, u2-u0, u3-u0]^-1
  Eigen::VectorXd volume;                  ///< rest volumes (> 0)
  int size() const { return static_cast<int>(T.rows()); }
};

/// Rest shapes taken from positions X (N x 3) of the tets T itself (deformation: the rest shell).
/// \throws InputError when X is not N x 3, T not K x 4, a tet id is outside [0, N) or a tet has
///         non-positive (or non-finite) rest volume.
RestTets rest_tets_from_positions(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T);

/// Rest shapes given per tet corner: corners is 4K x 3, rows 4t..4t+3 the rest positions of tet
/// t's vertices T(t,0..3).
/// \throws InputError when T is not K x 4, corners not 4K x 3, or a tet has non-positive (or
///         non-finite) rest volume.
RestTets rest_tets_from_corners(const Eigen::MatrixXi& T, const Eigen::MatrixXd& corners);

/// Row j of a tet's 4 x 3 rest corners: the rest position of its vertex T(t, j).
using TetCorners = Eigen::Matrix<double, 4, 3, Eigen::RowMajor>;

/// The same with the corners made per tet by `corners(t, ids, U)` (ids = row t of T; called
/// concurrently for different t), so that no 4K x 3 corner matrix is held: at millions of tets it would be the largest
/// temporary of the setup.
/// \throws InputError when T is not K x 4 or a tet has non-positive (or non-finite) rest volume;
///         whatever `corners` throws.
RestTets rest_tets_from_corner_function(Eigen::MatrixXi T,
                                        const std::function<void(Eigen::Index t, const std::array<int, 4>& ids, TetCorners& U)>& corners);

} // namespace gshell
