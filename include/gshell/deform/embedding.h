#pragma once
// Detail embedded in a rest shell and carried along by its deformations (paper §4.2, Fig. 8):
// each point is stored as (tet, barycentric coordinates) of the rest shell.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <functional>
#include <vector>

namespace gshell {

struct Embedding {
  Eigen::VectorXi tet;      ///< P: containing tet (nearest tet for outside points)
  Eigen::MatrixXi vertices; ///< P x 4: that tet's vertex ids, so carrying needs no tet list
  Eigen::MatrixXd bary;     ///< P x 4 affine coordinates, each row sums to 1
  /// Points that no tet contains. They are bound to the nearest tet with *extrapolated*
  /// coordinates (some negative), not clamped: the rest pose is still reproduced exactly and the
  /// point follows the nearest tet's affine map, keeping its offset from the shell instead of
  /// being flattened onto the shell's surface.
  std::vector<int> outside;
  double max_outside_distance = 0; ///< largest distance from an outside point to its tet (model units)

  int size() const { return static_cast<int>(tet.size()); }
};

/// Called by embed_points on the calling thread after each block of points: (points located so
/// far, all points). Whatever it throws ends the call (a caller's cancellation).
using EmbedProgress = std::function<void(int located, int total)>;

/// Locates every row of P (P x 3) in the tets T (K x 4) over the rest positions X_rest (N x 3),
/// with a hashed grid (TetLocator), in parallel, in blocks of points (`progress` after each: about
/// 0.2 s of work on two cores; millions of points take seconds).
/// \throws InputError when P is not P x 3 or has a non-finite coordinate, as TetLocator's
///         constructor (X_rest, T shapes and ids), or when every tet is flat (TetLocator); whatever
///         `progress` throws.
Embedding embed_points(const Eigen::MatrixXd& X_rest, const Eigen::MatrixXi& T, const Eigen::MatrixXd& P,
                       const EmbedProgress& progress = {});

/// Positions of the embedded points for deformed shell vertices X (same vertex ids as X_rest):
/// row p = sum_k bary(p,k) * X(vertices(p,k)).
/// \throws InputError when X is not N x 3 with a row for every vertex the embedding uses.
Eigen::MatrixXd carry(const Embedding& embedding, const Eigen::MatrixXd& X);

} // namespace gshell
