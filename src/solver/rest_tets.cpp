#include <gshell/solver/rest_tets.h>

#include <gshell/error.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <cmath>
#include <string>

namespace gshell {

namespace {

// Fills tet t's rest data from its four rest corners; rejects flat or inverted rest shapes
// because the energy divides by them.
void set_rest_shape(RestTets& rest, Eigen::Index t, const Eigen::Vector3d& u0, const Eigen::Vector3d& u1,
                    const Eigen::Vector3d& u2, const Eigen::Vector3d& u3) {
  Eigen::Matrix3d Dm;
  Dm << u1 - u0, u2 - u0, u3 - u0;
  const double det = Dm.determinant();
  if (!(det > 0) || !std::isfinite(det))
    throw InputError("rest tet " + std::to_string(t) + " has non-positive volume (" + std::to_string(det / 6) +
                     ")");
  rest.Dm_inv[t] = Dm.inverse();
  rest.volume[t] = det / 6;
}

} // namespace

RestTets rest_tets_from_positions(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T) {
  if (X.cols() != 3 || T.cols() != 4)
    throw InputError("rest_tets_from_positions: expected N x 3 positions and K x 4 tets (got " +
                     std::to_string(X.rows()) + " x " + std::to_string(X.cols()) + " and " + std::to_string(T.rows()) +
                     " x " + std::to_string(T.cols()) + ")");
  RestTets rest;
  rest.T = T;
  rest.Dm_inv.resize(T.rows());
  rest.volume.resize(T.rows());
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    for (int j = 0; j < 4; ++j)
      if (T(t, j) < 0 || T(t, j) >= X.rows())
        throw InputError("tet " + std::to_string(t) + " has vertex id " + std::to_string(T(t, j)) +
                         " out of range");
    set_rest_shape(rest, t, X.row(T(t, 0)).transpose(), X.row(T(t, 1)).transpose(), X.row(T(t, 2)).transpose(),
                   X.row(T(t, 3)).transpose());
  }
  return rest;
}

RestTets rest_tets_from_corners(const Eigen::MatrixXi& T, const Eigen::MatrixXd& corners) {
  if (T.cols() != 4) throw InputError("rest_tets_from_corners: expected K x 4 tets");
  if (corners.rows() != 4 * T.rows() || corners.cols() != 3)
    throw InputError("rest_tets_from_corners: expected " + std::to_string(4 * T.rows()) + " x 3 corners");
  return rest_tets_from_corner_function(T, [&](Eigen::Index t, const std::array<int, 4>&, TetCorners& U) { U = corners.middleRows(4 * t, 4); });
}

RestTets rest_tets_from_corner_function(Eigen::MatrixXi T,
                                        const std::function<void(Eigen::Index t, const std::array<int, 4>& ids, TetCorners& U)>& corners) {
  if (T.cols() != 4) throw InputError("rest_tets_from_corners: expected K x 4 tets");
  RestTets rest;
  rest.T = std::move(T);
  rest.Dm_inv.resize(rest.T.rows());
  rest.volume.resize(rest.T.rows());
  // TBB rethrows a tet's InputError in this thread.
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, rest.T.rows(), 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
    TetCorners U;
    std::array<int, 4> ids;
    for (Eigen::Index t = r.begin(); t != r.end(); ++t) {
      for (int j = 0; j < 4; ++j) ids[j] = rest.T(t, j);
      corners(t, ids, U);
      set_rest_shape(rest, t, U.row(0).transpose(), U.row(1).transpose(), U.row(2).transpose(), U.row(3).transpose());
    }
  });
  return rest;
}

} // namespace gshell
