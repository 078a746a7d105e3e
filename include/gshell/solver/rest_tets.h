#pragma once
// Per-tet rest shapes for the deformation energy (docs/design.md "The energy").
#include <Eigen/Core>
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

} // namespace gshell
